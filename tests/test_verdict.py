import pytest

from monovisual3d.verdict import CAUSES, Cause, verdict_of


def test_verdict_is_the_most_severe_cause():
    assert verdict_of([]) == "ok"
    causes = [Cause("scatter", "a", "suspect"), Cause("image_size", "b", "unreliable")]
    assert verdict_of(causes) == "unreliable"
    assert verdict_of(causes[:1]) == "suspect"


def test_cause_rejects_unknown_ids_and_severities():
    with pytest.raises(ValueError, match="unknown cause"):
        Cause("nonsense", "x")
    with pytest.raises(ValueError, match="severity"):
        Cause("scatter", "x", "ok")


def test_cause_as_json_names_the_cause():
    d = Cause("hand_eye", "a hand-eye error", views=(1, 2), details={"k2": 3.0}).to_dict()
    assert d == {
        "cause": "hand_eye",
        "message": "a hand-eye error",
        "severity": "suspect",
        "views": [1, 2],
        "details": {"k2": 3.0},
    }
    assert set(CAUSES) >= {
        "image_size",
        "box_coordinates",
        "hand_eye",
        "time_offset",
        "view_disagrees",
        "duplicate_views",
        "pose_convention",
        "distortion",
        "one_pose",
    }
