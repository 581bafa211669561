"""The one validation module: numbers, vectors, arrays, positions, quaternion norms and byte sizes, each failing with one line."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from monovisual3d.checks import (
    as_array,
    as_float,
    as_int,
    check_position,
    check_quaternion_xyzw,
    finite_array,
    finite_number,
    format_bytes,
    is_int,
    is_real,
    parse_bytes,
    vector,
)
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


def test_is_int_takes_python_and_numpy_integers_only() -> None:
    assert [is_int(v) for v in (3, np.int64(3), np.uint8(3), 3.0, True, np.bool_(False), "3")] == [
        True,
        True,
        True,
        False,
        False,
        False,
        False,
    ]


def test_numbers_refuse_bools_text_and_non_finite_values_naming_the_path() -> None:
    assert finite_number(np.float32(0.5), "a.b") == 0.5
    with pytest.raises(InputError, match=r"^a\.b: expected a number, got True$"):
        finite_number(True, "a.b")
    with pytest.raises(InputError, match=r"^a\.b: got 2e\+06, beyond the 1e\+06 m accepted$"):
        finite_number(2e6, "a.b", 1e6, "m")
    with pytest.raises(InputError, match=r"too large for a number"):
        finite_number(10**400, "a.b")


def test_table_cells_may_be_numeric_text() -> None:
    assert as_float(" 1.5 ", "row 2: x") == 1.5
    assert as_int("7", "row 2: n", minimum=1) == 7
    with pytest.raises(InputError, match=r"^row 2: x: expected a number, got 'one'$"):
        as_float("one", "row 2: x")
    with pytest.raises(InputError, match=r"^row 2: x: got inf, expected a finite number$"):
        as_float("inf", "row 2: x")
    with pytest.raises(InputError, match=r"^row 2: n: expected an integer, got 1\.5$"):
        as_int(1.5, "row 2: n")


def test_vectors_name_the_bad_element() -> None:
    assert_allclose(vector(np.array([1, 2, 3]), 3, "p"), [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match=r"^p: expected 3 numbers, got 2$"):
        vector([1, 2], 3, "p")
    with pytest.raises(InputError, match=r"^p\[1\]: expected a number, got '2'$"):
        vector([1, "2", 3], 3, "p")


def test_arrays_by_shape_and_by_size() -> None:
    assert finite_array([[1, 0], [0, 1]], (2, 2), "m").shape == (2, 2)
    assert as_array([1, 0, 0, 1], "k", shape=(2, 2)).shape == (2, 2)  # a flat list is reshaped; finite_array does not
    with pytest.raises(InputError, match=r"^m: expected shape \[2, 2\], got \[4\]$"):
        finite_array([1, 0, 0, 1], (2, 2), "m")
    with pytest.raises(InputError, match=r"^k: expected a list of numbers, got True in \[1, True\]$"):
        as_array([1, True], "k")
    for check in (lambda v: finite_array(v, (2,), "v"), lambda v: as_array(v, "v")):
        with pytest.raises(InputError, match=r"^v: got \[an integer of 401 digits, 1\], a number too large$"):
            check([10**400, 1])
        with pytest.raises(InputError, match=r"^v: contains NaN or infinity$"):
            check([np.nan, 1.0])


def test_positions_and_quaternions() -> None:
    check_position(np.array([1.0, -2.0, 3.0]), "p")
    with pytest.raises(InputError, match=r"^p: coordinate 2e\+06 m, beyond the 1e\+06 m accepted \(wrong units\?\)$"):
        check_position(np.array([0.0, -2e6, 0.0]), "p")
    assert_allclose(check_quaternion_xyzw([0, 0, 0, 1.0005]), [0, 0, 0, 1])
    with pytest.raises(InputError, match=r"^q: norm 2, expected 1 \(order is x, y, z, w\)$"):
        check_quaternion_xyzw([0, 0, 0, 2], where="q")
