"""Wire compatibility: every message class serialises to the bytes ``rosbags`` gives for the ROS 2 definitions.

``rosbags`` carries the message definitions of each ROS 2 distribution (``Stores.ROS2_HUMBLE``,
``Stores.ROS2_JAZZY``) and serialises CDR as ROS 2 does. vision_msgs is not in its stores: the package's
``.msg`` definitions (:data:`monovisual3d.io.ros_messages.VISION_MSGS_ROS2`) are registered, after a check
against the independent transcription below. Each message is filled with seeded random values (sequences of 0-3
items, strings of 0-6 characters, so every alignment case occurs) from the *rosbags* field definitions, then
built both ways and serialised.
"""

from __future__ import annotations

import string
from typing import Any

import numpy as np
import pytest

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")
typesys = pytest.importorskip("rosbags.typesys", reason="needs rosbags (pip install 'monovisual3d[ros]')")

from ros_reference import VISION_MSGS_4  # noqa: E402

from monovisual3d.io.ros_messages import VISION_MSGS_ROS2  # noqa: E402
from monovisual3d.ros2 import msgs  # noqa: E402
from monovisual3d.ros2.names import dds_type  # noqa: E402

DISTROS = {"humble": typesys.Stores.ROS2_HUMBLE, "jazzy": typesys.Stores.ROS2_JAZZY}


def _types_from(defs: dict[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, text in defs.items():
        out.update(typesys.get_types_from_msg(text, name))
    return out


def _store(distro: str) -> Any:
    store = typesys.get_typestore(DISTROS[distro])
    store.register(_types_from(VISION_MSGS_ROS2))
    return store


def test_the_package_vision_msgs_are_those_of_humble_and_jazzy() -> None:
    assert _types_from(VISION_MSGS_ROS2) == _types_from(VISION_MSGS_4)


# ----------------------------------------------------------------------------- random values from rosbags' definitions
_FLOATS = {"float32", "float64"}
_INTS = {"int8": (-128, 127), "uint8": (0, 255), "int16": (-(2**15), 2**15 - 1), "uint16": (0, 2**16 - 1)}
_INTS |= {"int32": (-(2**31), 2**31 - 1), "uint32": (0, 2**32 - 1), "int64": (-(2**63), 2**63 - 1), "uint64": (0, 2**64 - 1)}


def _base_value(kind: str, rng: np.random.Generator) -> Any:
    if kind in _FLOATS:
        return float(np.float32(rng.normal(0, 100))) if kind == "float32" else float(rng.normal(0, 100))
    if kind == "bool":
        return bool(rng.integers(2))
    if kind == "string":
        return "".join(rng.choice(list(string.ascii_letters + "/_"), size=int(rng.integers(0, 7))))
    lo, hi = _INTS[kind]
    return int(rng.integers(lo, hi, endpoint=True, dtype=np.uint64 if kind == "uint64" else np.int64))


def _value(node: Any, store: Any, rng: np.random.Generator) -> Any:
    """A random value for a rosbags field node: a base value, ``("msg", name, {field: value})``, or a list."""
    kind, detail = node
    if kind == typesys.base.Nodetype.BASE:
        return _base_value(detail[0], rng)
    if kind == typesys.base.Nodetype.NAME:
        return ("msg", detail, {name: _value(sub, store, rng) for name, sub in store.fielddefs[detail][1]})
    sub, count = detail
    n = count if kind == typesys.base.Nodetype.ARRAY else int(rng.integers(0, 4))
    return [_value(sub, store, rng) for _ in range(n)]


def _ours(v: Any) -> Any:
    if isinstance(v, tuple):
        return msgs.MESSAGE_TYPES[v[1]](**{k: _ours(x) for k, x in v[2].items()})
    return [_ours(x) for x in v] if isinstance(v, list) else v


def _theirs(v: Any, node: Any, store: Any) -> Any:
    kind, detail = node
    if kind == typesys.base.Nodetype.NAME:
        fields = dict(store.fielddefs[detail][1])
        return store.types[detail](**{k: _theirs(x, fields[k], store) for k, x in v[2].items()})
    if kind == typesys.base.Nodetype.BASE:
        return v
    sub = detail[0]
    if sub[0] == typesys.base.Nodetype.BASE and sub[1][0] != "string":
        return np.array(v, dtype={"bool": np.bool_}.get(sub[1][0], sub[1][0]))
    return [_theirs(x, sub, store) for x in v]


@pytest.mark.parametrize("distro", sorted(DISTROS))
@pytest.mark.parametrize("ros_type", sorted(msgs.MESSAGE_TYPES))
def test_bytes_equal_rosbags_serialisation(ros_type: str, distro: str) -> None:
    store = _store(distro)
    rng = np.random.default_rng(sum(map(ord, ros_type + distro)))
    for _ in range(5):
        value = _value((typesys.base.Nodetype.NAME, ros_type), store, rng)
        ours = _ours(value).serialize()
        theirs = bytes(store.serialize_cdr(_theirs(value, (typesys.base.Nodetype.NAME, ros_type), store), ros_type))
        assert ours == theirs
        back = msgs.MESSAGE_TYPES[ros_type].deserialize(theirs)
        assert back.serialize() == theirs


def test_every_class_carries_the_ros2_dds_type_name() -> None:
    for ros_type, cls in msgs.MESSAGE_TYPES.items():
        assert cls.__idl_typename__ == dds_type(ros_type)
        assert cls.__idl__.idl_transformed_typename == dds_type(ros_type)


def test_the_classes_cover_every_type_they_nest() -> None:
    """Each message class's nested types are classes here too (rosbags' Humble definitions name them)."""
    store = _store("humble")
    for ros_type in msgs.MESSAGE_TYPES:
        for _, (kind, detail) in store.fielddefs[ros_type][1]:
            nested = (
                detail
                if kind == typesys.base.Nodetype.NAME
                else detail[0][1]
                if detail[0][0] == typesys.base.Nodetype.NAME
                else None
            )
            assert nested is None or nested in msgs.MESSAGE_TYPES, f"{ros_type} nests {nested}"


def test_type_hashes_are_those_of_jazzy() -> None:
    """The ``typehash=RIHS01_...;`` the endpoints carry in USER_DATA, as ROS 2 Iron and later compute it."""
    store = _store("jazzy")
    assert msgs.TYPE_HASHES == {name: store.hash_rihs01(name) for name in msgs.TYPE_HASHES}
    assert msgs.user_data(msgs.String) == f"typehash={store.hash_rihs01('std_msgs/msg/String')};".encode()
    assert msgs.user_data(msgs.Header) == b""
