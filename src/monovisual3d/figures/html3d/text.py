"""User text shown as text: plotly renders a subset of HTML in titles, labels and hover texts.

A detection label, an image name or a session file name comes from a file someone else may have
made; escaped here, ``<a href=...>`` or ``<span style=...>`` in it is shown as written instead of
becoming a link or restyling the page.
"""

from __future__ import annotations


def plain_text(text: object) -> str:
    """``str(text)`` with ``&``, ``<`` and ``>`` escaped as HTML entities, which plotly shows as the characters.

    Examples
    --------
    >>> plain_text('<a href="https://x">fruit</a> & co')
    '&lt;a href="https://x"&gt;fruit&lt;/a&gt; &amp; co'
    """
    return str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
