"""Options of the ``bayes`` method (:class:`BayesConfig`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ...checks import is_real
from ...errors import InputError
from ...limits import DEFAULT_MAX_BYTES, DEFAULT_REACH_M, MIN_SEARCH_RESOLUTION_M
from ..options import check_shared_options, nested_config, plain_options
from .sensor import SensorModel

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

#: Object models of ``BayesConfig.shape``.
SHAPES = ("auto", "sphere", "spheroid", "ellipsoid")
#: The on/off switches of :class:`BayesTuning` (true or false).
SWITCHES = ("swap", "steal", "regroup", "shape_swap", "second_look", "view_assign", "one_sided_refit")
#: Elongated search bins use every this-many-th radius bin: their coarser size steps (~30 % with the default
#: bins) cost a fraction of a nat per edge, the refinement fixes the size, and the search costs less.
ELONGATED_RADIUS_STRIDE = 2
#: Ratio of neighbouring radius bins when ``n_radii`` is None: 2 ** (1 / 5), about 15 % (a sphere's box edges then move
#: by at most 7 % of its size between bins, about one sensor sigma); the default 10-160 mm has 21 bins.
RADIUS_BIN_RATIO = 2.0**0.2
#: Semi-axis bounds of the shape fits when no ``size_range`` is given, metres: 5 mm (a tray's or a lid's half-thickness)
#: to 160 mm (a tray's half-length); widened to the search's radii where those reach further.
FIT_SEMI_AXIS_RANGE_M = (0.005, 0.16)
#: A refined radius (or semi-axis along the axis) outside ``[radius_min / f, f * radius_max]`` with this ``f`` means the
#: fit diverged: the object keeps the estimate it had (:attr:`BayesConfig.fit_radius_range`). A chosen margin, not a
#: fitted one: the search's radii already lie in ``[radius_min, radius_max]``; twice beyond that range is divergence.
DIVERGED_RADIUS_FACTOR = 2.0
#: Self-calibrations of ``BayesConfig.calibrate``: none, or one camera-frame (hand-eye) correction shared by all views.
CALIBRATIONS = ("none", "hand-eye")
#: Edge noise of ``BayesConfig.edge_noise``: raised to the session's box scatter where it exceeds the sensor model's
#: (:mod:`.edge_noise`), or as stated (``alpha``).
EDGE_NOISES = ("auto", "stated")
#: Compute backends of the ``bayes`` method: the fused numba kernels (default) and the numpy reference.
BACKENDS = ("numba", "numpy")


def _is_bool(value: Any) -> bool:
    """Whether ``value`` is true or false (a numpy bool too)."""
    return isinstance(value, bool) or type(value).__name__ == "bool_"


def _nested(value: Any, cls: type, name: str) -> Any:
    """A nested options object: ``value`` itself, or built from a mapping of its fields (a config read from JSON)."""
    if isinstance(value, cls):
        return value
    if isinstance(value, dict):
        return nested_config(cls, value, name)
    raise InputError(f"{name}: got {type(value).__name__}, expected a {cls.__name__} or a mapping of its fields")


def _floats(value: Any, n: int, name: str, expected: str) -> NDArray[np.float64]:
    """``n`` finite numbers from a sequence or a comma-separated string."""
    import numpy as np

    items: Any = value.split(",") if isinstance(value, str) else value
    try:
        out = np.array([float(v) for v in items], dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: got {str(value)[:60]!r}, expected {expected}") from None
    if (
        out.shape != (n,)
        or not np.all(np.isfinite(out))
        or (not isinstance(value, str) and any(isinstance(v, bool) for v in items))
    ):
        raise InputError(f"{name}: got {str(value)[:60]!r}, expected {expected}")
    return out


@dataclass(frozen=True)
class BayesTuning:
    """The ``bayes`` method's developer knobs: search effort, shape bins and the passes' on/off switches.

    Not options a user decides (the defaults are the method; ``docs/decisions/`` says why each is what it is): they
    exist to measure what a part of the method is worth (an ablation) and to trade effort for speed in a study. Not
    on the command line's option list; set them from Python (``BayesConfig(tuning=BayesTuning(...))``), or by name
    where a method's options are given as ``name=value`` (``localize --set``, ``batch --option``).

    Attributes
    ----------
    coarse_resolution : float, metres, cell size of the first search level (``resolution`` if that is coarser;
        coarser still when the workspace would not fit in ``max_memory``)
    n_radii : int or None, log-spaced radius bins between radius_min and radius_max (None: neighbours about 15 %
        apart, :data:`RADIUS_BIN_RATIO`)
    elongations : tuple or str, ratios (>= 1) of the semi-axis along ``up`` to the one across it of the search's
        hypotheses, e.g. "1,2.5": every second radius bin is also scored as upright spheroids of these elongations,
        so a tall box (bottle, container, hanging cucumber) is explained from the start; "1" searches spheres only
    lying_yaws : int, yaws (evenly over 180 degrees about ``up``) at which each elongated bin is also scored lying, its
        long axis horizontal (a can, a box or a tray on its side; 0: upright bins only)
    lying_elongations : tuple or str or None, ratios (> 1) of the long semi-axis to the across one of the lying bins
        (None: those of ``elongations``)
    elongation_cost : float, nats: what an elongated hypothesis pays against a sphere (the Occam factor of its extra
        shape parameter)
    elongation_slack : float, nats: at each search level an elongated bin is refined further only where its box
        evidence is at least the cell's best sphere bin's minus this
    prune_slack : float, nats: at each search level, cells whose best score is below ``accept - prune_slack`` are dropped
    dominance_margin : float, nats: a hypothesis whose every box is also used by another scoring more than this above
        it is dropped in the search (inf: never)
    lookahead : int, at each extraction step refine up to this many distinct candidates near the best grid score and
        keep the best refined one (1 = plain greedy); the steal pass also tries this many
    lookahead_margin : float, nats: candidates of the look-ahead score within this of the best
    max_hypotheses : int, cap on the hypotheses scored at one search level (the memory budget may lower it)
    radius_margin_bins : int, radius bins a child cell inherits on each side of those its parent kept
    lazy_last_level : bool or None: leave the search's last level to the extraction, which scores a cell's children
        only when the cell nears the best; None: where that level would be large (``search.LAZY_LAST_LEVEL_ABOVE``)
    swap : bool, the swap pass: two overlapping objects trade their boxes in a view where both fit better
    steal : bool, the steal pass: a fruit gets back the box a neighbour took when the neighbour can do without it
    regroup : bool, the regroup pass: an object whose boxes are several fruit's is extracted again with its neighbours
    shape_swap : bool, the shape-swap pass: pairs judged with the shape models trade boxes or are refitted together
    second_look : bool, the second look: objects grown by, and built from, the boxes no object holds
    view_assign : bool, the view assignment: one view's boxes around a free box assigned afresh
    one_sided_refit : bool, the final refit of a sphere seen in 3 or more views scores an edge inside its prediction
        (a leaf's cut) with a flat tail after ``cut_inward_floor`` nats (off: the symmetric loss)
    cut_inward_floor : float, nats, the inward floor of ``one_sided_refit``
    """

    coarse_resolution: float = 0.04
    n_radii: int | None = None
    elongations: tuple[float, ...] | str = (1.0, 2.5)
    lying_yaws: int = 4
    lying_elongations: tuple[float, ...] | str | None = None
    elongation_cost: float = 2.0
    elongation_slack: float = 0.0
    prune_slack: float = 2.0
    dominance_margin: float = 10.0
    lookahead: int = 3
    lookahead_margin: float = 4.0
    max_hypotheses: int = 8_000_000
    radius_margin_bins: int = 1
    lazy_last_level: bool | None = None
    swap: bool = True
    steal: bool = True
    regroup: bool = True
    shape_swap: bool = True
    second_look: bool = True
    view_assign: bool = True
    one_sided_refit: bool = True
    cut_inward_floor: float = 1.5

    def __post_init__(self) -> None:
        self._check_elongations()
        self._check_elongations("lying_elongations")
        for name in ("n_radii", "lookahead", "max_hypotheses"):
            v = getattr(self, name)
            if name == "n_radii" and v is None:
                continue  # set from the radius range by BayesConfig
            if not (is_real(v) and float(v).is_integer() and v >= 1):
                raise InputError(f"{name}: got {v!r}, expected an integer >= 1")
            object.__setattr__(self, name, int(v))
        for name in ("radius_margin_bins", "lying_yaws"):
            v = getattr(self, name)
            if not (is_real(v) and float(v).is_integer() and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected an integer >= 0")
            object.__setattr__(self, name, int(v))
        v = self.coarse_resolution
        if not (is_real(v) and math.isfinite(v) and v > 0):
            raise InputError(f"coarse_resolution: got {v!r}, expected a positive number of metres")
        for name in ("prune_slack", "lookahead_margin", "elongation_slack", "elongation_cost"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        if not (is_real(self.dominance_margin) and self.dominance_margin >= 0):
            raise InputError(f"dominance_margin: got {self.dominance_margin!r}, expected a number of nats >= 0 (inf: never)")
        if not (is_real(self.cut_inward_floor) and math.isfinite(self.cut_inward_floor) and self.cut_inward_floor > 0):
            raise InputError(f"cut_inward_floor: got {self.cut_inward_floor!r}, expected a positive number of nats")
        for name in SWITCHES:
            if not _is_bool(getattr(self, name)):
                raise InputError(f"{name}: got {getattr(self, name)!r}, expected true or false")
        if self.lazy_last_level is not None and not isinstance(self.lazy_last_level, bool):
            raise InputError(f"lazy_last_level: got {self.lazy_last_level!r}, expected true, false or null (by size)")

    def _check_elongations(self, name: str = "elongations") -> None:
        value = getattr(self, name)
        if value is None and name == "lying_elongations":
            return
        items: Any = value.split(",") if isinstance(value, str) else (value,) if is_real(value) else value
        try:
            q = tuple(float(v) for v in items)
        except (TypeError, ValueError):
            raise InputError(f"{name}: got {str(value)[:60]!r}, expected numbers >= 1, e.g. 1,2,4") from None
        if not q or not all(math.isfinite(v) and v >= 1 for v in q) or any(isinstance(v, bool) for v in items):
            raise InputError(f"{name}: got {str(value)[:60]!r}, expected numbers >= 1, e.g. 1,2,4")
        object.__setattr__(self, name, tuple(sorted(set(q))))


@dataclass(frozen=True)
class BayesConfig:
    """Options of the ``bayes`` method.

    Attributes
    ----------
    resolution : float, metres, cell size of the scored grid (accuracy comes from the continuous refinement)
    radius_min : float, metres, smallest object radius of the search (``size_range`` sets it)
    radius_max : float, metres, largest object radius of the search (``size_range`` sets it)
    reach : float, metres, manipulator reach R (a cube of side 2R in front of the first view) when the session has no workspace
    accept : float, nats, minimum refined score of a reported object; raise it (e.g. 12) when the detector gives
        false positives, at the cost of missing occluded fruit
    min_views : int, minimum number of views with an associated box
    use_masks : bool, use instance masks in the refinement when detections carry them
    pose_sigma_mm : float, millimetres, stated 1-sigma error of each view's camera position per axis (0: exact)
    pose_sigma_deg : float, degrees, stated 1-sigma error of each view's camera rotation per axis (0: exact)
    calibrate : str, none or hand-eye: estimate one camera-frame correction (a hand-eye error) shared by all views
        jointly with the fruit, apply it and report it (``quality.calibration``); needs 5 or more views and 6 or more
        fruit seen in two or more
    edge_noise : str, auto or stated: with auto, where the boxes scatter well beyond the sensor model's edge noise
        (``alpha``), the session is localised again with ``alpha`` raised to their scatter (reported as
        ``quality.edge_noise``); stated keeps ``alpha`` as given
    shape : str, object model: sphere, spheroid (two equal semi-axes), ellipsoid (three) or auto (per object by BIC;
        round fruit stay spheres)
    size_range : tuple or str or None, metres, (min, max) object size as a semi-axis length, e.g. "0.01,0.12": it sets
        radius_min/radius_max of the search and the largest semi-axis of a shape fit; a fitted semi-axis may be
        smaller than min, down to 5 mm (a flat object's half-thickness, :attr:`semi_axis_range`). Default: semi-axes of
        5-160 mm (cherry tomatoes to cucumbers, trays) and search radii radius_min-radius_max
    up : tuple or str, base frame vertical of the upright spheroid/ellipsoid models, e.g. "0,0,1"
    free_orientation : bool, fit the spheroid/ellipsoid orientation freely instead of upright plus yaw (needs views
        that constrain it, e.g. 4 or more around the fruit)
    solids : bool, with shape auto also fit upright cylinders and cuboids (cans, bottles, boxes, containers: their exact
        boxes) and keep one when the boxes clearly prefer it
    isolated_margin : float, metres: an object seen in two views whose depth lies more than this outside the depths of
        the objects seen in three or more is dropped (false-positive boxes whose rays meet away from the scene;
        :mod:`.isolated`; inf: never)
    backend : str, numba (fused compiled kernels) or numpy (the readable reference)
    threads : int or None, CPU threads of the compiled kernels (None: chosen by the amount of work)
    max_memory : int or str, bytes (or text such as 2GiB): memory budget of the call
    sensor : SensorModel, the box likelihood's parameters (edge noise, floors, miss probability...); its fields are
        options too (``alpha``, ``sigma0_px``, ...)
    tuning : BayesTuning, developer knobs (search effort, shape bins, the passes' switches)
    """

    resolution: float = 0.01
    radius_min: float = 0.01
    radius_max: float = 0.16
    reach: float = DEFAULT_REACH_M
    accept: float = 8.0
    min_views: int = 2
    use_masks: bool = True
    pose_sigma_mm: float = 0.0
    pose_sigma_deg: float = 0.0
    calibrate: str = "none"
    edge_noise: str = "auto"
    shape: str = "auto"
    size_range: tuple[float, float] | str | None = None
    up: tuple[float, float, float] | str = (0.0, 0.0, 1.0)
    free_orientation: bool = False
    solids: bool = True
    isolated_margin: float = 0.1
    backend: str = "numba"
    threads: int | None = None
    max_memory: int | str = DEFAULT_MAX_BYTES
    sensor: SensorModel = field(default_factory=SensorModel)
    tuning: BayesTuning = field(default_factory=BayesTuning)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sensor", _nested(self.sensor, SensorModel, "sensor"))
        object.__setattr__(self, "tuning", _nested(self.tuning, BayesTuning, "tuning"))
        self._check_shape_fields()
        v = self.min_views
        if not (is_real(v) and float(v).is_integer() and v >= 1):
            raise InputError(f"min_views: got {v!r}, expected an integer >= 1")
        object.__setattr__(self, "min_views", int(v))
        for name in ("radius_min", "radius_max", "resolution", "reach"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v > 0):
                raise InputError(f"{name}: got {v!r}, expected a positive number of metres")
        if self.resolution < MIN_SEARCH_RESOLUTION_M:
            raise InputError(
                f"resolution: got {self.resolution:g} m, finer than the {MIN_SEARCH_RESOLUTION_M:g} m accepted "
                "(each halving adds a search level; the refinement, not the grid, gives the accuracy)"
            )
        if not self.radius_min < self.radius_max:
            raise InputError(f"radius_min/radius_max: got {self.radius_min}/{self.radius_max}, expected 0 < min < max (metres)")
        if self.tuning.n_radii is None:
            steps = math.log(self.radius_max / self.radius_min) / math.log(RADIUS_BIN_RATIO)
            object.__setattr__(self, "tuning", replace(self.tuning, n_radii=math.ceil(steps - 1e-9) + 1))
        for name in ("pose_sigma_mm", "pose_sigma_deg"):
            v = getattr(self, name)
            if not (is_real(v) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: got {v!r}, expected a finite number >= 0")
        if self.calibrate not in CALIBRATIONS:
            raise InputError(f"calibrate: got {self.calibrate!r}, expected one of {list(CALIBRATIONS)}")
        if self.edge_noise not in EDGE_NOISES:
            raise InputError(f"edge_noise: got {self.edge_noise!r}, expected one of {list(EDGE_NOISES)}")
        if not (is_real(self.isolated_margin) and self.isolated_margin >= 0):
            raise InputError(f"isolated_margin: got {self.isolated_margin!r}, expected a number of metres >= 0 (inf: never)")
        if not (is_real(self.accept) and math.isfinite(self.accept)):
            raise InputError(f"accept: got {self.accept!r}, expected a finite number of nats")
        if self.min_views < 2:
            raise InputError(f"min_views: got {self.min_views}, expected >= 2 (one view cannot fix depth)")
        for name in ("use_masks", "free_orientation", "solids"):
            if not _is_bool(getattr(self, name)):
                raise InputError(f"{name}: got {getattr(self, name)!r}, expected true or false")
        if self.backend not in BACKENDS:
            raise InputError(f"backend: got {self.backend!r}, expected one of {list(BACKENDS)} for method 'bayes'")
        check_shared_options(self)

    @classmethod
    def from_options(cls, **options: Any) -> BayesConfig:
        """A config from options by name, those of :attr:`sensor` and :attr:`tuning` included (``alpha=0.06``,
        ``swap=False``): what ``localize(session, **options)`` and the command line's ``name=value`` options give.

        Examples
        --------
        >>> cfg = BayesConfig.from_options(accept=12, alpha=0.06, swap=False)
        >>> cfg.accept, cfg.sensor.alpha, cfg.tuning.swap
        (12, 0.06, False)
        """
        return nested_config(cls, options, "bayes")

    @property
    def n_radii(self) -> int:
        """Radius bins of the search (``tuning.n_radii``, set from the radius range when not given)."""
        return int(self.tuning.n_radii)  # type: ignore[arg-type]

    def _check_shape_fields(self) -> None:
        if self.shape not in SHAPES:
            raise InputError(f"shape: got {self.shape!r}, expected one of {list(SHAPES)}")
        import numpy as np

        up = _floats(self.up, 3, "up", "three numbers, e.g. 0,0,1")
        if not np.linalg.norm(up) > 1e-12:
            raise InputError(f"up: got {up.tolist()}, expected a vector of non-zero length (base frame vertical, e.g. 0,0,1)")
        object.__setattr__(self, "up", tuple(float(v) for v in up / np.linalg.norm(up)))
        if self.size_range is not None:
            lo, hi = _floats(self.size_range, 2, "size_range", "MIN,MAX in metres, e.g. 0.01,0.12")
            if not 0 < lo < hi:
                raise InputError(f"size_range: got {lo:g},{hi:g}, expected 0 < MIN < MAX (semi-axis length, metres)")
            object.__setattr__(self, "size_range", (float(lo), float(hi)))
            object.__setattr__(self, "radius_min", float(lo))
            object.__setattr__(self, "radius_max", float(hi))

    @property
    def up_vector(self) -> NDArray[np.float64]:
        """The vertical of the upright models, shape (3,), unit, base frame."""
        import numpy as np

        return np.asarray(self.up, dtype=float)

    @property
    def fit_radius_range(self) -> tuple[float, float]:
        """Radii (metres) a refit may reach before it counts as diverged (:data:`DIVERGED_RADIUS_FACTOR`)."""
        return self.radius_min / DIVERGED_RADIUS_FACTOR, self.radius_max * DIVERGED_RADIUS_FACTOR

    @property
    def semi_axis_range(self) -> tuple[float, float]:
        """Bounds of the shape fit's semi-axes, metres: up to ``size_range``'s MAX (else 160 mm, at least the search's
        largest radius), down to 5 mm or the smallest radius searched, whichever is smaller.

        ``size_range``'s MIN bounds the search's radii, the objects' sizes, not every semi-axis of their shape: a tray
        200 mm long is 30 mm thick, a half-thickness of 15 mm (docs/real.md, "The size range and flat objects"). The
        largest semi-axis is not held above MIN either: the search's radii already are."""
        thinnest, longest = FIT_SEMI_AXIS_RANGE_M
        if self.size_range is not None:
            return (min(thinnest, self.size_range[0]), self.size_range[1])  # type: ignore[index]
        return (min(thinnest, self.radius_min), max(longest, self.radius_max))

    @property
    def search_start(self) -> float:
        """Cell size of the first search level, metres: ``tuning.coarse_resolution``, or ``resolution`` if that is
        coarser."""
        return float(max(self.tuning.coarse_resolution, self.resolution))

    @property
    def pose_position_sigma(self) -> float:
        """Stated camera position uncertainty, metres per axis."""
        return float(self.pose_sigma_mm) / 1000.0

    @property
    def pose_rotation_sigma(self) -> float:
        """Stated camera rotation uncertainty, radians per axis."""
        return math.radians(float(self.pose_sigma_deg))

    @property
    def poses_uncertain(self) -> bool:
        return self.pose_sigma_mm > 0 or self.pose_sigma_deg > 0

    @property
    def radii(self) -> NDArray[np.float64]:
        """Radius bins, shape (n_radii,), metres."""
        import numpy as np

        if self.n_radii == 1:
            return np.array([np.sqrt(self.radius_min * self.radius_max)])
        return np.geomspace(self.radius_min, self.radius_max, self.n_radii)

    @property
    def hypothesis_bins(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The search's shape bins: semi-axes across their axis and along it, each shape (K,), metres.

        Every radius bin as a sphere, then every :data:`ELONGATED_RADIUS_STRIDE`-th radius bin with each
        elongation > 1, elongation-major (the radius bins of one elongation are neighbours, as :attr:`radii`),
        leaving out elongated bins longer than the largest semi-axis (:attr:`semi_axis_range`): first upright
        (axis ``up``), then lying at each of ``lying_yaws`` yaws with the ``lying_elongations``, yaw-major (axes:
        :attr:`hypothesis_axes`).
        """
        across, along, _ = self._bins()
        return across, along

    @property
    def hypothesis_axes(self) -> NDArray[np.float64]:
        """Symmetry axis of each bin of :attr:`hypothesis_bins`, shape (K, 3), unit, base frame: ``up`` for the
        spheres and upright bins, :attr:`lying_axes` for the lying ones."""
        return self._bins()[2]

    def _bins(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Semi-axes across and along, and the axis, of every shape bin: (K,), (K,), (K, 3)."""
        import numpy as np

        r, tuning = self.radii, self.tuning
        coarse = r[::ELONGATED_RADIUS_STRIDE]
        longest = self.semi_axis_range[1] * (1 + 1e-9)

        def elongated(qs: tuple[float, ...]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            across = [coarse[q * coarse <= longest] for q in qs if q > 1.0]
            along = [a * q for a, q in zip(across, [q for q in qs if q > 1.0])]
            return np.concatenate([np.zeros(0)] + across), np.concatenate([np.zeros(0)] + along)

        up_across, up_along = elongated(tuning.elongations)  # type: ignore[arg-type]
        lying = tuning.elongations if tuning.lying_elongations is None else tuning.lying_elongations
        lie_across, lie_along = elongated(lying if tuning.lying_yaws else ())  # type: ignore[arg-type]
        n_yaws = tuning.lying_yaws if len(lie_across) else 0
        spheres = r if 1.0 in tuning.elongations else np.zeros(0)  # type: ignore[operator]
        across = np.concatenate([spheres, up_across] + [lie_across] * n_yaws)
        along = np.concatenate([spheres, up_along] + [lie_along] * n_yaws)
        axes = np.tile(self.up_vector, (len(across), 1))
        if n_yaws:
            axes[len(spheres) + len(up_across) :] = np.repeat(self.lying_axes, len(lie_across), axis=0)
        return across, along, axes

    @property
    def lying_axes(self) -> NDArray[np.float64]:
        """Long axes of the lying bins, shape (lying_yaws, 3), unit, base frame: horizontal (perpendicular to
        ``up``), at yaws ``i * 180 / lying_yaws`` degrees from the horizontal direction nearest the base x axis
        (the y axis when ``up`` is along x)."""
        import numpy as np

        up = self.up_vector
        ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = ref - up * (ref @ up)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(up, e1)
        yaw = np.pi * np.arange(self.tuning.lying_yaws) / max(self.tuning.lying_yaws, 1)
        return np.cos(yaw)[:, None] * e1 + np.sin(yaw)[:, None] * e2

    def to_dict(self) -> dict[str, Any]:
        """The options as plain JSON values, :attr:`sensor` and :attr:`tuning` as nested objects."""
        return plain_options(self)
