"""A seeded structural mutator of valid inputs: sessions, truth/result files, imported files.

Every function takes a :class:`random.Random`, so a case is reproduced from its
seed alone. Mutations work on the parsed tree (replace, delete, add, duplicate,
scale, retype values; degenerate geometry; masks) and on the text (JSON or YAML;
duplicate keys, invalid UTF-8, deep nesting, YAML aliases, bombs and tags, NaN
literals, truncation, control characters).
"""

from __future__ import annotations

import copy
import json
import math
import random
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from monovisual3d.examples import example_session_path, example_truth_path
from monovisual3d.frames import look_at
from monovisual3d.masks import encode_rle

HUGE_INT = 10**400

#: Hostile scalar and container values (shared by the mutator and the hypothesis strategies).
HOSTILE: list[Any] = [
    None,
    True,
    False,
    0,
    -1,
    1,
    2**31,
    2**63,
    -(2**63),
    2**64 + 1,
    HUGE_INT,
    -HUGE_INT,
    0.0,
    -0.0,
    0.5,
    1e-320,
    1e6,
    1e6 + 1,
    -1e6 - 1,
    1e15,
    1e300,
    -1e300,
    1.7e308,
    math.nan,
    math.inf,
    -math.inf,
    "",
    "x",
    "1.5",
    "nan",
    "\u202e\u0000",
    "a\nb",
    "\x1b[31mred",
    "é" * 3,
    "x" * 5000,
    [],
    {},
    [1, 2],
    [[1, 2, 3]],
    {"a": 1},
    list(range(3000)),
    [0.5] * 4,
    [math.nan] * 4,
    [HUGE_INT] * 3,
]

LABELS = ["tomato", "", "\u202e", "a\nb", "x" * 300, "🍅"]


def base_sessions() -> list[dict[str, Any]]:
    """Valid session dicts: the shipped example, variants (matrix poses, camera_link, distortion, masks, YAML-only)."""
    ex = json.loads(example_session_path().read_text())
    out = [ex]
    m = copy.deepcopy(ex)
    from monovisual3d import load_session

    s = load_session(ex)
    for v, view in zip(m["views"], s.views):
        v["pose"] = {"matrix": view.T_base_optical.tolist()}
    m["workspace"] = {"min": [0.4, -0.2, 0.25], "max": [0.8, 0.2, 0.65]}
    out.append(m)
    d = copy.deepcopy(ex)
    d["camera"] = {"width": 640, "height": 480, "fx": 462.0, "fy": 461.0, "cx": 321.0, "cy": 239.0}
    d["camera"]["distortion"] = {"model": "plumb_bob", "coefficients": [0.01, -0.02, 0.0, 0.0, 0.0]}
    out.append(d)
    k = copy.deepcopy(ex)
    for view in k["views"]:
        box = view["detections"][0]["bbox_xyxy"]
        u1, v1, u2, v2 = box
        cu, cv, r = (u1 + u2) / 2, (v1 + v2) / 2, (u2 - u1) / 2
        ang = np.linspace(0, 2 * np.pi, 12, endpoint=False)
        view["detections"][0]["mask"] = {"polygon": [[cu + r * math.cos(a), cv + r * math.sin(a)] for a in ang]}
    out.append(k)
    r = copy.deepcopy(ex)
    vv, uu = np.mgrid[0:480, 0:640]
    u1, v1, u2, v2 = r["views"][0]["detections"][0]["bbox_xyxy"]
    disk = (uu + 0.5 - (u1 + u2) / 2) ** 2 + (vv + 0.5 - (v1 + v2) / 2) ** 2 <= ((u2 - u1) / 2) ** 2
    r["views"][0]["detections"][0]["mask"] = encode_rle(disk)
    out.append(r)
    # a second object and a false positive, camera_link poses from look_at
    c = {"camera": {"width": 320, "height": 240, "hfov_deg": 60.0}, "pose_frame": "optical", "views": []}
    for i, p in enumerate([[0.0, -0.3, 0.4], [0.0, 0.0, 0.5], [0.0, 0.3, 0.4], [0.1, 0.0, 0.2]]):
        T = look_at(p, [0.6, 0.0, 0.45])
        c["views"].append(
            {
                "pose": {"matrix": T.tolist()},
                "detections": [{"bbox_xyxy": [140.0, 100.0, 180.0, 140.0], "score": 0.8, "label": "tomato"}],
                "stamp": float(i),
                "image": f"img_{i}.png",
            }
        )
    out.append(c)
    return out


