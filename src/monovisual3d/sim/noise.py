"""Detector and kinematics noise for simulated sessions (the paper's noise model and more).

Box noise (the paper's N(0, 0.05), defined relative to the box size)
--------------------------------------------------------------------
For a box with centre ``(cx, cy)``, width ``w`` and height ``h`` (pixels), and
``sigma = NoiseModel.box_sigma`` (paper: 0.05), four independent standard
normal draws ``z1..z4`` give::

    cx' = cx + sigma * w * z1          # centre moves by 5 % of the width (1 std)
    cy' = cy + sigma * h * z2
    w'  = w * max(1 + sigma * z3, 0.1)  # size scales by 1 +- 5 % (1 std)
    h'  = h * max(1 + sigma * z4, 0.1)

(the 0.1 floor only guards against negative sizes, probability ~1e-70 at
sigma = 0.05). The noisy box is then clipped to the image, as a detector's
boxes are; a box that ends up outside the image or under 1 px wide or high is
dropped.

Missed detections: each true detection is dropped independently with
probability ``drop_probability`` (paper: 0.02).

False positives: each image gets ``Poisson(false_positive_rate)`` extra boxes,
centre uniform over the image, width uniform in ``false_positive_size_px`` and
height = width times a log-uniform aspect in [0.8, 1.25], clipped to the image.

Camera-pose error: the pose written to the session is the true pose perturbed
by ``p' = p + e_p`` with ``e_p ~ N(0, pose_position_std^2 I3)`` (metres, per
base-frame axis) and ``R' = R @ exp([e_r]x)`` with ``e_r ~ N(0,
pose_rotation_std^2 I3)`` (radians, per axis of the camera's optical frame); the
image itself is rendered from the true pose. This mimics arm kinematics errors.

Hand-eye error: one rigid motion ``E`` of the camera in its own (optical) frame,
drawn once per session with ``hand_eye_position_std`` (metres) and
``hand_eye_rotation_std`` (radians) per axis (:func:`hand_eye_offset`), the same
in every view: ``T_base_optical_reported = T_base_optical' @ E``, as an error of
the hand-eye calibration ``T_ee_optical`` leaves it. Unlike the per-view error it
does not average out over views (docs/real.md, "A hand-eye calibration's error").
It is drawn after every other draw of a session, so the same seed gives the same
boxes with and without it.

All draws take ``rng`` (a :class:`numpy.random.Generator`, a seed, or None).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from ..checks import is_real
from ..errors import InputError
from ..frames import check_transform
from ..limits import MAX_SIM_FALSE_POSITIVES, MAX_SIM_POSE_ERROR_DEG, MAX_SIM_POSE_ERROR_MM

#: The paper's noisy simulation: N(0, 0.05) on box centre and size, 2 % missed detections.
PAPER_BOX_SIGMA = 0.05
PAPER_DROP_PROBABILITY = 0.02
#: Size floor of the multiplicative size noise.
MIN_SIZE_FACTOR = 0.1
#: The narrowest visible part of an object (pixels) a detector of visible parts reports (:func:`wholly_hidden`): two
#: pixels, the edge noise of exact boxes (``bayes``'s ``sigma0_px`` is one).
MIN_VISIBLE_PX = 2.0
#: The ``monovisual3d simulate`` option of each noise parameter, for messages.
CLI_OPTIONS = {
    "box_sigma": "--noise",
    "drop_probability": "--drop",
    "false_positive_rate": "--false-positives",
    "pose_error_mm": "--pose-error-mm",
    "pose_error_deg": "--pose-error-deg",
    "hand_eye_error_mm": "--hand-eye-error-mm",
    "hand_eye_error_deg": "--hand-eye-error-deg",
}


def _option(name: str) -> str:
    """``--noise (noise.box_sigma)``: the CLI option and the NoiseModel field, for messages."""
    if name.startswith(("pose_error_", "hand_eye_error_")):  # parameters of NoiseModel.from_mm_deg, not fields
        return f"{CLI_OPTIONS[name]} ({name})"
    return f"{CLI_OPTIONS[name]} (noise.{name})" if name in CLI_OPTIONS else f"noise.{name}"


def _check_at_most(value: float, most: float, name: str) -> None:
    """Refuse a noise parameter beyond its documented limit (:mod:`monovisual3d.limits`)."""
    if value > most:
        raise InputError(f"{_option(name)}: got {value:g}, more than the {most:g} accepted")


#: The pose-error fields of :class:`NoiseModel`: per view, then the session's hand-eye error.
_POSE_FIELDS = ("pose_position_std", "pose_rotation_std", "hand_eye_position_std", "hand_eye_rotation_std")


@dataclass(frozen=True)
class NoiseModel:
    """Noise applied by the simulator (see the module docstring for the exact definitions).

    Attributes
    ----------
    box_sigma : float
        Std of the box-centre shift and of the relative size change, as a fraction of the box size (paper: 0.05).
    drop_probability : float
        Probability that a true detection is missed, in [0, 1] (paper: 0.02).
    false_positive_rate : float
        Expected number of false-positive boxes per image (Poisson mean).
    false_positive_size_px : tuple (min, max)
        Range of false-positive box widths, pixels.
    pose_position_std : float
        Std of the reported camera position error per base-frame axis, metres.
    pose_rotation_std : float
        Std of the reported camera rotation error per optical-frame axis, radians.
    hand_eye_position_std, hand_eye_rotation_std : float
        Std per optical-frame axis (metres, radians) of the one hand-eye error of the session, the same in every view.

    Examples
    --------
    >>> NoiseModel.paper().box_sigma, NoiseModel.paper().drop_probability
    (0.05, 0.02)
    >>> NoiseModel().is_noiseless
    True
    """

    box_sigma: float = 0.0
    drop_probability: float = 0.0
    false_positive_rate: float = 0.0
    false_positive_size_px: tuple[float, float] = (10.0, 120.0)
    pose_position_std: float = 0.0
    pose_rotation_std: float = 0.0
    hand_eye_position_std: float = 0.0
    hand_eye_rotation_std: float = 0.0

    def __post_init__(self) -> None:
        for name in ("box_sigma", "false_positive_rate", *_POSE_FIELDS):
            value = getattr(self, name)
            if not is_real(value) or not (math.isfinite(value) and value >= 0):
                raise InputError(f"{_option(name)}: got {value!r}, expected a finite number >= 0")
            object.__setattr__(self, name, float(value))
        _check_at_most(self.false_positive_rate, MAX_SIM_FALSE_POSITIVES, "false_positive_rate")
        for name in _POSE_FIELDS:
            most = MAX_SIM_POSE_ERROR_MM / 1000.0 if name.endswith("position_std") else math.radians(MAX_SIM_POSE_ERROR_DEG)
            _check_at_most(getattr(self, name), most, name)
        p = self.drop_probability
        if not is_real(p) or not 0.0 <= p <= 1.0:
            raise InputError(f"{_option('drop_probability')}: got {p!r}, expected a probability in [0, 1]")
        object.__setattr__(self, "drop_probability", float(p))
        try:
            lo, hi = (float(v) for v in self.false_positive_size_px)
        except (TypeError, ValueError):
            raise InputError(
                f"noise.false_positive_size_px: got {self.false_positive_size_px!r}, expected (min, max) pixels"
            ) from None
        if not (1.0 <= lo <= hi and math.isfinite(hi)):
            raise InputError(f"noise.false_positive_size_px: got ({lo}, {hi}), expected 1 <= min <= max pixels")
        object.__setattr__(self, "false_positive_size_px", (lo, hi))

    @classmethod
    def paper(cls, **overrides: Any) -> NoiseModel:
        """The paper's noisy simulation (box_sigma 0.05, drop_probability 0.02), with optional overrides."""
        return cls(**{"box_sigma": PAPER_BOX_SIGMA, "drop_probability": PAPER_DROP_PROBABILITY, **overrides})

    @classmethod
    def from_mm_deg(
        cls,
        *,
        box_sigma: float = 0.0,
        drop_probability: float = 0.0,
        false_positive_rate: float = 0.0,
        pose_error_mm: float = 0.0,
        pose_error_deg: float = 0.0,
        hand_eye_error_mm: float = 0.0,
        hand_eye_error_deg: float = 0.0,
    ) -> NoiseModel:
        """Constructor with the pose and hand-eye errors in millimetres and degrees (as the CLI takes them)."""
        bounds = (
            ("pose_error_mm", pose_error_mm, MAX_SIM_POSE_ERROR_MM),
            ("pose_error_deg", pose_error_deg, MAX_SIM_POSE_ERROR_DEG),
            ("hand_eye_error_mm", hand_eye_error_mm, MAX_SIM_POSE_ERROR_MM),
            ("hand_eye_error_deg", hand_eye_error_deg, MAX_SIM_POSE_ERROR_DEG),
        )
        for name, value, most in bounds:
            if not (is_real(value) and math.isfinite(value) and value >= 0):
                raise InputError(f"{_option(name)}: got {value!r}, expected a finite number >= 0")
            if value > most:
                raise InputError(f"{_option(name)}: got {value:g}, more than the {most:g} accepted")
        return cls(
            box_sigma=box_sigma,
            drop_probability=drop_probability,
            false_positive_rate=false_positive_rate,
            pose_position_std=pose_error_mm / 1000.0,
            pose_rotation_std=math.radians(pose_error_deg),
            hand_eye_position_std=hand_eye_error_mm / 1000.0,
            hand_eye_rotation_std=math.radians(hand_eye_error_deg),
        )

    @property
    def is_noiseless(self) -> bool:
        """True when the model changes nothing."""
        return (
            self.box_sigma == 0
            and self.drop_probability == 0
            and self.false_positive_rate == 0
            and all(getattr(self, name) == 0 for name in _POSE_FIELDS)
        )

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["false_positive_size_px"] = list(self.false_positive_size_px)
        return out

    def apply_to_boxes(
        self, boxes_xyxy: ArrayLike, image_size: tuple[int, int], rng: np.random.Generator | int | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Noisy detections of one image: perturb, drop, clip and add false positives.

        Parameters
        ----------
        boxes_xyxy : array_like, shape (N, 4), pixels, the true visible boxes
        image_size : (width, height), pixels
        rng : numpy Generator, seed or None

        Returns
        -------
        boxes_xyxy : ndarray, shape (K, 4), pixels, the reported boxes (true ones first, then false positives)
        source : ndarray, shape (K,), int64, index into the input boxes, -1 for false positives
        """
        rng = np.random.default_rng(rng)
        boxes = _check_boxes(boxes_xyxy)
        width, height = image_size
        source = np.arange(len(boxes))
        if self.drop_probability > 0:
            keep = ~drop_mask(len(boxes), self.drop_probability, rng)
            boxes, source = boxes[keep], source[keep]
        if self.box_sigma > 0:
            boxes = perturb_boxes(boxes, self.box_sigma, rng)
        if self.false_positive_rate > 0:
            fp = false_positive_boxes(image_size, self.false_positive_rate, rng, size_range_px=self.false_positive_size_px)
            boxes = np.concatenate([boxes, fp])
            source = np.concatenate([source, np.full(len(fp), -1)])
        boxes, ok = clip_boxes_to_image(boxes, width, height)
        return boxes[ok], source[ok].astype(np.int64)

    def apply_to_pose(self, T_base_optical: ArrayLike, rng: np.random.Generator | int | None = None) -> NDArray[np.float64]:
        """The pose reported for a camera truly at ``T_base_optical`` (4, 4) before the session's hand-eye error (the
        simulator applies that to every view); see :func:`perturb_pose`."""
        return perturb_pose(T_base_optical, self.pose_position_std, self.pose_rotation_std, rng)

    def hand_eye_error(self, rng: np.random.Generator | int | None = None) -> NDArray[np.float64] | None:
        """The session's hand-eye error ``E`` (4, 4, optical frame; :func:`hand_eye_offset`), or None (drawing
        nothing) when its stds are zero, so that sessions without one draw the same numbers as before."""
        if self.hand_eye_position_std == 0 and self.hand_eye_rotation_std == 0:
            return None
        return hand_eye_offset(self.hand_eye_position_std, self.hand_eye_rotation_std, rng)


def perturb_boxes(boxes_xyxy: ArrayLike, sigma: float, rng: np.random.Generator | int | None = None) -> NDArray[np.float64]:
    """Gaussian noise on box centres and sizes relative to the box size (not clipped).

    Parameters
    ----------
    boxes_xyxy : array_like, shape (N, 4), pixels
    sigma : float, relative std (paper: 0.05)
    rng : numpy Generator, seed or None

    Returns
    -------
    boxes_xyxy : ndarray, shape (N, 4), pixels

    Examples
    --------
    >>> perturb_boxes([[100, 100, 140, 120]], 0.0, rng=0)
    array([[100., 100., 140., 120.]])
    """
    rng = np.random.default_rng(rng)
    boxes = _check_boxes(boxes_xyxy)
    if not (math.isfinite(sigma) and sigma >= 0):
        raise InputError(f"sigma: got {sigma!r}, expected a finite number >= 0")
    z = rng.standard_normal((len(boxes), 4))
    size = boxes[:, 2:] - boxes[:, :2]
    centre = 0.5 * (boxes[:, :2] + boxes[:, 2:]) + sigma * size * z[:, :2]
    new_size = size * np.maximum(1.0 + sigma * z[:, 2:], MIN_SIZE_FACTOR)
    return np.concatenate([centre - 0.5 * new_size, centre + 0.5 * new_size], axis=1)


def drop_mask(n: int, probability: float, rng: np.random.Generator | int | None = None) -> NDArray[np.bool_]:
    """Shape (n,): True for each detection that is missed (independent Bernoulli draws).

    Examples
    --------
    >>> drop_mask(3, 0.0, rng=0)
    array([False, False, False])
    """
    if not 0.0 <= probability <= 1.0:
        raise InputError(f"drop_probability: got {probability!r}, expected a probability in [0, 1]")
    rng = np.random.default_rng(rng)
    return rng.random(n) < probability


def false_positive_boxes(
    image_size: tuple[int, int],
    rate: float,
    rng: np.random.Generator | int | None = None,
    *,
    size_range_px: tuple[float, float] = (10.0, 120.0),
) -> NDArray[np.float64]:
    """Random spurious boxes for one image (not clipped).

    Parameters
    ----------
    image_size : (width, height), pixels
    rate : float, expected number of boxes (Poisson mean)
    rng : numpy Generator, seed or None
    size_range_px : (min, max), box width range in pixels

    Returns
    -------
    boxes_xyxy : ndarray, shape (K, 4), pixels, K ~ Poisson(rate)

    Examples
    --------
    >>> false_positive_boxes((640, 480), 0.0, rng=0).shape
    (0, 4)
    """
    if not (math.isfinite(rate) and rate >= 0):
        raise InputError(f"false_positive_rate: got {rate!r}, expected a finite number >= 0")
    rng = np.random.default_rng(rng)
    width, height = image_size
    k = int(rng.poisson(rate))
    w = rng.uniform(size_range_px[0], size_range_px[1], k)
    h = w * np.exp(rng.uniform(math.log(0.8), math.log(1.25), k))
    cx = rng.uniform(0.0, width, k)
    cy = rng.uniform(0.0, height, k)
    return np.stack([cx - 0.5 * w, cy - 0.5 * h, cx + 0.5 * w, cy + 0.5 * h], axis=1).reshape(-1, 4)


def perturb_pose(
    T_base_optical: ArrayLike,
    position_std: float,
    rotation_std: float,
    rng: np.random.Generator | int | None = None,
) -> NDArray[np.float64]:
    """A pose with a random rigid error: position in the base frame, rotation about the optical axes.

    Parameters
    ----------
    T_base_optical : array_like, shape (4, 4)
    position_std : float, metres, std per base-frame axis
    rotation_std : float, radians, std per optical-frame axis (rotation vector components)
    rng : numpy Generator, seed or None

    Returns
    -------
    T_base_optical_reported : ndarray, shape (4, 4)

    Examples
    --------
    >>> perturb_pose(np.eye(4), 0.0, 0.0, rng=0)[:3, 3]
    array([0., 0., 0.])
    """
    T = check_transform(T_base_optical, where="T_base_optical")
    for name, value in (("position_std", position_std), ("rotation_std", rotation_std)):
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"{name}: got {value!r}, expected a finite number >= 0")
    rng = np.random.default_rng(rng)
    e = rng.standard_normal(6)
    out = T.copy()
    out[:3, 3] += position_std * e[:3]
    out[:3, :3] = T[:3, :3] @ Rotation.from_rotvec(rotation_std * e[3:]).as_matrix()
    return out


def hand_eye_offset(
    position_std: float, rotation_std: float, rng: np.random.Generator | int | None = None
) -> NDArray[np.float64]:
    """A random rigid error ``E`` (4, 4) of a camera in its own optical frame: a hand-eye calibration's error.

    ``T_base_optical @ E`` is the pose reported for a camera truly at ``T_base_optical``; the same ``E`` in every
    view of a session (an eye-in-hand camera: ``T_base_ee @ T_ee_optical @ E``).

    Parameters
    ----------
    position_std : float, metres, std per optical-frame axis
    rotation_std : float, radians, std per optical-frame axis (rotation vector components)
    rng : numpy Generator, seed or None

    Examples
    --------
    >>> E = hand_eye_offset(0.001, 0.005, rng=0)
    >>> bool(np.allclose(E[:3, :3] @ E[:3, :3].T, np.eye(3))), bool(np.linalg.norm(E[:3, 3]) < 0.01)
    (True, True)
    """
    return perturb_pose(np.eye(4), position_std, rotation_std, rng)


def clip_boxes_to_image(
    boxes_xyxy: ArrayLike, width: int, height: int, *, min_size_px: float = 1.0
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Clip boxes (N, 4) to ``[0, width] x [0, height]``.

    Returns
    -------
    boxes_xyxy : ndarray, shape (N, 4), the clipped boxes
    ok : ndarray, shape (N,), bool, False where the clipped box is under ``min_size_px`` wide or high
    """
    b = np.array(boxes_xyxy, dtype=float).reshape(-1, 4)
    b[:, [0, 2]] = np.clip(b[:, [0, 2]], 0.0, float(width))
    b[:, [1, 3]] = np.clip(b[:, [1, 3]], 0.0, float(height))
    ok = (b[:, 2] - b[:, 0] >= min_size_px) & (b[:, 3] - b[:, 1] >= min_size_px)
    return b, ok


