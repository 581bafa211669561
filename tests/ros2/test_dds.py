"""The DDS endpoints as ROS 2 makes them: QoS matching, late joiners, data representation, type hash, domain."""

from __future__ import annotations

import time

import pytest

pytest.importorskip("cyclonedds", reason="needs the cyclonedds package (pip install 'monovisual3d[ros2]')")

from monovisual3d.errors import InputError  # noqa: E402
from monovisual3d.ros2 import dds, msgs  # noqa: E402


@pytest.fixture
def ep():  # noqa: ANN201
    dp = dds.participant(dds.domain_id_from_env())
    yield dds.Endpoints(dp)
    dp.__del__()


def _received(reader, timeout_s: float = 5.0) -> list:  # noqa: ANN001
    deadline, got = time.monotonic() + timeout_s, []
    while time.monotonic() < deadline and not got:
        got = reader.take(16)
        time.sleep(0.02)
    return got


@pytest.mark.parametrize("publisher", ["default", "sensor"], ids=["reliable", "best-effort"])
def test_detections_reader_hears_reliable_and_best_effort_publishers(ep, publisher: str) -> None:  # noqa: ANN001
    topic = f"/qos_{publisher}/detections"
    reader = ep.reader(topic, msgs.Detection2DArray, dds.sensor_reader_qos())
    writer = ep.writer(topic, msgs.Detection2DArray, dds.publisher_qos(publisher))
    time.sleep(0.3)
    writer.write(msgs.Detection2DArray(header=msgs.Header(frame_id="cam")))
    assert [m.header.frame_id for m in _received(reader)] == ["cam"]


def test_a_reliable_reader_does_not_hear_best_effort(ep) -> None:  # noqa: ANN001
    """Why the inputs are best effort by default (--reliable-inputs makes them reliable)."""
    reader = ep.reader("/qos_strict/detections", msgs.Detection2DArray, dds.sensor_reader_qos(reliable=True))
    writer = ep.writer("/qos_strict/detections", msgs.Detection2DArray, dds.publisher_qos("sensor"))
    time.sleep(0.3)
    writer.write(msgs.Detection2DArray())
    assert _received(reader, 0.5) == []


def test_static_tf_and_outputs_reach_late_subscribers(ep) -> None:  # noqa: ANN001
    static = ep.writer("/late/tf_static", msgs.TFMessage, dds.publisher_qos("tf_static"))
    static.write(msgs.TFMessage(transforms=[msgs.TransformStamped(child_frame_id="cam")]))
    out = ep.writer("/late/status", msgs.String, dds.output_writer_qos())
    out.write(msgs.String("old"))
    out.write(msgs.String("latest"))
    time.sleep(0.2)
    tf_reader = ep.reader("/late/tf_static", msgs.TFMessage, dds.tf_static_reader_qos())
    status_reader = ep.reader("/late/status", msgs.String, dds.tf_static_reader_qos())  # a transient-local subscriber
    assert _received(tf_reader)[0].transforms[0].child_frame_id == "cam"
    assert [m.data for m in _received(status_reader)] == ["latest"]


def test_writers_offer_plain_cdr_and_carry_the_type_hash(ep) -> None:  # noqa: ANN001
    writer = ep.writer("/repr/detections", msgs.Detection3DArray, dds.output_writer_qos())
    reader = ep.reader("/repr/detections", msgs.Detection3DArray, dds.tf_reader_qos())
    deadline = time.monotonic() + 5
    while not reader.get_matched_publications() and time.monotonic() < deadline:
        time.sleep(0.02)
    qos = reader.get_matched_publication_data(reader.get_matched_publications()[0]).qos
    policies = {type(p).__name__: p for p in qos}
    representation = policies["DataRepresentation"]
    assert representation.use_cdrv0_representation and not representation.use_xcdrv2_representation  # XCDR1 only
    assert policies["Userdata"].data == msgs.user_data(msgs.Detection3DArray)
    assert writer.get_matched_subscriptions()


@pytest.mark.parametrize(("value", "domain"), [("", 0), (" 7 ", 7), ("232", 232)])
def test_domain_from_ros_domain_id(value: str, domain: int) -> None:
    assert dds.domain_id_from_env({"ROS_DOMAIN_ID": value}) == domain
    assert dds.domain_id_from_env({}) == 0


@pytest.mark.parametrize("value", ["-1", "233", "x", "1.5"])
def test_bad_ros_domain_id(value: str) -> None:
    with pytest.raises(InputError, match=r"ROS_DOMAIN_ID: got .*, expected an integer from 0 to 232"):
        dds.domain_id_from_env({"ROS_DOMAIN_ID": value})


def test_one_topic_one_type(ep) -> None:  # noqa: ANN001
    ep.reader("/typed", msgs.String, dds.tf_reader_qos())
    with pytest.raises(InputError, match="topic /typed: used with two message types, String and Empty"):
        ep.writer("/typed", msgs.Empty, dds.output_writer_qos())
