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

Measured at 1% noise, seed 1 (logLS of the identified model against the exact response;
``weighting="none"`` -> ``"level"``; the estimator's floor, least-squares residues at the
exact poles, in brackets): truss 0.0057 -> 0.0041 (0.0024), truss_high 0.00047 -> 0.00083
(0.0007), ladder 0.0019 -> 0.00043, plate 0.00029 -> 0.00050 (0.0003), cluster 0.030 ->
0.00032 (0.017, unweighted); the truss from displacement or velocity data 0.030 / 0.0077
-> 0.0041 / 0.0041 (a weight ``1 / level`` absorbs the ``|s|^k`` of the quantity); the
cluster over 8-30 Hz 0.099 -> 1.5e-5; a held-out structure with ten modes below its band
0.088 / 0.044 / 0.040 -> 0.0041 / 0.0041 / 0.0044 (seeds 1-3).  Not yet the default: with it,
51 locked figures of the test suite move (most of them better, each to be re-examined),
the noise-free plate goes 4.5e-12 -> 5e-4 (7 poles instead of 12), and the held-out
structure at seed 1 gains a spurious in-band pole at its upper band edge (61.9 Hz, damping
4e-4, next to a mode at 63.1 Hz; significant 7-9x and its damping determined to 0.2 in
``ln zeta`` by the selection's noise field, 1.6 by the final statistics), and displacement
data of modes at 12 and 70 Hz outside a 16-62 Hz band
(``tests/test_identify_damped_modes.py``, 1%) go 1.8e-5 -> 0.018: the weighted trial poles
settle at 4.5-5.1 and 83-92 Hz and are removed again, the selection cycling; likewise
``truss_high`` tested over 30-70 Hz at 1% (modes at 27.6 and 77.6 Hz just outside): 0.0009
-> 0.072, no out-of-band pole kept -- the out-of-band probe's start cost falls steadily
towards the far bound (8.4e-4 at 7.7 Hz against 9.7e-4 at 25.8 Hz), the trial is pushed to
the bound and rejected (probing from every local minimum of that cost changes nothing).  Data taken through an exponential window (impact tests:
lines correlated) are not weighted.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["line_weights"]

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