def visible_part_boxes(boxes_xyxy: ArrayLike, depths: ArrayLike) -> NDArray[np.float64]:
    """The boxes a detector of visible parts draws around upright objects side by side, which hide each other by
    vertical strips: where a nearer object's whole box spans a farther box's height and overlaps it from one side,
    the farther box ends at the nearer box's edge; a farther box wholly behind keeps its box (its visible strips
    still span it), and so does one whose top or bottom shows.

    Parameters
    ----------
    boxes_xyxy : array_like, shape (K, N, 4), pixels: the whole boxes of N objects in K views
    depths : array_like, shape (K, N), metres: each object's depth along each view's optical axis

    Returns
    -------
    ndarray, shape (K, N, 4): the boxes of the visible parts

    Examples
    --------
    >>> boxes = np.array([[[100.0, 50, 200, 300], [150.0, 60, 260, 290]]])
    >>> visible_part_boxes(boxes, np.array([[0.5, 0.6]]))[0, 1].tolist()  # the farther one, hidden on its left
    [200.0, 60.0, 260.0, 290.0]
    """
    whole = np.asarray(boxes_xyxy, dtype=float)
    d = np.asarray(depths, dtype=float)
    if whole.ndim != 3 or whole.shape[2] != 4 or d.shape != whole.shape[:2]:
        raise InputError(f"boxes_xyxy and depths: expected shapes (K, N, 4) and (K, N), got {whole.shape} and {d.shape}")
    out = whole.copy()
    for k in range(len(whole)):
        for far in range(whole.shape[1]):
            f = out[k, far]
            for near in np.flatnonzero(d[k] < d[k, far]):
                n = whole[k, near]
                if n[1] > f[1] or n[3] < f[3]:
                    continue  # the nearer box does not span the farther one's height: its edges stay visible
                if n[0] <= f[0] < n[2] < f[2]:
                    f[0] = n[2]  # hidden on its left
                elif f[0] < n[0] < f[2] <= n[2]:
                    f[2] = n[0]  # hidden on its right
    return out


