"""Regression tests of issue 13: each hostile input class ends in one exact error line (or a warning), never a traceback.

One minimal input per class, found by the fuzz suite (``tests/fuzz``); the error
line is asserted in full, so a change of wording is a deliberate change here.
"""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from monovisual3d import InputError, InputWarning, load_session
from monovisual3d.checks import as_array
from monovisual3d.cli import app
from monovisual3d.errors import excerpt, one_line
from monovisual3d.examples import example_session_path
from monovisual3d.grid import VoxelGrid
from monovisual3d.truth import load_objects

HUGE = "1" + "0" * 400  # a JSON integer no float can hold


@pytest.fixture
def example() -> dict[str, Any]:
    return json.loads(example_session_path().read_text())


def write(tmp_path: Path, text: str | bytes, name: str = "s.json") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def error_of(source: Any) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        with pytest.raises(InputError) as info:
            load_session(source)
    return str(info.value)


def cli_error(args: list[str]) -> str:
    """The single stderr line of a CLI run that must exit 2."""
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    return lines[0].removeprefix("error: ")


# ---------------------------------------------------------------------- 1. huge integers
@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('"hfov_deg": 69.0', f'"hfov_deg": {HUGE}', "camera.hfov_deg: got an integer of 401 digits, too large for a number"),
        (
            '"height": 480',
            f'"height": {HUGE}',
            "camera.height: got an integer of 401 digits, more than the 32768 pixels accepted",
        ),
        (
            "288.891",
            HUGE,
            "views[0].detections[0].bbox_xyxy[0]: got an integer of 401 digits, too large for a number",
        ),
        (
            "-0.5",
            HUGE,
            "views[0].pose.quaternion_xyzw: got [an integer of 401 digits, 0.5, -0.5, 0.5], a number too large",
        ),
    ],
)
def test_huge_json_integers(tmp_path: Path, example: dict[str, Any], old: str, new: str, message: str) -> None:
    text = json.dumps(example)
    assert old in text
    path = write(tmp_path, text.replace(old, new, 1))
    assert error_of(path) == f"{path}: {message}"


def test_huge_integer_in_evaluate(tmp_path: Path) -> None:
    path = write(tmp_path, f'{{"objects": [{{"position": [{HUGE}, 0, 0]}}]}}', "e.json")
    with pytest.raises(InputError) as info:
        load_objects(path)
    assert str(info.value) == f"{path}: objects[0].position[0]: got an integer of 401 digits, too large for a number"


# ---------------------------------------------------------------------- 2. deep nesting
@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("s.json", "not valid JSON: nested deeper than 64 levels"),
        ("s.yaml", "not valid YAML at line 1, column 65: nested deeper than 64 levels"),
    ],
)
def test_deep_nesting(tmp_path: Path, name: str, message: str) -> None:
    path = write(tmp_path, "[" * 5000 + "]" * 5000, name)
    assert error_of(path) == f"{path}: {message}"
    with pytest.raises(InputError, match="nested deeper than 64 levels"):
        load_objects(path)


def test_nesting_within_python_limits_but_too_deep_names_the_path(tmp_path: Path) -> None:
    path = write(tmp_path, '{"metadata": ' + "[" * 70 + "]" * 70 + "}")
    assert error_of(path) == f"{path}: metadata" + "[0]" * 62 + ": nested deeper than 64 levels"


# ---------------------------------------------------------------------- 3. YAML alias bombs, tags
def _bomb(levels: int) -> str:
    lines = ['a0: &a0 ["x","x","x","x","x","x","x","x","x","x"]']
    lines += [f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, levels + 1)]
    return "metadata:\n" + "".join(f"  {line}\n" for line in lines)


def test_yaml_alias_bomb_is_refused_quickly(tmp_path: Path, example: dict[str, Any]) -> None:
    text = _bomb(9) + yaml.safe_dump(example).replace("hfov_deg: 69.0", "hfov_deg: *a9")
    path = write(tmp_path, text, "s.yaml")
    assert error_of(path) == f"{path}: metadata.a6: more than 5,000,000 values (YAML aliases expanded), the most accepted"


def test_small_alias_bomb_error_is_short(tmp_path: Path, example: dict[str, Any]) -> None:
    # 10**5 values: under the size limit, so the loader reaches the field; the message quotes an excerpt only
    text = _bomb(4) + yaml.safe_dump(example).replace("label: tomato", "label: *a4", 1)
    path = write(tmp_path, text, "s.yaml")
    msg = error_of(path)
    assert msg.startswith(f"{path}: views[0].detections[0].label: expected a class name (text), got [[[[['x', 'x'")
    assert len(msg) <= 300


