"""Whether a solid (an upright cylinder or cuboid, :mod:`monovisual3d.geometry.solids`) or an ellipsoid model of fruit
explains an object's boxes: the choice of ``bayes``'s shape stage (:mod:`.shapes`) among the fits of
:func:`monovisual3d.geometry.fit.fit_shape_by_bic`.

A solid wins when the boxes clearly prefer it to the best ellipsoid model, with the edge noise estimated from the fits
(:func:`solid_evidence`); where the BIC under the sensor model's edge noise prefers the ellipsoid model, only when the
solid also fits its boxes far more precisely than that noise (:func:`precise`). Both are judged on the box edges and
on the box sizes alone (:func:`size_residuals`), which an error in the views' poses leaves as they are.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ...geometry.fit import fit_parameters, hopeless
from ...geometry.solids import SOLIDS
from .sensor import SensorModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ...geometry.fit import EllipsoidFit

#: Evidence (nats, :func:`solid_evidence`) a solid needs over the best ellipsoid model: prior odds of e : 1 for the
#: ellipsoids, the models of fruit. Under box noise of a few per cent a cylinder and a spheroid of the same size fit
#: about equally well, and without prior odds (0 nats) spheroids are often taken for cylinders, placed a little high;
#: near-exact boxes speak for the right model by far more than that (why: docs/decisions/bayes-shapes.md#solid_evidence_nats).
SOLID_EVIDENCE_NATS = 1.0
#: A solid the BIC under the sensor model's edge noise does not prefer may still win by its evidence when its fit is
#: this unlikely, or less, under that noise: its chi2 below this quantile of the chi2 distribution of its degrees of
#: freedom (a detector more precise than the sensor model assumes). Three views' 12 edges and a cuboid's 7 parameters:
#: chi2 below 1.6, its 12 edges within about 0.37 sensor sigmas RMS (why: docs/decisions/bayes-shapes.md#precise_quantile).
PRECISE_QUANTILE = 0.1
#: Degrees of freedom (edges less parameters) a solid's fit needs for that: three whole views of a cuboid. Containers
#: side by side seen from their height with boxes of their visible parts (tests/methods/bayes/test_bayes_shape_swap.py)
#: leave the farther one 2-3 after the edges the nearer one hides; its cuboid, weakly fixed there, came out 8-9 mm off
#: where the spheroid the BIC prefers is 3-5 mm off.
MIN_PRECISE_DOF = 5
#: Parameters of a fit that place its centre: the sizes of its boxes (:func:`size_residuals`) fix the others.
CENTRE_PARAMETERS = 3
#: Degrees of freedom the sizes' :func:`precise` needs: three views give 6 sizes, of which a cuboid's 4 shape
#: parameters leave 2 (a tray's cut or covered edge one fewer).
MIN_PRECISE_SIZE_DOF = 1
#: Edges either fit misses by this many sensor sigmas (``alpha``) or more are outliers, left out of the evidence.
OUTLIER_SIGMAS = 3.0


def solid_evidence(solid: EllipsoidFit, other: EllipsoidFit, sizes: bool = False) -> float:
    """Half the difference (nats) between the Bayesian information criteria of ``other`` and ``solid`` with the edge
    noise estimated from the residuals (``E ln(chi2 / E) + P ln E`` for each; positive: the solid is preferred).

    The edge noise of the sensor model (``alpha``) is a bound for poor detectors, under which a solid and an
    ellipsoid of the same size are within a fraction of a sigma of each other on every edge: there, the plain
    BIC picks either at random. With the noise taken from the fits themselves, near-perfect boxes of a cylinder
    speak for it by hundreds of nats, noisy ones by about nothing. Edges either fit misses by
    :data:`OUTLIER_SIGMAS` sensor sigmas or more (a leaf's cut, a merged false positive: the robust fits let them go)
    are left out, so that they do not make the evidence; with no more edges left than parameters it is ``-inf``.

    With ``sizes`` the same on the fits' box widths and heights (:func:`size_residuals`), the parameters counted less
    the centre's :data:`CENTRE_PARAMETERS` (which the sizes barely fix): an error in a view's reported pose moves its
    whole box by a few pixels, which on a thin box's 4-5 px of edge noise outweighs what its edges say about the
    shape, and leaves the sizes as they are."""
    if sizes:
        (ms, ss), (mo, so) = size_residuals(solid), size_residuals(other)
        rs, ro = ms / ss, mo / so
    else:
        rs, ro = solid.residuals_px / solid.sigma_px, other.residuals_px / other.sigma_px  # the same edges, normalised
    inlier = (np.abs(rs) < OUTLIER_SIGMAS) & (np.abs(ro) < OUTLIER_SIGMAS)
    e = int(inlier.sum())
    if e <= max(solid.n_parameters, other.n_parameters) - (CENTRE_PARAMETERS if sizes else 0):
        return -math.inf
    tiny = 1e-12  # chi2 of an exact fit: the evidence stays finite
    chi2_solid, chi2_other = float(np.sum(rs[inlier] ** 2)), float(np.sum(ro[inlier] ** 2))
    return 0.5 * (
        e * math.log((chi2_other + tiny) / (chi2_solid + tiny)) + (other.n_parameters - solid.n_parameters) * math.log(e)
    )


def solid_if_clear(best: EllipsoidFit, fits: dict[str, EllipsoidFit]) -> EllipsoidFit:
    """The solid of ``fits`` with the most :func:`solid_evidence` against the lowest-BIC ellipsoid model when that
    exceeds :data:`SOLID_EVIDENCE_NATS`, else that ellipsoid model (``best`` when none was fitted): the solids join the
    models of fruit and win when the boxes say so clearly. A solid that ``best`` is not (the BIC under the sensor
    model's edge noise prefers an ellipsoid model or another solid) must also fit its boxes far better than that noise
    (:func:`precise`); the solid with the most evidence wins, whichever the BIC preferred. Both are also judged on the
    box sizes alone (``sizes=True``), which an unstated error in the views' poses leaves as they are: the evidence is
    the larger of the two.

    The sensor model's edge noise (``alpha``, a bound for poor detectors) makes a large box's edge sigma tens of pixels,
    under which a solid's better fit of near-perfect boxes weighs less than its extra parameters: a flat tray's cuboid
    fits its exact boxes to under a pixel where a spheroid misses them by about 10 px, and the BIC still takes the
    spheroid. With boxes as noisy as the sensor model says, the BIC is the better judge: the evidence, which estimates
    the noise from 12 edges, takes noisy fruit for solids now and then
    (why: docs/decisions/bayes-shapes.md#precise_quantile). A flat tray seen from its height with the arm's pose error
    (1 mm and 0.15 degrees per axis): each view's box moves 2-8 px, on the tray's thin side that is 1-2 edge sigmas,
    and the edges' evidence left the cuboid out in favour of a spheroid or ellipsoid 10-30 mm off; its sizes keep it
    (``tests/methods/bayes/test_bayes_solids.py``)."""
    others = [f for m, f in fits.items() if m not in SOLIDS]
    if not others:
        return best
    other = min(others, key=lambda f: f.bic)
    solids = [f for m, f in fits.items() if m in SOLIDS and (f is best or precise(f) or precise(f, sizes=True))]
    if not solids:
        return other
    solid, evidence = max(
        ((f, max(solid_evidence(f, other), solid_evidence(f, other, sizes=True))) for f in solids), key=lambda t: t[1]
    )
    return solid if evidence > SOLID_EVIDENCE_NATS else other


def size_residuals(fit: EllipsoidFit) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The misses of ``fit``'s box widths and heights, pixels, and their noise stds (each (S,)): one per view and
    axis whose two edges the fit used (``x2 - x1`` and ``y2 - y1``, predicted less observed).

    An error in a view's reported pose moves the whole box (by the same few pixels at both edges of an axis) and
    barely resizes it: the sizes carry an object's shape whatever the poses' error."""
    index = np.full(fit.used.shape, -1)
    index[fit.used] = np.arange(int(fit.used.sum()))
    misses, sigmas = [], []
    for lo, hi in ((0, 2), (1, 3)):
        both = fit.used[:, lo] & fit.used[:, hi]
        i, j = index[both, lo], index[both, hi]
        misses.append(fit.residuals_px[j] - fit.residuals_px[i])
        sigmas.append(np.hypot(fit.sigma_px[i], fit.sigma_px[j]))
    return np.concatenate(misses), np.concatenate(sigmas)


def precise(fit: EllipsoidFit, sizes: bool = False) -> bool:
    """Whether ``fit`` misses its boxes by so much less than the sensor model's edge noise that such noise would give
    a chi2 this low with probability under :data:`PRECISE_QUANTILE` (chi2 distribution of its degrees of freedom);
    with ``sizes``, its box sizes (:func:`size_residuals`)."""
    if sizes:
        misses, sigmas = size_residuals(fit)
        dof, chi2 = len(misses) - (fit.n_parameters - CENTRE_PARAMETERS), float(np.sum((misses / sigmas) ** 2))
    else:
        dof, chi2 = fit.n_edges - fit.n_parameters, fit.chi2
    if dof < (MIN_PRECISE_SIZE_DOF if sizes else MIN_PRECISE_DOF):
        return False
    from scipy.special import gammainc  # on first use: 0.1 s to import

    return bool(gammainc(0.5 * dof, 0.5 * chi2) < PRECISE_QUANTILE)  # the chi2 distribution function


def solid_may_win(
    solid: str, fits: dict[str, EllipsoidFit], free_orientation: bool = False, floor_px: float = SensorModel.sigma0_px
) -> bool:
    """Whether a fit of the model ``solid`` is worth making beside ``fits`` (at least one ellipsoid model, the same
    edges): it could have the lowest BIC (:func:`monovisual3d.geometry.fit.hopeless`), or it could win by its evidence
    (:func:`solid_if_clear`): its fit would keep :data:`MIN_PRECISE_DOF` degrees of freedom, and the best ellipsoid
    model does not already fit the boxes both as closely as :func:`precise` asks and to within ``floor_px`` RMS
    (pixels: the sensor model's noise floor ``sigma0_px``, the quantisation of a box's edges).

    The second condition is a heuristic, not a bound (the evidence grows without limit as the solid's chi2 falls): a
    cuboid's fit costs about ten times a spheroid's, and where an ellipsoid model fits to the pixel (exact boxes of a
    fruit) the cuboid has nothing to show. Precision alone is not enough: the sensor model's edge noise is 5 % of a
    box's size, 15-25 px on a flat tray's 300-450 px wide boxes, and a spheroid, round in plan, follows a rectangle's
    box widths over three views by moving in depth, 4-9 px RMS and 5-25 mm off, which that noise calls precise; the
    cuboid fits the same boxes to under a pixel (``tests/methods/bayes/test_bayes_solids.py``). Containers with
    near-perfect boxes are fitted too: the best ellipsoid model misses the exact boxes of a 5 x 5 x 12 cm box seen
    from 15-30 degrees by 1.5-4 px RMS."""
    if not hopeless(solid, fits, free_orientation):
        return True
    others = [f for m, f in fits.items() if m not in SOLIDS]
    if not others:
        return True
    n_parameters = len(fit_parameters(solid, free_orientation=free_orientation))
    best = min(others, key=lambda f: f.bic)
    return others[0].n_edges - n_parameters >= MIN_PRECISE_DOF and not (precise(best) and best.rms_px <= floor_px)
