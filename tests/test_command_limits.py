"""Regression tests of issue 23 (nothing unbounded, nothing lost) outside the batch: each case ends in one line.

Devices and FIFOs as inputs, huge counts in options (candidates, simulated false
positives, views, pose errors, seeds, resolution), outputs equal to inputs, missing
output folders, ``/dev/full``, import results that would be empty or too big, and the
``--time-limit`` / ``--max-memory`` budget. Each asserts the exit code and the one error line.
"""

from __future__ import annotations

import json
import os
import stat
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from monovisual3d import InputError, limits, load_session
from monovisual3d._structured import read_capped_bytes, read_text
from monovisual3d.active.candidates import CapSpec, check_candidates, load_candidates
from monovisual3d.budget import TimeLimitExceeded, check_seconds, time_limit
from monovisual3d.cli import app
from monovisual3d.examples import example_session_path
from monovisual3d.sim.noise import NoiseModel
from monovisual3d.sim.scenes import paper_scene
from monovisual3d.sim.simulate import check_sim_work, write_simulation
from monovisual3d.sim.viewpoints import poses_by_name, ring_poses

FIXTURES = Path(__file__).parent / "io" / "fixtures"
runner = CliRunner()
posix_only = pytest.mark.skipif(sys.platform == "win32", reason="devices and FIFOs")


def run(*args: str) -> tuple[int, str]:
    """Exit code and the error text (stderr, else stdout) of one CLI call; no traceback allowed."""
    r = runner.invoke(app, list(args))
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    text = (r.stderr or r.stdout).strip()
    assert "Traceback" not in text
    return r.exit_code, text


def one_error(*args: str) -> str:
    code, text = run(*args)
    assert code == 2, text
    lines = [line for line in text.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, text
    return lines[0]


# ---------------------------------------------------------------------- devices and FIFOs
@posix_only
@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_devices_are_refused_before_reading(device: str) -> None:
    with pytest.raises(InputError, match=f"^{device}: is a device, expected a regular file$"):
        read_text(device)
    assert one_error("localize", device) == f"error: {device}: is a device, expected a regular file"
    session = str(example_session_path())
    assert one_error("view", session, "-r", device, "-o", os.devnull + ".html") == (
        f"error: {device}: is a device, expected a regular file"
    )


@posix_only
def test_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "s.json"
    os.mkfifo(fifo)
    assert stat.S_ISFIFO(fifo.stat().st_mode)
    with pytest.raises(InputError, match=r"is a FIFO \(named pipe\), expected a regular file"):
        read_capped_bytes(fifo)


def test_read_capped_bytes_caps(tmp_path: Path) -> None:
    path = tmp_path / "big.json"
    path.write_bytes(b" " * 101)
    with pytest.raises(InputError, match=r"101 bytes, larger than the 100 bytes accepted"):
        read_capped_bytes(path, limit=100)
    assert read_capped_bytes(path, limit=101) == b" " * 101


# ---------------------------------------------------------------------- next-view
def test_candidate_count_limit(tmp_path: Path) -> None:
    session = str(example_session_path())
    n = limits.MAX_CANDIDATES + 1
    assert one_error("next-view", session, "--candidates", f"cap:{n}") == (
        f"error: --candidates: got 'cap:{n}', more than the {limits.MAX_CANDIDATES} candidates accepted (cap:N)"
    )
    huge = "9" * 23
    assert one_error("next-view", session, "--candidates", f"cap:{huge}").startswith(
        f"error: --candidates: got 'cap:{huge}', more than the"
    )
    with pytest.raises(InputError, match="more than the 5000 candidates accepted"):
        CapSpec(n=n)
    pose = {"position": [0.2, 0.0, 0.0], "quaternion_xyzw": [0, 0, 0, 1]}
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"poses": [pose] * n}))
    with pytest.raises(InputError, match=rf"poses: {n} candidate poses, more than the {limits.MAX_CANDIDATES} accepted"):
        load_candidates(path)
    with pytest.raises(InputError, match="more than the"):
        check_candidates(np.broadcast_to(np.eye(4), (n, 4, 4)))