def base_objects() -> list[dict[str, Any]]:
    """Valid truth / result dicts for ``evaluate``."""
    truth = json.loads(example_truth_path().read_text())
    result = {"objects": [{"position": [0.6, 0.01, 0.45], "score": 0.9, "radius": 0.03}], "method": "paper"}
    many = {"objects": [{"position": [0.1 * i, 0.05 * i, 0.4], "radius": 0.03, "label": "t"} for i in range(6)]}
    return [truth, result, many, {"objects": []}]


# ---------------------------------------------------------------------- tree mutations
def _nodes(tree: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [path]
    if isinstance(tree, dict):
        for k, v in tree.items():
            out += _nodes(v, (*path, k))
    elif isinstance(tree, list) and len(tree) <= 64:
        for i, v in enumerate(tree):
            out += _nodes(v, (*path, i))
    return out


def _get(tree: Any, path: tuple[Any, ...]) -> Any:
    for p in path:
        tree = tree[p]
    return tree


def _set(tree: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    _get(tree, path[:-1])[path[-1]] = value
    return tree


def hostile_value(rng: random.Random, old: Any = None) -> Any:
    """A hostile replacement for ``old``: from :data:`HOSTILE`, or ``old`` scaled, negated or retyped."""
    r = rng.random()
    if isinstance(old, (int, float)) and not isinstance(old, bool) and r < 0.45:
        op = rng.choice(["scale", "neg", "tiny", "int", "float", "str", "huge"])
        if op == "scale":
            return old * rng.choice([1e3, 1e6, 1e-6, 1e15, 1e300, -1])
        if op == "neg":
            return -old if old else -1
        if op == "tiny":
            return old + rng.choice([1e-12, -1e-12, 0.5, -0.5])
        if op == "int":
            return int(old) if not isinstance(old, float) or math.isfinite(old) else 0
        if op == "float":
            return float(old) if abs(old) < 1e308 else old
        if op == "str":
            return str(old)
        return int(old) * 10 ** rng.randint(20, 400) if not isinstance(old, float) or math.isfinite(old) else HUGE_INT
    if isinstance(old, str) and r < 0.3:
        return rng.choice([old * 50, old.upper(), old + "\x00", "", 1, None])
    return copy.deepcopy(rng.choice(HOSTILE))


def mutate_tree(tree: Any, rng: random.Random, n: int | None = None) -> Any:
    """Apply ``n`` (1-3) random structural edits to a deep copy of ``tree``."""
    tree = copy.deepcopy(tree)
    for _ in range(n or rng.choice([1, 1, 1, 2, 3])):
        paths = _nodes(tree)
        path = rng.choice(paths)
        node = _get(tree, path)
        op = rng.choice(["replace"] * 5 + ["delete", "delete", "add", "dup_item", "truncate", "huge_list", "swap", "wrap"])
        parent = _get(tree, path[:-1]) if path else None
        if op == "replace" or (op in ("delete", "swap") and not path):
            tree = _set(tree, path, hostile_value(rng, node))
        elif op == "delete":
            del parent[path[-1]]
        elif op == "add":
            target = node if isinstance(node, dict) else parent if isinstance(parent, dict) else None
            if target is not None:
                target[rng.choice(["extra", "Width", "bbox_xyxy", "matrix", "é", "views", "0", "mask"])] = hostile_value(rng)
        elif op == "dup_item" and isinstance(node, list) and node:
            node.append(copy.deepcopy(rng.choice(node)))
        elif op == "truncate" and isinstance(node, list):
            del node[rng.randrange(len(node) + 1) :]
        elif op == "huge_list" and isinstance(node, list) and node:
            node.extend(copy.deepcopy(node[-1]) for _ in range(rng.choice([100, 1000])))
        elif op == "swap" and isinstance(parent, dict) and len(parent) > 1:
            other = rng.choice(list(parent))
            parent[path[-1]], parent[other] = parent[other], parent[path[-1]]
        elif op == "wrap":
            tree = _set(tree, path, [node] if rng.random() < 0.5 else {"value": node})
    return tree


def mutate_session(base: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    """A session with generic tree edits and/or session-aware ones (geometry, masks, workspace, camera)."""
    s = copy.deepcopy(base)
    kind = rng.choice(["tree"] * 5 + ["geometry", "mask", "workspace", "camera", "boxes", "views"])
    views = s.get("views") or []
    if kind == "geometry" and views:
        op = rng.choice(["same", "close", "single", "far", "behind"])
        if op == "same":
            for v in views:
                v["pose"] = copy.deepcopy(views[0]["pose"])
        elif op == "close":
            for i, v in enumerate(views):
                v["pose"] = copy.deepcopy(views[0]["pose"])
                key = "position" if "position" in v["pose"] else None
                if key:
                    v["pose"]["position"][0] += 1e-3 * i
        elif op == "single":
            del views[1:]
        elif op == "far":
            v = rng.choice(views)
            if "position" in v["pose"]:
                v["pose"]["position"] = [rng.choice([1e5, 9.9e5, 1e6, -1e6]), 0.0, 0.0]
        else:
            v = rng.choice(views)
            if "quaternion_xyzw" in v["pose"]:
                v["pose"]["quaternion_xyzw"] = [1.0, 0.0, 0.0, 0.0]
    elif kind == "mask" and views:
        det = rng.choice(views)["detections"] or [{"bbox_xyxy": [1, 1, 2, 2]}]
        cam = s.get("camera", {})
        h, w = cam.get("height", 480), cam.get("width", 640)
        det = det[0]
        op = rng.choice(["poly", "poly_far", "rle", "rle_str", "rle_bad", "rle_huge"])
        if op == "poly":
            det["mask"] = {"polygon": [[rng.uniform(-50, 700), rng.uniform(-50, 500)] for _ in range(rng.randint(0, 8))]}
        elif op == "poly_far":
            det["mask"] = {"polygon": [[290, 210], [rng.choice([1e300, 1e6, -1e4, 1300.0]), 215], [300, 260]]}
        elif op == "rle":
            n = h * w if isinstance(h, int) and isinstance(w, int) else 1
            a = rng.randrange(max(n, 1))
            det["mask"] = {"size": [h, w], "counts": [a, rng.randrange(1, 2000), max(n - a - 1, 0)]}
        elif op == "rle_str":
            det["mask"] = {
                "size": [h, w],
                "counts": "".join(
                    rng.choice("0123456789:;<=>?@ABCDEFGHIJKLMNOPQRSTUVWXYZ[\\]^_`abcdefghijklmnopqrstuvwxyz")
                    for _ in range(rng.randint(0, 40))
                ),
            }
        elif op == "rle_bad":
            det["mask"] = {"size": rng.choice([[h], [h, w, 1], ["a", w], [True, w], [w, h]]), "counts": [0, 1]}
        else:
            det["mask"] = {"size": [100000, 100000], "counts": [0, 10**10]}
    elif kind == "workspace":
        lo = [rng.choice([-1e308, -1e5, -3e4, -10.0, 0.0, 0.4, 0.6]) for _ in range(3)]
        hi = [x + rng.choice([1e-9, 0.01, 0.5, 10.0, 6e4, 2e5, -1.0]) for x in lo]
        s["workspace"] = {"min": lo, "max": hi}
    elif kind == "camera":
        cam = s.setdefault("camera", {})
        op = rng.choice(["size", "hfov", "fx", "dist"])
        if op == "size":
            cam[rng.choice(["width", "height"])] = rng.choice([1, 2, 16384, 32768, 32769, 100000, 10**9, HUGE_INT, 640.0])
        elif op == "hfov" and "hfov_deg" in cam:
            cam["hfov_deg"] = rng.choice([1e-9, 0.001, 179.999, 180, 1e300, HUGE_INT])
        elif op == "fx":
            cam.pop("hfov_deg", None)
            cam.update(fx=rng.choice([1e-9, 1.0, 1e7, 1.1e7, 1e300]), fy=500.0, cx=rng.choice([320.0, -1e7, 1e7]), cy=240.0)
        else:
            model = rng.choice(["plumb_bob", "rational_polynomial", "equidistant", "fisheye", "none", "bogus", None, 3])
            n = rng.choice([0, 4, 5, 8, 14, 15])
            cam["distortion"] = {"model": model, "coefficients": [rng.choice([0.0, 0.1, -1.0, 5.0, 1e6, 1e7]) for _ in range(n)]}
    elif kind == "boxes" and views:
        v = rng.choice(views)
        if v["detections"]:
            d = rng.choice(v["detections"])
            op = rng.choice(["invert", "outside", "huge", "point", "many"])
            if op == "invert":
                x1, y1, x2, y2 = d["bbox_xyxy"]
                d["bbox_xyxy"] = [x2, y1, x1, y2]
            elif op == "outside":
                d["bbox_xyxy"] = [-100.0, -100.0, rng.choice([-1.0, 0.0, 0.5]), 10.0]
            elif op == "huge":
                d["bbox_xyxy"] = [-1e300, -1e300, 1e300, 1e300]
            elif op == "point":
                x1, y1 = d["bbox_xyxy"][:2]
                d["bbox_xyxy"] = [x1, y1, x1 + 1e-9, y1 + 1e-9]
            else:
                v["detections"] = [copy.deepcopy(d) for _ in range(rng.choice([50, 500]))]
    elif kind == "views" and views:
        s["views"] = [copy.deepcopy(rng.choice(views)) for _ in range(rng.choice([0, 1, 30, 200]))]
    if kind == "tree" or rng.random() < 0.3:
        s = mutate_tree(s, rng)
    return s


# ---------------------------------------------------------------------- text mutations
def _bomb(levels: int) -> str:
    lines = ['b0: &b0 ["x","x","x","x","x","x","x","x","x","x"]']
    lines += [f"b{i}: &b{i} [" + ",".join([f"*b{i - 1}"] * 10) + "]" for i in range(1, levels + 1)]
    return "".join(f"  {line}\n" for line in lines)


def to_text(data: Any, rng: random.Random, yaml_ok: bool = True) -> tuple[bytes, str]:
    """Serialise ``data`` as JSON or YAML, possibly with a text-level attack; returns (bytes, suffix)."""
    as_yaml = yaml_ok and rng.random() < 0.25
    try:
        if as_yaml and len(json.dumps(data, default=str)) > 10_000:  # PyYAML is slow: big documents go as JSON
            as_yaml = False
        if as_yaml:
            dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
            text = yaml.dump(data, Dumper=dumper, allow_unicode=rng.random() < 0.5, sort_keys=False)
        else:
            text = json.dumps(data, ensure_ascii=rng.random() < 0.5)
    except (ValueError, TypeError, OverflowError, RecursionError):
        text = json.dumps({"unserialisable": True})
        as_yaml = False
    suffix = ".yaml" if as_yaml else ".json"
    if rng.random() < 0.6:
        return text.encode(), suffix
    attack = rng.choice(
        ["dup", "utf8", "deep", "nan", "truncate", "bom", "ctrl", "bytes", "bomb", "alias", "tag", "recursive", "bigint"]
    )
    if attack == "dup":
        for key in ('"width"', '"bbox_xyxy"', '"views"', '"position"', "width:", "bbox_xyxy:", "position:"):
            if key in text:
                i = text.index(key)
                text = (
                    text[:i]
                    + (f"{key} 1, " if key.startswith('"') else f"{key} 1\n" + " " * (i - text.rfind("\n", 0, i) - 1))
                    + text[i:]
                )
                break
    elif attack == "utf8":
        i = rng.randrange(len(text) + 1)
        raw = text.encode()
        return raw[:i] + rng.choice([b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x80\x80"]) + raw[i:], suffix
    elif attack == "deep":
        depth = rng.choice([63, 64, 65, 500, 5000])
        if as_yaml:
            text = "metadata: " + "[" * depth + "]" * depth + "\n" + text
        else:
            text = '{"metadata": ' + "[" * depth + "]" * depth + ", " + text.lstrip()[1:]
    elif attack == "nan":
        text = text.replace("0.95", rng.choice(["NaN", "Infinity", "-Infinity", ".nan", ".inf"]), 1)
    elif attack == "truncate":
        text = text[: rng.randrange(len(text) + 1)]
    elif attack == "bom":
        text = "\ufeff" + text
    elif attack == "ctrl":
        i = rng.randrange(len(text) + 1)
        text = text[:i] + rng.choice(["\x1b[31m", "\x00", "\x07", "\u2028", "\r"]) + text[i:]
    elif attack == "bytes":
        raw = bytearray(text.encode())
        for _ in range(rng.randint(1, 5)):
            if raw:
                raw[rng.randrange(len(raw))] = rng.randrange(256)
        return bytes(raw), suffix
    elif attack == "bigint":
        text = text.replace("640", "1" + "0" * rng.choice([20, 309, 400, 5000]), 1)
    elif as_yaml and attack in ("bomb", "alias", "tag", "recursive"):
        field = rng.choice(["hfov_deg", "width", "label", "score", "position"])
        if attack == "bomb":
            levels = rng.choice([4, 6, 9])
            text = "metadata:\n" + _bomb(levels) + text
            text = text.replace(f"{field}:", f"{field}: *b{levels}\n  _was:", 1) if f"{field}:" in text else text
        elif attack == "alias":
            text = "metadata:\n  shared: &s [1, 2, 3]\n" + text
            text = text.replace(f"{field}:", f"{field}: *s\n  _was:", 1) if f"{field}:" in text else text
        elif attack == "tag":
            tag = rng.choice(
                [
                    "!!python/object/apply:os.system ['true']",
                    "!!binary aGVsbG8=",
                    "!custom x",
                    "!!set {a}",
                    "!!timestamp 2024-01-01",
                ]
            )
            text = f"metadata: {tag}\n" + text
        else:
            text = "metadata: &r [*r]\n" + text
    return text.encode("utf-8", "surrogatepass"), suffix


def mutate_text_file(path: Path, rng: random.Random) -> None:
    """Edit a text fixture in place: token replaced, line dropped/duplicated, truncation, bad bytes."""
    raw = path.read_bytes()
    op = rng.choice(["token", "token", "line", "dup", "truncate", "bytes", "huge"])
    text = raw.decode("utf-8", "replace")
    lines = text.splitlines(keepends=True) or [""]
    i = rng.randrange(len(lines))
    if op == "token":
        tokens = [
            "nan",
            "inf",
            "-1",
            "1e308",
            "1e999",
            str(HUGE_INT),
            "true",
            "abc",
            "",
            "[",
            "{",
            "1.5",
            "-0",
            "~",
            "!!python/object x",
        ]
        words = lines[i].split(",") if "," in lines[i] else lines[i].split(" ")
        j = rng.randrange(len(words))
        words[j] = rng.choice(tokens)
        lines[i] = ("," if "," in lines[i] else " ").join(words)
    elif op == "line":
        del lines[i]
    elif op == "dup":
        lines.insert(i, lines[i])
    elif op == "truncate":
        lines = ["".join(lines)[: rng.randrange(len(text) + 1)]]
    elif op == "huge":
        lines.insert(i, lines[i] * 2000)
    else:
        b = bytearray(raw)
        for _ in range(rng.randint(1, 4)):
            if b:
                b[rng.randrange(len(b))] = rng.randrange(256)
        path.write_bytes(bytes(b))
        return
    path.write_text("".join(lines))
