"""Finding sessions: folders, globs, files, ids, truth, and the errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from monovisual3d.batch import find_sessions
from monovisual3d.errors import InputError

IDS = ["a/s0/session.json", "a/s1/session.json", "b/s2/session.json"]


def test_folder_is_searched_recursively_with_ids_relative_to_it(sim_root: Path) -> None:
    found = find_sessions([sim_root])
    assert [s.session_id for s in found] == IDS
    assert all(s.path.is_absolute() and s.path.name == "session.json" for s in found)
    assert all(s.truth_path == s.path.parent / "truth.json" for s in found)


def test_glob_and_shell_expanded_files_give_the_folder_ids(sim_root: Path) -> None:
    assert [s.session_id for s in find_sessions([str(sim_root / "*" / "*" / "session.json")])] == IDS
    expanded = sorted(sim_root.glob("*/*/session.json"))
    assert [s.session_id for s in find_sessions(expanded)] == IDS
    assert [s.session_id for s in find_sessions([str(sim_root / "**")])] == IDS


def test_two_folders_get_ids_from_their_common_parent(sim_root: Path) -> None:
    assert [s.session_id for s in find_sessions([sim_root / "a", sim_root / "b"])] == IDS


def test_a_session_named_twice_is_run_once(sim_root: Path) -> None:
    found = find_sessions([sim_root, sim_root / "a" / "s0" / "session.json", str(sim_root / "a" / ".." / "a")])
    assert [s.session_id for s in found] == IDS


def test_a_single_file_has_its_name_as_id_and_no_truth_when_none_beside_it(tmp_path: Path) -> None:
    f = tmp_path / "plant_7.yaml"
    f.write_text("camera: {}\n")
    (found,) = find_sessions([f])
    assert found.session_id == "plant_7.yaml"
    assert found.truth_path is None


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda d: [], "inputs: empty"),
        (lambda d: [d / "nope"], "nope: no such file or folder"),
        (lambda d: [str(d / "*.json")], r"\*\.json: matched no file or folder"),
        (lambda d: [d], "no session.json or session.yaml or session.yml in this folder or below"),
    ],
)
def test_bad_inputs_are_one_line_errors(tmp_path: Path, make, match: str) -> None:
    with pytest.raises(InputError, match=match):
        find_sessions(make(tmp_path))