def wholly_hidden(boxes_xyxy: ArrayLike, depths: ArrayLike, min_visible_px: float = MIN_VISIBLE_PX) -> NDArray[np.bool_]:
    """Which objects a detector of visible parts sees nothing of, and draws no box for: those whose whole box lies
    inside a nearer object's whole box (two containers in line with the camera), or whose visible part
    (:func:`visible_part_boxes`) is narrower than ``min_visible_px``.

    Parameters
    ----------
    boxes_xyxy : array_like, shape (K, N, 4), pixels: the whole boxes of N objects in K views
    depths : array_like, shape (K, N), metres: each object's depth along each view's optical axis
    min_visible_px : float, pixels: the narrowest visible part a detector reports

    Returns
    -------
    ndarray, shape (K, N), bool

    Examples
    --------
    >>> boxes = np.array([[[100.0, 50, 200, 300], [120.0, 60, 180, 290], [150.0, 60, 260, 290]]])
    >>> wholly_hidden(boxes, np.array([[0.5, 0.6, 0.7]])).tolist()
    [[False, True, False]]
    """
    whole = np.asarray(boxes_xyxy, dtype=float)
    d = np.asarray(depths, dtype=float)
    visible = visible_part_boxes(whole, d)
    nearer = d[:, None, :] < d[:, :, None]  # (K, far, near)
    inside = np.all(whole[:, None, :, :2] <= whole[:, :, None, :2], axis=3) & np.all(
        whole[:, None, :, 2:] >= whole[:, :, None, 2:], axis=3
    )
    return np.any(nearer & inside, axis=2) | (visible[..., 2] - visible[..., 0] < min_visible_px)


def _check_boxes(boxes_xyxy: ArrayLike) -> NDArray[np.float64]:
    b = np.asarray(boxes_xyxy, dtype=float)
    if b.size == 0:
        return np.zeros((0, 4))
    if b.ndim != 2 or b.shape[1] != 4:
        raise InputError(f"boxes_xyxy: expected shape (N, 4), got {b.shape}")
    if not np.all(np.isfinite(b)):
        raise InputError("boxes_xyxy: contains NaN or infinity")
    if np.any(b[:, 2] < b[:, 0]) or np.any(b[:, 3] < b[:, 1]):
        raise InputError("boxes_xyxy: has x2 < x1 or y2 < y1, expected (x1, y1, x2, y2)")
    return b
