"""The published session JSON Schema and the loader agree."""

from __future__ import annotations

import copy
import json
import warnings
from typing import Any

import io_scene as scene
import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from monovisual3d.errors import InputError, InputWarning
from monovisual3d.examples import example_session_path
from monovisual3d.io import session_schema, session_schema_path, validate_session_schema
from monovisual3d.session.load import session_from_dict

BASE: dict[str, Any] = {
    "camera": {"width": 640, "height": 480, "fx": 462.4, "fy": 462.4, "cx": 320.0, "cy": 240.0},
    "views": [
        {
            "pose": {"position": [0.0, 0.0, 0.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0]},
            "detections": [{"bbox_xyxy": [300.0, 220.0, 340.0, 260.0], "score": 0.9, "label": "tomato"}],
        }
    ],
}


def doc(**changes: Any) -> dict[str, Any]:
    """BASE with changes at dotted paths (``views.0.pose``); the value ``...`` deletes the key."""
    out = copy.deepcopy(BASE)
    for path, value in changes.items():
        *parents, last = path.split("__")
        node = out
        for p in parents:
            node = node[int(p)] if p.isdigit() else node[p]
        key = int(last) if last.isdigit() else last
        if value is ...:
            del node[key]
        else:
            node[key] = value
    return out


def loader_accepts(data: Any) -> bool:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        try:
            session_from_dict(data, "doc.json")
        except InputError:
            return False
    return True


def schema_accepts(data: Any) -> bool:
    return not validate_session_schema(data)


def test_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(session_schema())
    assert session_schema_path().name == "session.schema.json"


def test_example_and_imported_sessions_validate(tmp_path):
    assert validate_session_schema(json.loads(example_session_path().read_text())) == []
    assert validate_session_schema(scene.direct_session_dict()) == []
    assert validate_session_schema(scene.direct_session().to_dict()) == []


