"""How long after a view's pose is available does the ROS 2 node publish its fruit (target: median <= 0.5 s), and how right?

Run with ``PYTHONPATH=src python experiments/ros2_latency.py [--views 10] [--rate 1] [--seeds 0,1,2] [--output latency.json]``
(needs the ``[ros2]`` extra). Everything stays on loopback unless ``CYCLONEDDS_URI`` says otherwise: this script
sets a loopback-only configuration and a random ``ROS_DOMAIN_ID`` when they are not set.

Per seed, a simulated greenhouse (2 % box noise, ``--views`` views on a ring) is played by ``ros2 play``'s library
call in this process while ``monovisual3d ros2 node`` runs in another (warmed up, its defaults plus the method
options given after ``--``). A view's pose is available when its detections, its camera info and the first TF
sample at or after its stamp have all been published (wall clock, this process); its latency runs from then until
this process takes the first Detection3DArray whose stamp is at or after the view's (views that arrive during an
estimate are answered by the next one). The node's own ``estimate_s`` (the method's wall time per estimate) and
``estimate_cpu_s`` (the CPU time its process used meanwhile: what the estimate costs when the CPUs are not shared)
are reported beside it, and each session's last estimate is compared with the simulation's truth (recall, mean
error of the matched fruit). Everything runs on this machine's CPUs: the player, the node and this reader share them.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from monovisual3d.bench.timing import machine_metadata
from monovisual3d.io.ros_messages import stamp_ns
from monovisual3d.metrics import evaluate
from monovisual3d.ros2 import dds, msgs
from monovisual3d.ros2.config import Topics
from monovisual3d.ros2.play import PlayConfig, play_session
from monovisual3d.sim import greenhouse_scene, ring_poses, scene_target, simulate
from monovisual3d.sim.noise import NoiseModel

#: Cyclone DDS on loopback only, no multicast (as the tests).
LOOPBACK = (
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><Peers><Peer address='127.0.0.1'/></Peers>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex></Discovery>"
    "</Domain></CycloneDDS>"
)
#: The benchmark's topics: nothing else on the domain hears them.
TOPICS = Topics.with_prefix(
    "/bench/fruit", camera_info="/bench/camera_info", detections="/bench/detections", tf="/bench/tf", tf_static="/bench/tf_static"
)
#: How long the reader waits for the node's answer to the last view, seconds.
ANSWER_S = 60.0


def _node(method_options: list[str]) -> subprocess.Popen:
    args = [sys.executable, "-m", "monovisual3d.cli", "ros2", "node", "--prefix", "/bench/fruit"]
    args += [
        "--camera-info",
        TOPICS.camera_info,
        "--detections",
        TOPICS.detections,
        "--tf",
        TOPICS.tf,
        "--tf-static",
        TOPICS.tf_static,
    ]
    return subprocess.Popen(args + method_options, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)


def _availability(published: list[tuple[float, str, int]]) -> dict[int, float]:
    """Per view stamp (ns): the wall time its detections, camera info and first TF sample at or after it were all out."""
    out: dict[int, float] = {}
    det = {s: t for t, topic, s in published if topic == TOPICS.detections}
    info = {s: t for t, topic, s in published if topic == TOPICS.camera_info}
    tf = sorted((s, t) for t, topic, s in published if topic == TOPICS.tf)
    for s, t_det in det.items():
        t_tf = next(t for stamp, t in tf if stamp >= s)
        out[s] = max(t_det, info.get(s, t_det), t_tf)
    return out


def _reset(reset: Any, status: Any) -> None:
    """Start a new session in the node (publish on its reset topic) and wait until it says so."""
    reset.write(msgs.Empty())
    deadline = time.monotonic() + ANSWER_S
    while not any(json.loads(s.data)["event"] == "reset" for s in status.take(64)):
        if time.monotonic() > deadline:
            raise SystemExit("the node did not reset")
        time.sleep(0.01)


def run_seed(seed: int, args: argparse.Namespace, out: Any, status: Any) -> dict[str, Any]:
    """One session played to the running node (reset before): latency per view (s) and the node's estimate times (s)."""
    scene = greenhouse_scene(rng=seed)
    session, truth = simulate(
        scene, poses=ring_poses(scene_target(scene), args.views), noise=NoiseModel(box_sigma=0.02), rng=seed
    )
    received: list[tuple[int, float]] = []
    last: Any = None
    estimates: list[float] = []
    cpu: list[float] = []
    played: dict[str, Any] = {}
    player = threading.Thread(target=lambda: played.update(play_session(session, PlayConfig(topics=TOPICS, rate_hz=args.rate))))
    player.start()
    last_view = None
    deadline = None
    while True:
        for msg in out.take(64):
            received.append((stamp_ns(msg.header.stamp), time.time()))
            last = msg
        for s in status.take(64):
            d = json.loads(s.data)
            if d["event"] == "estimate" and d.get("estimate_s") is not None:
                estimates.append(d["estimate_s"])
                cpu.append(d["estimate_cpu_s"])
        if not player.is_alive() and last_view is None:
            last_view = max(_availability(played["published"]))
            deadline = time.monotonic() + ANSWER_S
        if last_view is not None and (any(s >= last_view for s, _ in received) or time.monotonic() > deadline):
            break
        time.sleep(0.002)
    latency = []
    for s, t_avail in sorted(_availability(played["published"]).items()):
        answers = [t for stamp, t in received if stamp >= s]
        if answers:
            latency.append(min(answers) - t_avail)
    p_base = np.array([[d.bbox.center.position.x, d.bbox.center.position.y, d.bbox.center.position.z] for d in last.detections])
    true_p = np.array([o["position"] for o in truth["objects"]])
    m = evaluate(p_base.reshape(-1, 3), true_p, truth_radii=np.array([o["radius"] for o in truth["objects"]]))
    return {
        "seed": seed,
        "views": len(session.views),
        "answered": len(latency),
        "latency_s": latency,
        "estimate_s": estimates,
        "estimate_cpu_s": cpu,
        "recall": m.recall,
        "error_mean_mm": m.euclidean_mean * 1e3,
    }