def test_next_view_never_overwrites_its_inputs(tmp_path: Path) -> None:
    session = tmp_path / "s.json"
    session.write_bytes(example_session_path().read_bytes())
    cands = tmp_path / "c.json"
    cands.write_text(json.dumps({"poses": [{"position": [0.2, 0.0, 0.0], "quaternion_xyzw": [0, 0, 0, 1]}]}))
    before = session.read_bytes(), cands.read_bytes()
    for target in (session, cands):
        assert one_error("next-view", str(session), "--candidates", str(cands), "-o", str(target)) == (
            f"error: {target}: is also an input file; refusing to overwrite it, choose another --output"
        )
    assert (session.read_bytes(), cands.read_bytes()) == before
    missing = tmp_path / "nowhere" / "plan.json"
    assert one_error("next-view", str(session), "--candidates", str(cands), "-o", str(missing)) == (
        f"error: {missing}: cannot write, folder {missing.parent} does not exist"
    )


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_next_view_dev_full_names_the_file() -> None:
    session = str(example_session_path())
    assert one_error("next-view", session, "--candidates", "cap:8", "-o", "/dev/full") == (
        "error: /dev/full: cannot write (No space left on device)"
    )


# ---------------------------------------------------------------------- simulate
@pytest.mark.parametrize(
    ("option", "value", "error"),
    [
        ("--false-positives", "1e9", "--false-positives (noise.false_positive_rate): got 1e+09, more than the 100 accepted"),
        ("--pose-error-deg", "1e300", "--pose-error-deg (pose_error_deg): got 1e+300, more than the 180 accepted"),
        ("--pose-error-mm", "1e300", "--pose-error-mm (pose_error_mm): got 1e+300, more than the 1000 accepted"),
        ("--seed", "-1", f"--seed: got -1, expected an integer in [0, {limits.MAX_SEED}]"),
        ("--views", "hemisphere:100000:90", "--views: got 'hemisphere:100000:90', more than the 500 views a simulation may have"),
        ("--views", "ring:1000000", "--views: got 'ring:1000000', more than the 500 views a simulation may have"),
        ("--n-fruit", "1000000000", "--n-fruit: got 1000000000, expected a positive integer of at most 1000"),
        ("--active", "500", "--active: got 500, expected a positive number of views of at most 20"),
    ],
)
def test_simulate_option_limits(tmp_path: Path, option: str, value: str, error: str) -> None:
    out = tmp_path / "out"
    extra = ["--scene", "random"] if option == "--n-fruit" else []
    assert one_error("simulate", "-o", str(out), option, value, *extra) == f"error: {error}"
    assert not out.exists()  # refused before anything was written


def test_simulate_work_limits() -> None:
    with pytest.raises(
        InputError, match=r"--supersample \(supersample\): 3 views x 640x480 px x 50\^2 = 2.3e\+09 rays, more than"
    ):
        check_sim_work(3, None, 50)
    with pytest.raises(InputError, match="--views: 501 views, more than the 500"):
        check_sim_work(limits.MAX_SIM_VIEWS + 1, None, 1)
    with pytest.raises(InputError, match="more than the 500 views"):
        poses_by_name("ring:501")
    with pytest.raises(InputError, match="more than the 100 accepted"):
        NoiseModel(false_positive_rate=101)


def test_simulate_pictures_limit(tmp_path: Path) -> None:
    poses = ring_poses([0.6, 0.0, 0.45], limits.MAX_SIM_PICTURES + 1)
    with pytest.raises(InputError, match="101 views with --images, more than the 100 pictures"):
        write_simulation(tmp_path / "o", paper_scene(), poses=poses, images=True)


