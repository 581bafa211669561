"""rerun recordings (extra ``[rerun]``): cameras, boxes and fruit end up in the .rrd file; skipped without rerun-sdk."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

pytest.importorskip("rerun", reason="rerun-sdk not installed (extra [rerun])")
pytest.importorskip("plotly")  # rerun_log reuses the 3D view's readers of results
from rerun.chunk import RrdReader  # noqa: E402

from figures.html3d_cases import result_dict, truth_dict, two_fruit_session  # noqa: E402
from monovisual3d.rerun_log import write_rrd  # noqa: E402


def columns(path: Path) -> dict[str, dict[str, list]]:
    """entity path -> column name -> first row's value, over every chunk of the file's recording."""
    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(path).store().stream():
        rb = chunk.to_record_batch()
        cols = out.setdefault(chunk.entity_path, {})
        for name in rb.schema.names:
            cols[name] = rb.column(rb.schema.get_field_index(name)).to_pylist()[0]
    return out


def test_recording_holds_cameras_boxes_fruit_and_truth(tmp_path: Path) -> None:
    path = write_rrd(two_fruit_session(), result_dict(), truth_dict(), path=tmp_path / "sub" / "s.rrd")
    data = columns(path)
    for i in range(3):
        cam = data[f"/world/views/{i:02d}"]
        assert "Pinhole:image_from_camera" in cam and "Transform3D:translation" in cam
        assert len(data[f"/world/views/{i:02d}/boxes"]["Boxes2D:centers"]) == 2
    T0 = np.array(two_fruit_session()["views"][0]["pose"]["matrix"])
    assert_allclose(np.reshape(data["/world/views/00"]["Transform3D:translation"], 3), T0[:3, 3], atol=1e-6)
    assert_allclose(np.reshape(data["/world/views/00"]["Pinhole:resolution"], 2), [640, 480])
    fruit = data["/world/fruit"]
    assert_allclose(fruit["Ellipsoids3D:centers"], [o["position"] for o in result_dict()["objects"]], atol=1e-6)
    assert_allclose(fruit["Ellipsoids3D:half_sizes"][1], [0.03, 0.02, 0.02], atol=1e-7)  # semi_axes
    assert len(data["/world/fruit_error_95"]["Ellipsoids3D:centers"]) == 1  # only fruit 0 has a covariance
    assert len(data["/world/truth"]["Ellipsoids3D:centers"]) == 2


def test_bad_session_is_rejected(tmp_path: Path) -> None:
    from monovisual3d.errors import InputError

    with pytest.raises(InputError, match=r"views: empty"):
        write_rrd({"camera": {"width": 640, "height": 480, "hfov_deg": 69}, "views": []}, path=tmp_path / "x.rrd")


def test_view_command_writes_the_recording(tmp_path: Path) -> None:
    import json

    from typer.testing import CliRunner

    from monovisual3d.cli import app

    session = tmp_path / "session.json"
    session.write_text(json.dumps(two_fruit_session()))
    out = tmp_path / "s.rrd"
    r = CliRunner().invoke(app, ["view", str(session), "-o", str(tmp_path / "s.html"), "--rrd", str(out)])
    assert r.exit_code == 0, r.output
    assert "/world/views/02/boxes" in columns(out)
    r = CliRunner().invoke(app, ["view", str(session), "-o", str(tmp_path / "s.html"), "--rrd", str(tmp_path / "s.txt")])
    assert r.exit_code == 2 and "--rrd: got" in r.output
