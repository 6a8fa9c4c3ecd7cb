"""How well an identified model reproduces its data, said where it matters (thesis 3.4).

A fit error above :data:`FIT_WARN` (relative quadratic error, 3.11), or above
:data:`FLOOR_WARN` times the error the data's own noise would leave, is reported with where
it comes from -- the frequency lines and the channels that carry most of it -- and what to
try, so that a user never takes a model that misses a third of the data, or what the data
plainly hold, for a good one.

The noise floor is the coherence's when the FRF carries one (:func:`coherence_floor`, 3.59;
on the family's simulated surveys it matches the realised noise within 7%); without one, the
second differences of the residual along the lines (:func:`difference_floor`,
``|r_(i-1) - 2 r_i + r_(i+1)|^2 / 6``, the estimate of the selection's noise test): equal to
the noise for noise independent between lines, blind to a residual smooth in frequency (a
mode the model misses).  Measured at 1% noise, seeds 1-3, on the five testbed members: fit
error / this floor 0.95-1.03; on a held-out structure whose 2-shaker test missed a heavily
damped mode at seeds 1 and 3, 3.5 and 3.9 (2.0 and 1.1 once found; 1.0-1.1 otherwise).  It
is used only when the residual looks like such noise: its second differences over two lines
have the same level as over one (a smooth residual's grow as the lag to the fourth power).
Measured level ratio (two lines over one): 0.84-1.06 at 1% noise (family and held-out
structure), 1.22 and 1.4 with the missed mode, 1.98-5.6 on noise-free data, whose residual
is a model error at the peaks (fit error 7-12 times the differences' level there, with no
noise to compare with); above :data:`LAG_RATIO` no floor is taken.  An exponential window,
which correlates the noise between lines, raises the ratio too (2.7-3 on the family's surveys
read without their coherence: no floor, and a fit error 5.5 times the noise's unsaid).  The
differences over ``k`` lines are then divided by their gain for the window's correlation
(:func:`~sdctrl.identification._line_correlation.difference_gain`; the recorded window's,
or the one of the decay the selection measured, ``noise_correlation``) instead of 6: the
family's surveys, ratio 1.13-1.31 (400 lines), floor 0.73-1.02 of the coherence's (1600
lines).  A residual rougher than the window lets noise be (a ratio below
``1 / LAG_RATIO``) gives no floor either.

A model that fits well can still hold poles that are no modes: when the structure's
frequencies drift during a test (temperature, mass loading, a changing suspension; the thesis
measured 0.2% between tests, 3.4.3), the columns measured early and late see each mode at
slightly different poles, and a model with one pole set for every column (3.7) splits each mode
into a multiplet of poles closer than their half-power bandwidth, with one shape on the
fixed side and differing shapes on the roving side.  :func:`drift_multiplets` says so when it
happens at several modes (true close modes are the exception a symmetry makes, drift acts on
every mode).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sdctrl._lib.logratio import log_magnitude_ratio
from sdctrl.identification._line_correlation import difference_gain, noise_correlation
from sdctrl.identification._noise import point_variance
from sdctrl.identification._variance import recorded_divisor

__all__ = ["DRIFT_MAC", "FIT_WARN", "FLOOR_WARN", "LAG_RATIO", "assessed", "coherence_floor",
           "difference_floor", "drift_multiplets", "fit_quality", "mean_logls", "with_logls"]

#: relative quadratic fit error (3.11) above which :func:`sdctrl.identify` warns
FIT_WARN = 0.10
#: ratio of the fit error to the error the data's noise alone would leave (coherence, 3.59)
#: above which :func:`sdctrl.identify` warns
FLOOR_WARN = 3.0
#: ratio of the second-difference levels of the residual over two lines and over one (each
#: over its gain for the lines' correlation) above which, or below whose inverse, it is not
#: taken for the data's noise (:func:`difference_floor`)
LAG_RATIO = 1.6
#: MAC of two poles' shapes on the fixed side (the side with fewer channels) above which two
#: poles closer than their half-power bandwidths may be one mode seen at drifting frequencies
DRIFT_MAC = 0.99
#: fewest multiplets (and share of the band's mode groups) that make the drift warning
DRIFT_MULTIPLETS, DRIFT_SHARE = 3, 0.25


def _concentration(err: np.ndarray, share: float = 0.8) -> np.ndarray:
    """Indices of the fewest entries of ``err`` (>= 0) carrying ``share`` of its sum."""
    order = np.argsort(err)[::-1]
    cum = np.cumsum(err[order])
    k = int(np.searchsorted(cum, share * cum[-1])) + 1
    return np.sort(order[:k])


def coherence_floor(data) -> float | None:
    """The relative fit error (3.11) an exact model would leave on ``data``: the point
    variance ``|H|^2 (1 - coherence) / (n_d - 1)`` (3.59, divided by the recorded averages'
    ``n_d - 1`` as the statistics do) summed over the lines and channels, over ``sum |H|^2``,
    square-rooted; None when the FRF carries no coherence measuring its noise
    (:func:`~sdctrl.data._coherence.measured_coherence`).
    """
    var = point_variance(data, recorded_divisor(data))
    total = float(np.sum(np.abs(data.H) ** 2))
    if var is None or not total > 0:
        return None
    floor = float(np.sqrt(var.sum() / total))
    return floor if floor > 0 else None


def difference_floor(R: np.ndarray, H: np.ndarray, rho=None) -> float | None:
    """The relative fit error (3.11) the noise of the data would leave, from the second
    differences of the residual ``R`` (nf, ns, na) along the lines (module notes):
    ``sqrt(mean_i sum |R_(i-1) - 2 R_i + R_(i+1)|^2 / g_1 / mean_i sum |H_i|^2)``, ``g_k`` the
    gain of the differences over ``k`` lines for noise correlated as ``rho`` between lines
    (:func:`~sdctrl.identification._line_correlation.difference_gain`: 6 for independent
    lines, None); None when the residual is not such noise (the level of the differences over
    two lines, ``R_(i-2) - 2 R_i + R_(i+2)``, over ``g_2``, not within a factor
    :data:`LAG_RATIO` of that over one: smoother, as a missed mode's, or rougher than the
    window lets noise be), when fewer than 8 lines, or when the data are zero."""
    nf = R.shape[0]
    total = float(np.mean(np.sum(np.abs(H.reshape(nf, -1)) ** 2, axis=1))) if nf else 0.0
    if nf < 8 or not total > 0:
        return None
    R = R.reshape(nf, -1)
    e1, e2 = (float(np.mean(np.sum(np.abs(R[:-2 * k] - 2 * R[k:-k] + R[2 * k:]) ** 2,
                                   axis=1))) / difference_gain(rho, k) for k in (1, 2))
    if not 0 < e1 or not e1 / LAG_RATIO <= e2 <= LAG_RATIO * e1:
        return None
    return float(np.sqrt(e1 / total))


def mean_logls(a, b) -> float:
    """``mean |ln|a| - ln|b||^2`` (3.12), the logLS of ``a`` against ``b``."""
    return float(np.mean(log_magnitude_ratio(a, b) ** 2))


def assessed(cm, data):
    """``cm`` with ``search.logls`` (:func:`with_logls`) and the warnings about its fit to
    ``data`` (:func:`fit_quality`, :func:`drift_multiplets`), its response at the lines of
    ``data`` evaluated once for both."""
    H = cm.frf(data.freq, quantity=data.quantity).H
    return with_logls(cm, data, H), fit_quality(cm, data, H) + drift_multiplets(cm)


def with_logls(cm, data, H):
    """``cm`` with ``search.logls``, its mean logLS (3.12) against ``data`` (the lines it was
    fitted to, as measured; ``H`` its response there); ``cm`` itself when it has no search
    record."""
    if cm.search is None:
        return cm
    return cm.replace(search=replace(cm.search, logls=mean_logls(H, data.H)))


def fit_quality(cm, data, H) -> list[str]:
    """Warnings about the fit of ``cm`` to ``data``: empty when the error is below
    :data:`FIT_WARN` and below :data:`FLOOR_WARN` times the error its noise alone would
    leave (:func:`coherence_floor` for an FRF with a coherence, else
    :func:`difference_floor` when the residual is noise independent between lines).

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.
    data : FRF
        The lines it was fitted to.
    H : ndarray
        The model's response at those lines (``data``'s quantity).

    Returns
    -------
    list of str
        One message naming the fit error (and its ratio to the noise floor), the frequency
        range and the channels that carry most of it, and what to try.
    """
    if not np.isfinite(cm.cost):
        return []
    Rc = data.H - H
    floor, source = coherence_floor(data), "coherence, 3.59"
    if floor is None:
        rho = noise_correlation(cm, data)
        floor = difference_floor(Rc, data.H, rho)
        source = ("second differences of the residual" if rho is None else "second differences "
                  "of the residual, for lines correlated by the window")
    above = floor is not None and cm.cost > FLOOR_WARN * floor
    if cm.cost <= FIT_WARN and not above:
        return []
    R = np.abs(Rc) ** 2
    total = float(R.sum())
    if not total > 0:
        return []
    per = R.sum(axis=(1, 2))
    lines = _concentration(per)
    runs = np.split(lines, np.flatnonzero(np.diff(lines) > 1) + 1)
    runs = sorted(runs, key=lambda r: -per[r].sum())[:3]
    where = ", ".join(f"{data.freq[r[0]]:.4g}-{data.freq[r[-1]]:.4g} Hz" for r in
                      sorted(runs, key=lambda r: r[0]))
    share = float(sum(per[r].sum() for r in runs) / total)
    chan = R.sum(axis=0).ravel()
    worst = np.argsort(chan)[::-1][:3]
    na = data.H.shape[2]
    names = ", ".join(f"{data.sensors[i // na]}/{data.actuators[i % na]} "
                      f"({chan[i] / total:.0%})" for i in worst)
    if cm.cost > FIT_WARN:
        level = f"{cm.cost:.1%} (above {FIT_WARN:.0%})"
    else:
        level = (f"{cm.cost:.2%}, {cm.cost / floor:.1f} times the {100 * floor:.2g}% that the "
                 f"data's noise alone would leave ({source}): the data hold more than the model")
    return [f"identify: the model leaves a relative fit error of {level}; {share:.0%} of it "
            f"lies in {where}; the largest channels (sensor/actuator) are {names}. Try "
            "band=(fmin, fmax) around the modes you need (lines with no mode, e.g. below the "
            "first resonance of a roving-hammer test, cannot be fitted; a mode just outside "
            "the band leaves its tail at the edge: move the edge away from it or give its "
            "pole), check the quantity and units of the data, or give poles= for modes the "
            "automatic selection missed."]


def _fixed_shape(R: np.ndarray, fixed_sensors: bool) -> np.ndarray:
    """Dominant singular vector of one pole's residue ``R`` (ns, na) on the fixed side."""
    U, _, Vh = np.linalg.svd(R, full_matrices=False)
    return U[:, 0] if fixed_sensors else Vh[0]