def _summary(values: list[float]) -> dict[str, float]:
    q = statistics.quantiles(values, n=10) if len(values) >= 2 else values * 9
    return {
        "n": len(values),
        "median": statistics.median(values),
        "p10": q[0],
        "p90": q[-1],
        "min": min(values),
        "max": max(values),
    }


def _arguments(args: argparse.Namespace) -> list[str]:
    """The command line that gives ``args`` (for the results' record)."""
    out = ["--views", str(args.views), "--rate", str(args.rate), "--seeds", args.seeds]
    return out + (["--", *args.method_options] if args.method_options else [])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--views", type=int, default=10, help="views per session (a ring around the plant)")
    parser.add_argument("--rate", type=float, default=1.0, help="views per second")
    parser.add_argument("--seeds", default="0,1,2", help="greenhouse seeds, comma separated")
    parser.add_argument("--output", type=Path, help="write the results (with machine metadata) as JSON here")
    parser.add_argument("method_options", nargs="*", help="after --: options of the node's method, e.g. -- --shape sphere")
    args = parser.parse_args()
    os.environ.setdefault("CYCLONEDDS_URI", LOOPBACK)
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(100, 230)))
    ep = dds.Endpoints(dds.participant(dds.domain_id_from_env()))
    out = ep.reader(TOPICS.out_detections, msgs.Detection3DArray, dds.tf_reader_qos())
    status = ep.reader(TOPICS.out_status, msgs.String, dds.tf_static_reader_qos())
    node = _node(args.method_options)
    try:
        t_start = time.monotonic()
        while not any(json.loads(s.data)["event"] == "started" for s in status.take(64)):
            if time.monotonic() - t_start > ANSWER_S or node.poll() is not None:
                raise SystemExit("the node did not start")
            time.sleep(0.05)
        reset = ep.writer(TOPICS.reset, msgs.Empty, dds.publisher_qos("default"))
        runs = []
        for seed in args.seeds.split(","):
            _reset(reset, status)
            out.take(64)  # the reset's empty Detection3DArray
            runs.append(run_seed(int(seed), args, out, status))
    finally:
        node.terminate()
        node.wait(30)
    latency = [x for r in runs for x in r["latency_s"]]
    later = [x for r in runs for x in r["latency_s"][1:]]  # a first view alone gives no fruit and costs nothing
    estimate = [x for r in runs for x in r["estimate_s"]]
    cpu = [x for r in runs for x in r["estimate_cpu_s"]]
    result = {
        "command": " ".join(["ros2_latency.py", *_arguments(args)]),
        "latency_s": _summary(latency),
        "latency_s_from_view_2": _summary(later),
        "estimate_s": _summary(estimate),
        "estimate_cpu_s": _summary(cpu),
        "views": sum(r["views"] for r in runs),
        "answered": sum(r["answered"] for r in runs),
        "runs": runs,
        "load_average": os.getloadavg(),
        "machine": machine_metadata(),
    }
    lat, est, est_cpu = result["latency_s"], result["estimate_s"], result["estimate_cpu_s"]
    print(f"views answered: {result['answered']} of {result['views']}")
    for r in runs:
        print(
            f"seed {r['seed']}: recall {r['recall']:.3f}, mean error {r['error_mean_mm']:.2f} mm (the last estimate against the truth)"
        )
    print(
        f"latency (pose available -> Detection3DArray taken): median {lat['median']:.3f} s, p10-p90 {lat['p10']:.3f}-{lat['p90']:.3f} s, max {lat['max']:.3f} s"
    )
    lat2 = result["latency_s_from_view_2"]
    print(f"  from each session's second view on: median {lat2['median']:.3f} s, p10-p90 {lat2['p10']:.3f}-{lat2['p90']:.3f} s")
    print(f"estimate, wall (node's estimate_s): median {est['median']:.3f} s, p10-p90 {est['p10']:.3f}-{est['p90']:.3f} s")
    print(
        f"estimate, CPU time of the node's process: median {est_cpu['median']:.3f} s, p10-p90 {est_cpu['p10']:.3f}-{est_cpu['p90']:.3f} s"
    )
    print(f"load average: {' '.join(f'{x:.2f}' for x in result['load_average'])}")
    if args.output is not None:
        args.output.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
