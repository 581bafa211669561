"""Byte sizes as text (:func:`parse_bytes`, :func:`format_bytes`) and the number check they use."""

from __future__ import annotations

import numpy as np
import pytest

from monovisual3d.checks import format_bytes, is_real, parse_bytes
from monovisual3d.errors import InputError
from monovisual3d.limits import MAX_PARSED_BYTES, MIN_MAX_MEMORY


@pytest.mark.parametrize(
    ("text", "expected"),
    [("2GiB", 2 * 1024**3), ("512 MB", 512 * 1000**2), ("1.5g", 1_500_000_000), ("1e9", 10**9), (" 64 mib ", 64 * 1024**2)],
)
def test_parse_bytes_reads_si_and_binary_units(text: str, expected: int) -> None:
    assert parse_bytes(text) == expected


def test_parse_bytes_takes_numbers_and_caps_them() -> None:
    assert parse_bytes(np.float32(2**30)) == 2**30
    assert parse_bytes(1e30) == MAX_PARSED_BYTES


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("2 parsecs", "expected a size in bytes such as 2GiB"),
        (True, "got bool"),
        ([1], "got list"),
        (MIN_MAX_MEMORY - 1, "expected at least 16 MiB"),
        (float("nan"), "expected at least"),
        ("-1GiB", "expected a size"),
    ],
)
def test_parse_bytes_refuses_bad_sizes_naming_the_field(value: object, message: str) -> None:
    with pytest.raises(InputError, match=f"^budget: .*{message}"):
        parse_bytes(value, "budget")


def test_format_bytes_reads_back() -> None:
    assert [format_bytes(n) for n in (512, 1536, 3 * 1024**2, 1.5 * 1024**3)] == ["512 B", "1.5 KiB", "3.0 MiB", "1.5 GiB"]
    for text in ("64.0 MiB", "1.5 GiB", "300.0 MiB"):
        assert format_bytes(parse_bytes(text.replace(" ", ""))) == text


def test_is_real_excludes_bools_and_strings() -> None:
    assert [is_real(v) for v in (1, 2.5, np.float64(1), np.int8(3), True, np.bool_(True), "1", None)] == [
        True,
        True,
        True,
        True,
        False,
        False,
        False,
        False,
    ]