def drift_multiplets(cm) -> list[str]:
    """A warning when the band's poles form multiplets that look like drifting modes.

    Consecutive in-band poles are linked when their frequencies differ by less than the sum
    of their half-power half-widths ``zeta f`` and their shapes on the fixed side (sensors when
    there are no more sensors than actuators, as in a roving-hammer survey) have a MAC above
    :data:`DRIFT_MAC`.  Linked poles form groups; a group of two or more is a multiplet.  At
    least :data:`DRIFT_MULTIPLETS` multiplets, making at least :data:`DRIFT_SHARE` of the
    groups, are reported (module notes).

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.

    Returns
    -------
    list of str
        One message (or none) naming the multiplets, the drift's size and what to try.
    """
    idx = np.flatnonzero(np.asarray(cm.in_band, bool))
    if idx.size < 2 * DRIFT_MULTIPLETS or cm.residues is None:
        return []
    idx = idx[np.argsort(cm.frequency[idx])]
    f, z = cm.frequency[idx], cm.damping[idx]
    ns, na = cm.residues.shape[1:]
    fixed_sensors = ns <= na
    shapes = [_fixed_shape(cm.residues[j], fixed_sensors) for j in idx]
    groups = [[0]]
    for k in range(1, idx.size):
        a, b = shapes[k - 1], shapes[k]
        mac = abs(np.vdot(a, b)) ** 2 / max(np.vdot(a, a).real * np.vdot(b, b).real, 1e-300)
        if f[k] - f[k - 1] < z[k] * f[k] + z[k - 1] * f[k - 1] and mac > DRIFT_MAC:
            groups[-1].append(k)
        else:
            groups.append([k])
    multi = [g for g in groups if len(g) > 1]
    if len(multi) < max(DRIFT_MULTIPLETS, DRIFT_SHARE * len(groups)):
        return []
    spread = float(np.median([(f[g[-1]] - f[g[0]]) / f[g].mean() for g in multi]))
    shown = "; ".join(", ".join(f"{f[k]:.4g}" for k in g) + " Hz" for g in multi[:3])
    side, other = ("sensors", "actuators (hit points)") if fixed_sensors else \
        ("actuators", "sensors (roving sensors: mass loading)")
    return [f"identify: {sum(len(g) for g in multi)} of the band's {idx.size} poles form "
            f"{len(multi)} multiplets closer than their half-power bandwidths with one shape at "
            f"the {side} (MAC > {DRIFT_MAC}), e.g. {shown}: the signature of modes whose "
            f"frequencies drift between {other} during the test (temperature, mass loading, "
            f"a changing suspension; spread {spread:.2%} here, thesis 3.4.3), so about "
            f"{len(groups)} modes rather than {idx.size} -- unless the structure has repeated "
            "modes (symmetry). The model "
            "reproduces the data, but count one mode per multiplet. Try: re-measure the first "
            "points at the end of the test to see the drift, identify groups of points "
            "measured close in time, or give poles= with one pole per multiplet (its fit "
            "error then shows what the drift costs; normal modes from such data are poor: "
            "the drift makes the residues complex, 3.40)."]