def test_what_simulate_writes_load_session_reads(tmp_path: Path) -> None:
    noise = NoiseModel.from_mm_deg(
        box_sigma=0.05,
        drop_probability=0.02,
        false_positive_rate=limits.MAX_SIM_FALSE_POSITIVES,
        pose_error_mm=limits.MAX_SIM_POSE_ERROR_MM,
        pose_error_deg=limits.MAX_SIM_POSE_ERROR_DEG,
    )
    paths = write_simulation(tmp_path / "o", paper_scene(), noise=noise, rng=3, images=False)
    session = load_session(paths["session"])
    assert len(session.views) == 3
    assert sum(len(v.detections) for v in session.views) > 3  # the false positives are there
    # a session the loader refuses is never written
    code, text = run("simulate", "-o", str(tmp_path / "far"), "--distance", "1e7", "--no-images")
    assert code == 2 and "the simulated session would not load" in text
    assert not (tmp_path / "far" / "session.json").exists()


def test_simulate_never_overwrites_its_scene(tmp_path: Path) -> None:
    paths = write_simulation(tmp_path / "o", paper_scene(), rng=0, images=False)
    before = paths["scene"].read_bytes()
    assert one_error("simulate", "--scene", str(paths["scene"]), "-o", str(tmp_path / "o")) == (
        f"error: {paths['scene']}: is also an input file; refusing to overwrite it, choose another --output"
    )
    assert paths["scene"].read_bytes() == before


# ---------------------------------------------------------------------- localize: work limits
def test_bayes_resolution_floor(tmp_path: Path) -> None:
    session = str(example_session_path())
    assert one_error("localize", session, "--resolution", "1e-9") == (
        "error: --resolution: got 1e-09 m, finer than the 0.001 m accepted "
        "(each halving adds a search level; the refinement, not the grid, gives the accuracy)"
    )
    code, text = run("batch", session, "-o", str(tmp_path / "b"), "--workers", "0", "-q", "--option", "resolution=1e-9")
    assert code == 2 and text.startswith("error: --option resolution: got 1e-09 m, finer than the 0.001 m accepted")


def thousand_boxes_session(tmp_path: Path) -> Path:
    """The hostile session of the dense-rows issue: 1,000 seeded random boxes in each of the example's 3 views."""
    data = json.loads(example_session_path().read_text())
    rng = np.random.default_rng(0)
    w, h = data["camera"]["width"], data["camera"]["height"]
    for view in data["views"]:
        xy = rng.uniform(0, [w - 40, h - 40], size=(1000, 2))
        view["detections"] = [{"bbox_xyxy": [x, y, x + 30, y + 30]} for x, y in xy.tolist()]
    path = tmp_path / "many.json"
    path.write_text(json.dumps(data))
    return path


def test_bayes_refuses_a_thousand_boxes_per_view_in_one_line(tmp_path: Path) -> None:
    line = one_error("localize", str(thousand_boxes_session(tmp_path)), "-q")
    assert "1,000 boxes" in line and "limits.MAX_BAYES_BOXES_PER_VIEW" in line


def test_paper_kmeans_work_is_bounded(tmp_path: Path) -> None:
    path = thousand_boxes_session(tmp_path)
    line = one_error("localize", str(path), "--method", "paper", "-q")
    assert line.startswith(f"error: {path}: --k: k-means of 1000 clusters over ")
    assert line.endswith("give a smaller --k, a coarser --resolution, or use --method bayes")


def test_session_box_and_view_limits() -> None:
    data = json.loads(example_session_path().read_text())
    view = data["views"][0]
    view["detections"] = view["detections"][:1] * (limits.MAX_DETECTIONS_PER_VIEW + 1)
    with pytest.raises(InputError, match=r"views\[0\].detections: 2001 detections, more than the 2,000 accepted per view"):
        load_session(data)
    data["views"] = [data["views"][1]] * (limits.MAX_VIEWS + 1)
    with pytest.raises(InputError, match=r"views: 10001 views, more than the 10,000 accepted \(limits.MAX_VIEWS\)"):
        load_session(data)


# ---------------------------------------------------------------------- import
def test_import_with_no_matching_image_is_an_error(tmp_path: Path) -> None:
    dets = tmp_path / "d.csv"
    dets.write_text((FIXTURES / "detections.csv").read_text().replace("img_", "other_"))
    out = tmp_path / "s.json"
    code, text = run(
        "import",
        "--camera",
        str(FIXTURES / "ros_camera_info.yaml"),
        "--poses",
        str(FIXTURES / "poses.csv"),
        "--detections",
        str(dets),
        "-o",
        str(out),
    )
    assert code == 2
    assert text.splitlines()[-1] == (
        f"error: {dets}: no detection image matches an image named in {FIXTURES / 'poses.csv'} "
        "(e.g. 'other_000' vs 'img_000'); check the names, or pass --match stamp or --match order"
    )
    assert not out.exists()


