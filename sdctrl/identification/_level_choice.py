"""The noise level per line of a fit's residual, chosen line by line between an additive and a
proportional level (the pole statistics without a coherence,
:mod:`~sdctrl.identification._pole_statistics`, thesis 3.4).

A test's noise is partly additive (a sensor's noise over the force spectrum: smooth over the
lines, the same at a peak as beside it) and partly proportional to the response (the force's
noise, leakage, a shaker's drive).  ``A`` is the running median of the residual's second
differences, ``M`` that of their ratio to the fitted ``|H|^2``, times ``|H|^2``.  Each is right
where its kind of noise dominates every line; they differ at peaks and anti-resonances, where
the statistics are read.

The larger of the two, the rule before, overstates additive noise at a peak narrower than the
running median's window: ``M`` there is the median ratio *beside* the peak times the peak's
``|H|^2``.  Roving-hammer survey, plate, 400 lines, coherence removed: the level at the top 3%
and 1% of lines was 5.2x and 9.5x the noise's variance (0.64x over all lines; 3 draws against
the variance over 30), and the 45 and 49.6 Hz modes' frequency and damping std 1.8-3x their
scatter.  Here each line takes the mixture ``(1 - p) A + p max(A, M)`` of :data:`GRID` whose
likelihood is largest over its neighbourhood of ``2 HALF + 1`` lines (each point estimate
``e_j`` is exponential with mean ``v_j``, the sum of the squares of two Gaussian parts: cost
``sum_j log v_j + e_j / v_j``), if it beats the larger level by :data:`MARGIN`.  The same
survey: 0.94x and 1.11x at the top lines (0.58x over all lines), those modes' scatter
0.87-1.16 of their std.

Two choices keep what the rule before got right:

- **never below the additive level.**  Where ``M < A`` (anti-resonances, and dips where modes
  cancel), ``M`` stands on a fitted ``|H|`` whose relative error is largest there: the
  cluster's hub channels at its four blade modes (10.15-10.29 Hz, 2-3 lines) have ``A / M``
  up to 100 and point estimates 8-12x ``M`` at the lines that determine the modes.  Choosing
  ``M`` there (a two-sided choice) cut the blade modes' scale std up to 2.3x and took 4 of 13
  draws further from the truth, 2 of them from the FE's scale (right) to the test's (0.5-0.9
  off in log): their error over std rose from rms 1.70 to 2.49
  (``tests/test_hybrid_mass_scale.py``).  With the floor the cluster is unchanged.  A
  proportional noise's level at an anti-resonance stays overstated (conservative);
- **no cap on a point's term.**  A line the model misses (its error larger than any noise)
  keeps the larger level about it: a capped term counts it the same under every level, and
  the smaller one then wins.

Where the residual itself holds the model's error the level follows it: the same survey's
26.3, 28.3 and 59.6 Hz modes have point estimates 9-17x the noise's variance at their peaks
(the automatic selection's fit there is above the noise), and their std stay 1.7-2.2x the
scatter.  A residual cannot tell that error from noise: give the coherence.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GRID", "HALF", "MARGIN", "chosen_level"]

#: mixing fractions ``p`` tried: the ratio ``p / (1 - p)`` from 1e-3 to 1e3 in steps of
#: 10^0.25, and the additive level alone (the larger level, ``p = 1``, is the default each of
#: these must beat)
GRID = np.concatenate([[0.0], 1.0 / (1.0 + 10.0 ** -np.arange(-3.0, 3.01, 0.25))])
#: half-width (lines) of the neighbourhood whose likelihood chooses a line's mixture: eleven
#: lines, about four independent second differences (each spans three lines)
HALF = 5
#: log-likelihood the neighbourhood must gain to leave the larger level (the rule before):
#: the choice is otherwise biased low (the mixture nearest each draw; proportional noise at
#: its peaks read 0.87 of its variance with no margin, 1.00 with 3; additive noise 1.20-1.21)
MARGIN = 3.0


def chosen_level(e: np.ndarray, A: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Per line, the mixture ``(1 - p) A + p max(A, M)`` of :data:`GRID` of largest likelihood
    for the point estimates ``e`` over the line's neighbourhood, where it beats ``max(A, M)``
    by :data:`MARGIN` (module notes).

    Parameters
    ----------
    e : ndarray (nf, m)
        Point estimates of the noise's variance (mean ``v_k``), non-negative.
    A, M : ndarray (nf, m)
        The additive and proportional candidate levels, positive.

    Returns
    -------
    ndarray (nf, m)
        Each line's level, between ``A`` and ``max(A, M)``.
    """
    top = np.maximum(A, M)
    out = top.copy()
    best = _cost(e, top) - MARGIN
    for p in GRID:
        v = (1.0 - p) * A + p * top
        cost = _cost(e, v)
        better = cost < best
        best[better] = cost[better]
        out[better] = v[better]
    return out


def _cost(e, v):
    """The negative log-likelihood of each line's neighbourhood (module notes)."""
    return _neighbourhood_sum(np.log(v) + e / v, HALF)


def _neighbourhood_sum(X: np.ndarray, half: int) -> np.ndarray:
    """Sum over lines ``k - half .. k + half`` (cut at the edges) of each line ``k`` (axis 0)."""
    nf = X.shape[0]
    c = np.concatenate([np.zeros((1,) + X.shape[1:]), np.cumsum(X, axis=0)])
    k = np.arange(nf)
    return c[np.minimum(k + half + 1, nf)] - c[np.maximum(k - half, 0)]
