"""The session: camera, views (pose + detections) and optional workspace.

A session is the input contract of :func:`monovisual3d.localize`. It is read from JSON or YAML (same
structure), validated on load, and every problem is reported as one line that names the file, the JSON
path and what was expected, for example ``session.json: views[3].pose.quaternion_xyzw: norm 0.71, expected 1``.

- :mod:`.model`: the frozen dataclasses :class:`Session`, :class:`View`, :class:`Detection`, :class:`Workspace`
  (core: every layer may use them);
- :mod:`.load`: the loader, ``dict`` or file -> :class:`Session` (:func:`~.load.load_session`);
- :mod:`.baseline`: the loader's warnings about view geometry that cannot triangulate depth (one view, one
  pose, too small a baseline);
- :mod:`.diagnose`: the input checks that name an integration mistake (boxes not in pixels or of another image,
  pose conventions, duplicated views, one pose, distortion coefficients), :func:`~.diagnose.check_session`;
  :mod:`.rays`: their test of whether box-centre rays of two views meet as one fruit would.

The whole package is core: it imports nothing above it.

See ``docs/formats.md`` for the full description.
"""

from __future__ import annotations

from .model import Detection, Session, View, Workspace

__all__ = ["Detection", "Session", "View", "Workspace"]