def test_recursive_alias(tmp_path: Path) -> None:
    path = write(tmp_path, "camera: &c [*c]\nviews: []\n", "s.yaml")
    assert error_of(path) == f"{path}: camera[0]: refers to itself (recursive alias)"


@pytest.mark.parametrize(
    ("tag", "shown"),
    [
        ("!!python/object:os.system", "'tag:yaml.org,2002:python/object:os.system'"),
        ("!!binary", "'tag:yaml.org,2002:binary'"),
        ("!!str", "'tag:yaml.org,2002:str'"),
        ("!custom", "'!custom'"),
    ],
)
def test_yaml_tags_are_refused(tmp_path: Path, tag: str, shown: str) -> None:
    path = write(tmp_path, f"camera: {tag} x\nviews: []\n", "s.yaml")
    assert (
        error_of(path) == f"{path}: not valid YAML at line 1, column 9: tag {shown} is not accepted (YAML tags are not supported)"
    )


# ---------------------------------------------------------------------- 4. masks and image size
def test_huge_rle_mask_is_refused_without_decoding(tmp_path: Path, example: dict[str, Any]) -> None:
    example["camera"].update(width=100000, height=100000)
    example["views"][0]["detections"][0]["mask"] = {"size": [100000, 100000], "counts": [0, 10000000000]}
    path = write(tmp_path, json.dumps(example))
    assert error_of(path) == f"{path}: camera.width: got 100000, more than the 32768 pixels accepted"


def test_image_pixel_count_is_bounded(example: dict[str, Any]) -> None:
    example["camera"].update(width=10000, height=10000)
    assert error_of(example) == "camera: a 10000x10000 image, more than the 67,108,864 pixels accepted"


def test_rle_mask_is_checked_run_by_run(example: dict[str, Any]) -> None:
    example["views"][0]["detections"][0]["mask"] = {"size": [480, 640], "counts": [480 * 640]}
    assert error_of(example) == "views[0].detections[0].mask.counts: the mask is empty, expected the detection's pixels"
    example["views"][0]["detections"][0]["mask"] = {"size": [480, 640], "counts": [1, 10**30]}
    assert error_of(example) == (
        "views[0].detections[0].mask.counts: run lengths sum to a number too large, expected height*width = 307200"
    )


# ---------------------------------------------------------------------- 5. grid-size guard
def test_huge_workspace_is_a_grid_size_error_for_the_paper_method(example: dict[str, Any]) -> None:
    from monovisual3d import localize

    example["workspace"] = {"min": [-1e5] * 3, "max": [1e5] * 3}
    with pytest.raises(InputError, match=r"^workspace: a \d+ mm grid has [0-9.e+]+ cells \(.*\) and needs about .* GiB") as info:
        localize(example, method="paper")
    assert info.value.args[0].endswith("or use a smaller workspace or a larger max_memory")


def test_huge_workspace_is_searched_coarse_to_fine_by_bayes(example: dict[str, Any]) -> None:
    from monovisual3d import localize

    example["workspace"] = {"min": [-1e5] * 3, "max": [1e5] * 3}
    result = localize(example)  # the first search level coarsens until it fits; nothing is allocated densely
    assert len(result.objects) == 1 and result.diagnostics["start_cell_size"] > 1000


def test_grid_guard_counts_in_python_integers() -> None:
    with pytest.raises(InputError) as info:
        VoxelGrid.from_bounds([-3e4] * 3, [3e4] * 3, 0.01)
    assert str(info.value) == (
        "workspace: a 10 mm grid has 2.16e+20 cells (6e+06x6e+06x6e+06) and needs about 9.656e+12 GiB, "
        "over the max_memory budget of 2.0 GiB; resolution 177 m fits, or use a smaller workspace or a larger max_memory"
    )
    with pytest.raises(InputError, match=r"^workspace: min \[.*\] and max \[.*\] must be 3 finite coordinates"):
        VoxelGrid.from_bounds([-1e308] * 3, [1e308] * 3, 0.01)
    with pytest.raises(InputError, match=r"^reach: a 10 mm grid has 8e\+21 cells"):
        VoxelGrid.in_front_of_camera(np.eye(4), 0.01, reach=1e5)