def test_import_errors_name_the_input_line(tmp_path: Path) -> None:
    labels = tmp_path / "labels"
    labels.mkdir()
    for f in (FIXTURES / "yolo_labels").iterdir():
        (labels / f.name).write_bytes(f.read_bytes())
    t = np.linspace(0, 2 * np.pi, limits.MAX_POLYGON_POINTS + 10, endpoint=False)
    pts = " ".join(f"{0.5 + 0.1 * np.cos(a):.6f} {0.5 + 0.1 * np.sin(a):.6f}" for a in t)
    n_lines = len([x for x in (labels / "img_001.txt").read_text().splitlines() if x.strip()])
    with open(labels / "img_001.txt", "a") as f:
        f.write(f"0 {pts}\n")
    line = one_error(
        "import",
        "--camera",
        str(FIXTURES / "opencv_calibration.yaml"),
        "--poses",
        str(FIXTURES / "poses.csv"),
        "--detections",
        str(labels),
        "-o",
        str(tmp_path / "s.json"),
    )
    assert (
        line == f"error: {labels / 'img_001.txt'}: line {n_lines + 1}: mask.polygon: 100010 points, more than the 100000 accepted"
    )


def test_import_refuses_huge_tables_before_parsing(tmp_path: Path) -> None:
    poses = tmp_path / "poses.csv"
    row = "img_x.png,1.0,0.18,0.0,0.47,-0.5,0.5,-0.5,0.5\n"
    poses.write_text("image,stamp,x,y,z,qx,qy,qz,qw\n" + row * (limits.MAX_TABLE_ROWS + 1))
    line = one_error(
        "import",
        "--camera",
        str(FIXTURES / "ros_camera_info.yaml"),
        "--poses",
        str(poses),
        "--detections",
        str(FIXTURES / "detections.csv"),
        "-o",
        str(tmp_path / "s.json"),
    )
    assert line == f"error: {poses}: 200,002 lines, more than the 200,000 accepted in one file"


# ---------------------------------------------------------------------- the budget
def test_time_limit_raises_and_restores() -> None:
    import signal
    import time

    before = signal.getsignal(signal.SIGALRM)
    with pytest.raises(TimeLimitExceeded, match=r"^--time-limit: still running after 0.2 s, stopped"):
        with time_limit(0.2):
            time.sleep(5)
    assert signal.getsignal(signal.SIGALRM) == before
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)
    with time_limit(None):
        pass
    for bad in (0, -1, float("nan"), float("inf"), 1e9):
        with pytest.raises(InputError, match=r"--time-limit: got .*, expected seconds in \(0, 86400\]"):
            check_seconds(bad)


def test_time_limit_on_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "o"
    assert one_error("simulate", "-o", str(out), "--time-limit", "0.001", "--no-images").startswith(
        "error: --time-limit: still running after 0.001 s, stopped"
    )
    assert one_error("localize", str(example_session_path()), "--time-limit", "-1") == (
        "error: --time-limit: got -1.0, expected seconds in (0, 86400]"
    )


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="the memory watchdog reads /proc")
def test_max_memory_stops_a_command_in_one_line(tmp_path: Path) -> None:
    import subprocess

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(__file__).parents[1] / "src"), os.environ.get("PYTHONPATH", "")]))
    args = ["simulate", "-o", str(tmp_path / "o"), "--views", "ring:100", "--supersample", "2", "--no-images"]
    proc = subprocess.run(
        [sys.executable, "-c", "from monovisual3d.cli import main; main()", *args, "--max-memory", "16MiB"],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert lines == ["error: --max-memory: the command grew by more than 16 MiB, stopped; raise --max-memory"]
    assert not (tmp_path / "o" / "session.json").exists()
