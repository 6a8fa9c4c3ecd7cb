"""The rank-one real residue of an extra mode closest to its per-channel fits, in the cost's
own metric (:func:`sdctrl.diagnosis._global_effects.fit_free_mode`).

A mode's residue ``c b^T`` (2.15) is rank one; the per-channel least-squares fits ``X`` of
the linearised complex logLS residual (3.12) are not, under noise.  Each channel's proxy cost
is ``W (x - X)^2`` plus a constant, ``W`` its least-squares weight: large where the data are
small.  A test of a symmetric structure has near-null channels (a sensor on the plane of
symmetry, an actuator driving only the antisymmetric modes) whose weights are many decades
above the others; there the residue must be fitted to its own tiny value.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["rank_one"]

#: at most this many alternating least-squares sweeps of an extra mode's rank-one residue
#: (:func:`rank_one`; they stop when the weighted misfit no longer decreases)
SWEEPS = 500
#: ... when a sweep lowers the proxy cost by less than this share of it
RTOL = 1e-9


def rank_one(X, W, floor=0.0, sweeps=SWEEPS):
    """``c b^T`` minimising ``sum W (X - c b^T)^2``: the rank-one residue closest to the
    per-channel fits ``X`` in the cost's own metric (``W`` each channel's least-squares
    weight, the proxy cost being ``sum W (x - X)^2`` plus a constant, ``floor``: the sweeps
    stop when they lower the proxy cost by less than ``RTOL`` of it).  The plain SVD
    weights every channel alike: a channel that is nearly null (by a structure's symmetry,
    say) is then given a residue far above its own response, and under noise the
    truncation error there dominates the whole cost.  Alternating weighted least squares,
    the best of four runs kept: from the SVD's rank-one term and from the skeleton ``X[:,
    a] X[s, :] / X[s, a]`` through the channel best determined (largest ``W X^2``), each
    with ``b`` or ``c`` updated first.  From a start whose small factor is wrong (the SVD's
    is the noise of the other channels), updating the other factor first locks it to zero
    on the heavy channel's row or column (a local minimum, the large entries there 100%
    off); which factor is small depends on the mode and the channels.  Not covered: a
    residue whose small sensor and actuator factors both sit on heavy channels."""
    U, S, Vt = np.linalg.svd(X)
    s_, a_ = np.unravel_index(np.argmax(W * X**2), X.shape)
    starts = [(U[:, 0] * S[0], Vt[0])]
    if X[s_, a_] != 0:
        starts.append((X[:, a_].copy(), X[s_] / X[s_, a_]))
    best = None
    for (c, b), first in itertools.product(starts, "bc"):
        c, b, F = _alternating(X, W, c, b, sweeps, first, floor)
        if best is None or F < best[0]:
            best = (F, c, b)
    return np.outer(best[1], best[2])


def _alternating(X, W, c, b, sweeps, first="b", floor=0.0):
    """Alternating weighted least squares of ``c b^T`` from ``(c, b)``, ``b`` (or ``c``)
    updated first, until the weighted misfit plus ``floor`` no longer decreases: ``(c, b,
    misfit)``."""
    WX, F = W * X, float(np.sum(W * (np.outer(c, b) - X) ** 2))
    for _ in range(sweeps):
        if first == "b":
            b = (c @ WX) / np.maximum(c**2 @ W, 1e-300)
        c = (WX @ b) / np.maximum(W @ b**2, 1e-300)
        b = (c @ WX) / np.maximum(c**2 @ W, 1e-300)
        Fn = float(np.sum(W * (np.outer(c, b) - X) ** 2))
        if F - Fn <= RTOL * (Fn + floor):
            return c, b, min(Fn, F)
        F = Fn
    return c, b, F