def test_reach_too_large_in_the_cli(tmp_path: Path) -> None:
    line = cli_error(["localize", str(example_session_path()), "-q", "--method", "paper", "--reach", "1e5"])
    assert line == (
        f"{example_session_path()}: --reach: a 10 mm grid has 8e+21 cells (2e+07x2e+07x2e+07) and needs about "
        "3.576e+14 GiB, over the --max-memory budget of 2.0 GiB; --resolution 591 fits, or use a smaller reach or a larger --max-memory"
    )


# ---------------------------------------------------------------------- 6, 7. coordinate magnitudes
def test_polygon_vertex_far_outside_the_image(example: dict[str, Any]) -> None:
    example["views"][0]["detections"][0]["mask"] = {"polygon": [[290, 210], [1e300, 215], [300, 260]]}
    assert error_of(example) == (
        "views[0].detections[0].mask.polygon[1]: [1e+300, 215] lies more than one image size outside the 640x480 image"
    )


@pytest.mark.parametrize("value", [1e300, 1e15, 1.5e6])
def test_view_position_beyond_bound(example: dict[str, Any], value: float) -> None:
    example["views"][0]["pose"]["position"] = [value, 0, 0]
    assert error_of(example) == f"views[0].pose.position: coordinate {value:.3g} m, beyond the 1e+06 m accepted (wrong units?)"


def test_matrix_and_workspace_positions_beyond_bound(example: dict[str, Any]) -> None:
    data = copy.deepcopy(example)
    data["workspace"] = {"min": [-1e308, 0, 0], "max": [1, 1, 1]}
    assert error_of(data) == "workspace.min: coordinate 1e+308 m, beyond the 1e+06 m accepted (wrong units?)"
    data = copy.deepcopy(example)
    data["views"][0]["pose"] = {"matrix": [[1, 0, 0, 2e6], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}
    assert error_of(data) == "views[0].pose.matrix: coordinate 2e+06 m, beyond the 1e+06 m accepted (wrong units?)"


# ---------------------------------------------------------------------- 8. evaluate with far truth
def test_evaluate_truth_beyond_bound(tmp_path: Path) -> None:
    truth = write(tmp_path, '{"objects": [{"position": [1e300, 0, 0]}]}', "t.json")
    est = write(tmp_path, '{"objects": [{"position": [0, 0, 0]}]}', "e.json")
    assert cli_error(["evaluate", str(est), str(truth)]) == (
        f"{truth}: objects[0].position: coordinate 1e+300 m, beyond the 1e+06 m accepted (wrong units?)"
    )


def test_evaluate_writes_null_not_nan(tmp_path: Path) -> None:
    truth = write(tmp_path, '{"objects": [{"position": [0.1, 0, 0]}]}', "t.json")
    est = write(tmp_path, '{"objects": []}', "e.json")
    out = tmp_path / "m.json"
    result = CliRunner().invoke(app, ["evaluate", str(est), str(truth), "-o", str(out)])
    assert result.exit_code == 0, result.output
    data = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"non-JSON token {c}"))
    assert data["precision"] is None and data["recall"] == 0.0


# ---------------------------------------------------------------------- 9. write failures and --output
@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_disk_full_is_one_line(tmp_path: Path) -> None:
    est = write(tmp_path, '{"objects": [{"position": [0, 0, 0]}]}', "e.json")
    assert cli_error(["evaluate", str(est), str(est), "-o", "/dev/full"]) == "/dev/full: cannot write (No space left on device)"


def test_output_checked_before_computing(tmp_path: Path) -> None:
    session = example_session_path()
    assert cli_error(["localize", str(session), "-o", str(tmp_path / "no" / "x.json")]) == (
        f"{tmp_path / 'no' / 'x.json'}: cannot write, folder {tmp_path / 'no'} does not exist"
    )
    assert cli_error(["localize", str(session), "-o", str(tmp_path)]) == f"{tmp_path}: is a directory, expected a file to write"


def test_output_may_not_overwrite_the_input(tmp_path: Path) -> None:
    session = write(tmp_path, example_session_path().read_text())
    before = session.read_text()
    assert cli_error(["localize", str(session), "-o", str(session)]) == (
        f"{session}: is also an input file; refusing to overwrite it, choose another --output"
    )
    assert cli_error(["localize", str(session), "--view", str(session)]) == (  # the option that named it
        f"{session}: is also an input file; refusing to overwrite it, choose another --view"
    )
    assert session.read_text() == before