GOOD = {
    "pinhole": doc(),
    "hfov": doc(camera={"width": 640, "height": 480, "hfov_deg": 69}),
    "plumb_bob": doc(camera__distortion={"model": "plumb_bob", "coefficients": [0.1, -0.2, 0.0, 0.001, 0.01]}),
    "radtan_4": doc(camera__distortion={"model": "radtan", "coefficients": [0.1, -0.2, 0.0, 0.001]}),
    "default_model": doc(camera__distortion={"coefficients": [0.1, -0.2, 0.0, 0.001]}),
    "rational": doc(camera__distortion={"model": "rational_polynomial", "coefficients": [0.1] * 8}),
    "fisheye": doc(camera__distortion={"model": "fisheye", "coefficients": [0.1, 0.01, 0.0, 0.0]}),
    "zero_coefficients": doc(camera__distortion={"model": "equidistant", "coefficients": [0, 0]}),
    "null_distortion": doc(camera__distortion=None),
    "matrix_pose": doc(views__0__pose={"matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}),
    "camera_link": doc(pose_frame="camera_link"),
    "workspace": doc(workspace={"min": [0, 0, 0], "max": [1, 1, 1]}),
    "null_workspace": doc(workspace=None),
    "empty_detections": doc(views__0__detections=[]),
    "polygon_mask": doc(views__0__detections__0__mask={"polygon": [[300, 220], [340, 220], [320, 260]]}),
    "rle_mask": doc(views__0__detections__0__mask={"size": [480, 640], "counts": [1000, 50, 306150]}),
    "nulls": doc(views__0__detections__0__score=None, views__0__image=None, views__0__stamp=None),
    "extras": doc(metadata={"anything": [1, 2]}, views__0__name="v0", views__0__stamp=12.5, views__0__image="a.png"),
    "numeric_label": doc(views__0__detections__0__label=3, views__0__detections__0__class_id=3),
}

#: Structural problems: both reject.
BAD = {
    "no_camera": doc(camera=...),
    "no_views": doc(views=...),
    "empty_views": doc(views=[]),
    "unknown_top_level": doc(extra=1),
    "no_width": doc(camera__width=...),
    "string_width": doc(camera__width="640"),
    "bool_height": doc(camera__height=True),
    "zero_width": doc(camera__width=0),
    "hfov_and_fx": doc(camera__hfov_deg=60),
    "missing_cy": doc(camera__cy=...),
    "negative_fx": doc(camera__fx=-1.0),
    "hfov_200": doc(camera={"width": 640, "height": 480, "hfov_deg": 200}),
    "unknown_camera_key": doc(camera__skew=0),
    "camera_model_field": doc(camera__model="OAK-1"),
    "unknown_distortion_key": doc(camera__distortion={"modle": "fisheye", "coefficients": [0.1, 0, 0, 0]}),
    "unknown_model": doc(camera__distortion={"model": "kannala", "coefficients": [0.1]}),
    "plumb_bob_3": doc(camera__distortion={"model": "plumb_bob", "coefficients": [0.1, 0.2, 0.3]}),
    "rational_5": doc(camera__distortion={"model": "rational_polynomial", "coefficients": [0.1] * 5}),
    "no_coefficients": doc(camera__distortion={"model": "plumb_bob"}),
    "string_coefficient": doc(camera__distortion={"coefficients": ["0.1", 0, 0, 0]}),
    "both_pose_forms": doc(views__0__pose__matrix=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
    "matrix_3x3": doc(views__0__pose={"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}),
    "quaternion_3": doc(views__0__pose__quaternion_xyzw=[0, 0, 1]),
    "no_quaternion": doc(views__0__pose__quaternion_xyzw=...),
    "string_position": doc(views__0__pose__position=["0", 0, 0]),
    "no_detections": doc(views__0__detections=...),
    "no_bbox": doc(views__0__detections__0__bbox_xyxy=...),
    "bbox_3": doc(views__0__detections__0__bbox_xyxy=[1, 2, 3]),
    "score_1_5": doc(views__0__detections__0__score=1.5),
    "unknown_detection_key": doc(views__0__detections__0__confidence=0.9),
    "bad_mask": doc(views__0__detections__0__mask={"points": []}),
    "no_workspace_max": doc(workspace={"min": [0, 0, 0]}),
    "pose_frame_world": doc(pose_frame="world"),
    "numeric_image": doc(views__0__image=5),
    "string_stamp": doc(views__0__stamp="12"),
    "unknown_view_key": doc(views__0__T=[1]),
}

#: What only the loader can check (values, not structure): the schema accepts, the loader rejects.
SEMANTIC = {
    "quaternion_norm": doc(views__0__pose__quaternion_xyzw=[0, 0, 0.5, 0.5]),
    "reflection_matrix": doc(views__0__pose={"matrix": [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}),
    "box_x2_before_x1": doc(views__0__detections__0__bbox_xyxy=[340.0, 220.0, 300.0, 260.0]),
    "box_outside_image": doc(views__0__detections__0__bbox_xyxy=[700.0, 220.0, 740.0, 260.0]),
    "workspace_max_below_min": doc(workspace={"min": [1, 1, 1], "max": [0, 2, 2]}),
    "integral_float_width": doc(camera__width=640.0),
}


@pytest.mark.parametrize("name", sorted(GOOD))
def test_good_documents_pass_both(name):
    assert validate_session_schema(GOOD[name]) == []
    assert loader_accepts(GOOD[name])


@pytest.mark.parametrize("name", sorted(BAD))
def test_structural_errors_fail_both(name):
    assert validate_session_schema(BAD[name]), "schema should reject"
    assert not loader_accepts(BAD[name]), "loader should reject"


@pytest.mark.parametrize("name", sorted(SEMANTIC))
def test_value_checks_are_the_loaders(name):
    assert validate_session_schema(SEMANTIC[name]) == []
    assert not loader_accepts(SEMANTIC[name])


def test_schema_errors_name_the_json_path():
    errors = validate_session_schema(BAD["score_1_5"])
    assert errors == ["views[0].detections[0].score: 1.5 is greater than the maximum of 1"]


# ---------------------------------------------------------------------- property: loader accepts => schema accepts
def paths_of(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += paths_of(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += paths_of(v, prefix + (i,))
    return out


VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 1000),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
    st.sampled_from(["", "0", "1.0", "plumb_bob", "fisheye", "none", "camera_link", "optical", "tomato"]),
    st.lists(st.floats(-2, 700, allow_nan=False), min_size=0, max_size=5),
    st.lists(st.lists(st.sampled_from([0, 1, 0.0, 1.0, "1"]), min_size=4, max_size=4), min_size=4, max_size=4),
    st.sampled_from([{}, {"polygon": []}, {"coefficients": [0.1, 0, 0, 0]}, {"min": [0, 0, 0], "max": [1, 1, 1]}]),
)
DOCS = [GOOD["plumb_bob"], GOOD["matrix_pose"], GOOD["hfov"], GOOD["extras"], GOOD["workspace"]]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(DOCS), st.data(), st.sampled_from(["replace", "delete", "add", "retype"]), VALUES)
def test_whatever_the_loader_accepts_the_schema_accepts(base, data, action, value):
    d = copy.deepcopy(base)
    path = data.draw(st.sampled_from(paths_of(d)[1:]))
    parent = d
    for p in path[:-1]:
        parent = parent[p]
    key = path[-1]
    if action == "replace":
        parent[key] = value
    elif action == "retype":  # a number written as text or as a boolean
        old = parent[key]
        if isinstance(old, (int, float)) and not isinstance(old, bool):
            parent[key] = data.draw(st.sampled_from([str(old), bool(old), [old]]))
    elif action == "delete":
        del parent[key]
    elif isinstance(parent, dict):
        parent[data.draw(st.sampled_from(["extra", "model", "name", "label", "stamp", "image", "score", "mask"]))] = value
    else:
        parent.append(value)
    if loader_accepts(d):
        assert schema_accepts(d), f"loader accepted but schema rejected: {validate_session_schema(d)}"
