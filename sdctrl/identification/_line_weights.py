"""Line weights of the identification: its least-squares cost made the logLS cost (3.12)
linearised (issue 22).

The models are judged by the logLS error (3.12), ``|log(H_fit / H)|^2`` averaged over the
lines and channels, every line and channel alike however loud; the fit (3.11), (3.16) is a
least-squares one, ``|H_fit - H|^2``, where a line counts with the square of its level.  The
two agree to first order when each entry is weighted by ``1 / |H|``: ``|H_fit - H|^2 /
|H|^2 = |log(H_fit / H)|^2`` for small errors.  Channels are already weighted by their
noise level (:func:`~sdctrl.identification._compression.channel_weights`); the lines are
weighted here by the inverse of their level across the channels, the geometric mean of
``|H_c(f)|`` -- the log-domain average, invariant to each channel's scale -- one weight per
line, shared by every channel so that the pole basis stays common to all of them (the
compression and the variable projection of (3.16) need one basis).  Noise relative to the
response, as H1 estimates have (3.59: ``|H|^2 (1 - coherence)``), is then of one level on
every line too: the weighted fit is its maximum-likelihood fit.

Without the weights, the lines at resonances dominate and the quiet lines barely count: a
displacement FRF rolls off as ``1 / w^2``, so the lines at the top of its band weigh
hundreds of times less than those at the bottom, and the tails of modes just above the band
go unfitted (the family's ``truss_high`` in displacement, 1% noise: logLS 0.073 against the
exact response, 0.0008 weighted); near-null channels of a symmetric structure away from the
resonances likewise (the cluster's hub channels: 0.030 -> 0.0016 over its band).

Neither weighting is best on every test, so the default (``weighting="auto"``) fits
both and keeps the fit whose mean logLS (3.12) against the data of the band is the lower
(:func:`kept_pass`): the measure the models are judged by, computed on the test's own lines
and channels, no threshold.  On the family at 1% noise (seeds 1-3), over their bands and
over fresh ones, in acceleration and displacement (36 cases, ``weighting="none"`` /
``"level"``, logLS of the identified model against the exact response), the rule kept the
fit closer to the exact response every time: the weighted fit on the truss (0.0057 /
0.0041), the cluster (0.030 / 0.00032), displacement data (truss_high 0.073 / 0.0008), the
ladder over 20-70 Hz (0.00018 / 2.1e-5), the held-out structure (0.088 / 0.0041),
``truss_high`` at seed 1 (0.00047 / 7.5e-5); the unweighted one on the plate at 1% (0.00029
/ 0.00050), ``truss_high`` at seed 2 (0.00062 / 0.00080) and ``truss_high`` tested
over 30-70 Hz, modes at 27.6 and 77.6 Hz just outside (0.0009 / 0.072: with the weights, the
out-of-band probe's start cost falls steadily towards the far bound, the trial is pushed to
the bound and rejected).  The weighted fit's gain is at the quiet lines: the tails of modes
outside the band, near-null channels and the top of a displacement FRF, which the
unweighted fit leaves; its loss is where the loud lines of resonances carry the information
(a mode's tail is fitted from its peak).  Both passes take the same time;
``cm.search.weighting`` records the one kept and ``cm.search.weighting_logls`` both
figures.  Data taken through an exponential window (impact tests: lines correlated) are not
weighted, and fitted once.  So are noise-free data (no measurable noise,
:func:`~sdctrl.identification._compression.measurable_noise`): the weights are the
maximum-likelihood ones for noise relative to the response, and without noise the
weighted fit chases round-off -- the noise-free testbed (``sd.testbed_frf()``), whose
modal solution differs by 1e-9 between BLAS thread counts, gave 15, 22 or 25 poles (up to
six spurious in band) and the unweighted fit 13 every time.

The LSCF start of both passes (:func:`~sdctrl.identification._fit_pass.fit_pass`) fits the
data without the line weights: it fits a rational function of ``s``, which a sum of modes
is and the same data times the weights are not (level-weighted, a noise-free six-mode
receptance gave one stable pole of six, ``truss_high`` at 1% a start that ended at logLS
0.00083 instead of 7.5e-5, the noise-free plate at 5e-4 with seven poles instead of 1.2e-12).

Data with a coherence declare their noise (3.59, the point variance ``|H|^2 (1 -
coherence)``): there the fit kept is the one whose misfit over that variance is the lower
(:func:`misfit`; ``cm.search.weighting_variance``), not the logLS, which counts noise as
misfit where it is not relative to the response.  The hammer survey of
``tests/test_identify_real_tests.py`` (2% relative noise plus a floor of 0.2% of each
channel's peak, coherence below 0.5 at antiresonances): logLS against the data 0.0954 /
0.0931 would keep the weighted fit, 0.0258 against the exact response; the misfit over the
point variance (1.817 / 1.864) keeps the unweighted one, 0.0204.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["WEIGHTINGS", "kept_pass", "line_weights", "misfit", "passes_to_run"]

#: the values of :func:`~sdctrl.identify`'s ``weighting``
WEIGHTINGS = ("auto", "none", "level")

#: an entry below this fraction of its channel's largest counts as this fraction (exact
#: zeros of a channel -- a node -- do not make a line's level zero)
FLOOR = 1e-12


def line_weights(Hm: np.ndarray) -> np.ndarray:
    """Weight of each line: the inverse geometric mean of ``|H|`` over the channels
    (module notes), normalised to a geometric mean of one over the lines.

    Parameters
    ----------
    Hm : ndarray, shape (nf, m)
        Complex FRF data, one column per sensor/actuator pair.

    Returns
    -------
    ndarray, shape (nf,)
        Positive weights (all ones when every channel is zero).
    """
    A = np.abs(Hm)
    top = A.max(axis=0)
    live = top > 0
    if not live.any():
        return np.ones(Hm.shape[0])
    A = np.maximum(A[:, live], FLOOR * top[live])
    log_level = np.mean(np.log(A), axis=1)
    return np.exp(np.mean(log_level) - log_level)


def passes_to_run(weighting: str, rules, Hm) -> tuple[str, ...]:
    """The line weightings to fit (``"none"``, ``"level"``) for :func:`~sdctrl.identify`'s
    ``weighting`` on the data ``Hm`` (lines x channels): for ``"auto"``, both where lines
    may be weighted (``rules.smooth_scan``: no exponential window) and the data show noise
    (:func:`~sdctrl.identification._compression.measurable_noise`), else the unweighted
    one; otherwise the one asked for, where it applies."""
    from sdctrl.identification._compression import measurable_noise

    if not rules.smooth_scan:
        return ("none",)
    if weighting == "auto":
        return ("none", "level") if measurable_noise(Hm) else ("none",)
    return (weighting,)


def kept_pass(passes, data):
    """Of ``[(cm, caught warnings), ...]`` (one per weighting fitted to ``data``, the band's
    lines), the one closest to the data (:func:`misfit`; the first on a tie); with two
    passes, both logLS figures are recorded on the kept model's ``search.weighting_logls``
    (unweighted, weighted), and where the coherence decided, both of its figures on
    ``search.weighting_variance``."""
    from dataclasses import replace

    from sdctrl.identification._noise import point_variance

    if len(passes) == 1:
        return passes[0]
    pv = point_variance(data)
    scores = [misfit(p[0], data, pv) for p in passes]
    best = int(np.argmin(scores))
    cm, caught = passes[best]
    logls = tuple(float(p[0].search.logls) for p in passes)
    by_variance = None if pv is None else tuple(float(x) for x in scores)
    search = replace(cm.search, weighting_logls=logls, weighting_variance=by_variance)
    return replace(cm, search=search), caught


def misfit(cm, data, pv) -> float:
    """How far ``cm`` is from ``data`` by the noise the data declare: with a coherence below
    one, the mean of ``|H_fit - H|^2`` over the point variance (3.59) of the lines and
    channels that have one (the fit's chi-square per entry: the noise of an H1 estimate is
    not always relative, a floor makes it absolute at antiresonances, where the logLS
    counts the noise as misfit); without, the mean logLS (3.12, ``cm.search.logls``: the
    maximum-likelihood measure of noise relative to the response, as the family's).  ``pv``
    is the data's point variance (``point_variance(data)``, None without a coherence)."""
    if pv is None:
        return float(cm.search.logls)
    H = cm.frf(data.freq, quantity=data.quantity).H
    live = pv > 0
    return float(np.mean(np.abs(H - data.H)[live] ** 2 / pv[live]))