def test_import_output_checked_first(tmp_path: Path) -> None:
    cam = write(tmp_path, "{}", "cam.json")
    line = cli_error(["import", "--camera", str(cam), "--poses", str(cam), "--detections", str(cam), "-o", str(cam)])
    assert line == f"{cam}: is also an input file; refusing to overwrite it, choose another --output"


# ---------------------------------------------------------------------- 10. option values
def test_superscript_k() -> None:
    line = cli_error(["localize", str(example_session_path()), "-q", "--method", "paper", "--k", "²"])
    assert line == "--k: got '²', expected a positive integer or one of ['max', 'mode', 'min', 'last']"


# ---------------------------------------------------------------------- accepted silently before
def test_duplicate_json_key_names_its_path(tmp_path: Path, example: dict[str, Any]) -> None:
    text = json.dumps(example).replace('"width": 640', '"width": "x", "width": 640')
    path = write(tmp_path, text)
    assert error_of(path) == f"{path}: camera.width: duplicate key, each key may appear once"


def test_duplicate_yaml_key(tmp_path: Path) -> None:
    path = write(tmp_path, "camera:\n  width: x\n  width: 640\nviews: []\n", "s.yaml")
    assert error_of(path) == f"{path}: not valid YAML at line 3, column 3: duplicate key 'width'"


def test_invalid_utf8_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, b'{"camera": "\xff"}')
    assert error_of(path) == f"{path}: not UTF-8 text (invalid byte 0xff at offset 12)"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ([[1, 0, 0, True]], "expected a list of numbers, got True in [[1, 0, 0, True]]"),
        (["1.5", 0, 0], "expected a list of numbers, got '1.5' in ['1.5', 0, 0]"),
    ],
)
def test_import_arrays_refuse_booleans_and_text(value: Any, message: str) -> None:
    with pytest.raises(InputError) as info:
        as_array(value, "hand_eye.translation")
    assert str(info.value) == f"hand_eye.translation: {message}"


def test_degenerate_geometry_warns(example: dict[str, Any]) -> None:
    same = copy.deepcopy(example)
    for view in same["views"]:
        view["pose"] = copy.deepcopy(example["views"][0]["pose"])
    with pytest.warns(InputWarning, match=r"^views: all 3 views have the same pose; depth cannot be triangulated"):
        load_session(same)
    close = copy.deepcopy(example)
    for i, view in enumerate(close["views"]):  # three positions 5 mm apart, 0.45 m from the fruit
        view["pose"] = copy.deepcopy(example["views"][0]["pose"])
        view["pose"]["position"][1] += 0.005 * i
    with pytest.warns(
        InputWarning,
        match=r"^views: the camera positions span 0\.57 degrees seen from the scene \(near \[1\.15, 0\.025, 0\.45\] m\), under 3;",
    ):
        load_session(close)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        load_session(example)  # well spread: no warning


def test_single_view_warns_in_the_cli(tmp_path: Path, example: dict[str, Any]) -> None:
    example["views"] = example["views"][:1]
    path = write(tmp_path, json.dumps(example))
    expected = f"{path}: views: a single view; depth comes from the box size alone, give views from several poses"
    with pytest.warns(InputWarning) as record:
        result = CliRunner().invoke(app, ["localize", str(path), "-q", "--method", "paper", "--resolution", "0.02"])
    assert result.exit_code == 0, result.output
    assert expected in [str(w.message) for w in record]


def test_control_characters_are_escaped(tmp_path: Path) -> None:
    name = tmp_path / "a\x1b[31mb\nc.json"
    assert cli_error(["localize", str(name)]) == f"{one_line(str(name))}: file not found"
    path = write(tmp_path, "camera: [\x1b[31m\n", "s.yaml")
    assert error_of(path) == f"{path}: not valid YAML: unacceptable character #x001b: special characters are not allowed"


def test_excerpt_is_bounded() -> None:
    bomb: Any = ["x"] * 10
    for _ in range(9):
        bomb = [bomb] * 10  # 10**10 values when expanded
    assert len(excerpt(bomb)) <= 60
    assert excerpt(10**5000) == "an integer of over 4000 digits"
    assert one_line("a\nb\x1b") == "a\\nb\\x1b"


def test_yaml_size_is_bounded(tmp_path: Path) -> None:
    path = write(tmp_path, "metadata: [" + "0, " * (1024**2) + "0]\n", "s.yaml")
    assert error_of(path) == f"{path}: {len(path.read_text())} characters, larger than the 2097152 accepted in YAML (use JSON)"
