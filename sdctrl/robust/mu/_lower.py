"""Lower bound of the robust stability margin: the smallest destabilising real Delta found.

The closed loop with the real parameters ``delta`` (one per block, ``|delta_i| <= alpha``) has
the state matrix ``A(delta) = A + Bc (I - Psi Dc)^-1 Psi Cc`` with ``Psi = R diag(delta) L``
(channels read and drive a few signals, :class:`sdctrl.robust.mu._frequency_sweep.FactoredSystem`).
Any ``delta`` that puts an eigenvalue on the imaginary axis proves ``margin <= max|delta_i|``.

The search is the real-parameter form of the mu power iteration (Young, Newlin and Doyle):
from each closed-loop pole, ``delta = alpha sign(d Re(lambda) / d delta)`` (the vertex that
pushes that pole right fastest), ``alpha`` the first crossing along it, the signs re-evaluated
at the crossing until they no longer change (a KKT point of ``min max|delta_i|`` subject to
``Re lambda = 0``); then random sign patterns and single sign flips around the best point.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq

__all__ = ["Destabilising", "destabilise", "perturbed_A"]


@dataclass(frozen=True, eq=False)
class Destabilising:
    """Smallest destabilising perturbation found.

    Parameters
    ----------
    alpha : float
        ``max |delta_i|`` (``inf`` when none was found).
    delta : ndarray
        Normalised parameters (one per block); the closed loop has an eigenvalue with
        non-negative real part.
    frequency : float
        ``|Im lambda|`` (rad/s) of the eigenvalue on the axis.
    """

    alpha: float
    delta: np.ndarray
    frequency: float


def _psi(fs, chan_block, d):
    return fs.R @ (d[chan_block][:, None] * fs.L)


def perturbed_A(fs, chan_block, d) -> np.ndarray:
    """Closed-loop state matrix for the block parameters ``d``.

    Parameters
    ----------
    fs : FactoredSystem
        Closed-loop Delta channels.
    chan_block : ndarray
        Block index of each channel.
    d : ndarray
        Parameter of each block.

    Returns
    -------
    ndarray
    """
    Psi = _psi(fs, chan_block, np.asarray(d, float))
    if np.any(fs.Dc):
        Psi = np.linalg.solve(np.eye(Psi.shape[0]) - Psi @ fs.Dc, Psi)
    return fs.A + fs.Bc @ Psi @ fs.Cc


def _max_real(fs, chan_block, d_stack):
    """Largest real part of the closed-loop eigenvalues for each row of ``d_stack``."""
    As = np.array([perturbed_A(fs, chan_block, d) for d in d_stack])
    return np.linalg.eigvals(As).real.max(axis=1)


def _critical(fs, chan_block, nb, d, pick=None):
    """Eigenvalue (largest real part, or nearest ``pick``) and the gradient of its real part."""
    d = np.asarray(d, float)
    lam, Yl, Xr = sla.eig(perturbed_A(fs, chan_block, d), left=True, right=True)
    k = int(np.argmax(lam.real)) if pick is None else int(np.argmin(np.abs(lam - pick)))
    x, y = Xr[:, k], Yl[:, k]
    Psi = _psi(fs, chan_block, d)
    a = y.conj() @ fs.Bc
    b = fs.Cc @ x
    if np.any(fs.Dc):
        eye = np.eye(Psi.shape[0])
        a = np.linalg.solve((eye - Psi @ fs.Dc).T, a)
        b = np.linalg.solve(np.eye(Psi.shape[1]) - fs.Dc @ Psi, b)
    per_chan = (a @ fs.R) * (fs.L @ b) / (y.conj() @ x)
    g = np.bincount(chan_block, per_chan.real, minlength=nb)
    return lam[k], g


def _first_crossing(fs, chan_block, s, cap: float, n_scan: int = 12):
    """Smallest ``alpha`` in ``(0, cap]`` found with ``A(alpha s)`` not stable (scan + Brent)."""
    if np.isfinite(cap):
        grid = cap * np.arange(1, n_scan + 1) / n_scan
    else:
        grid = 0.02 * 2.0 ** np.arange(14)
    f = _max_real(fs, chan_block, grid[:, None] * s[None])
    hit = np.flatnonzero(f >= 0)
    if not hit.size:
        return np.inf
    j = hit[0]
    hi = grid[j]
    lo = grid[j - 1] if j > 0 else 0.0
    if lo == 0.0 and _max_real(fs, chan_block, [hi * s * 1e-9])[0] >= 0:
        return hi * 1e-9

    def fr(a):
        return _max_real(fs, chan_block, [a * s])[0]
    a = brentq(fr, lo, hi, xtol=1e-13 * hi, rtol=1e-15)
    # returned on the unstable side, by a margin that survives rounding in other codes
    for k in range(60):
        b = a * (1 + 1e-9 * 2.0 ** k)
        if b >= hi or fr(b) >= 0:
            return min(b, hi)
    return hi


def _sign_iteration(fs, chan_block, nb, s, cap, iters: int = 8):
    """Fixed point of ``s = sign(grad Re lambda_crit(alpha s))``; returns (alpha, s)."""
    best = (np.inf, s)
    for _ in range(iters):
        a = _first_crossing(fs, chan_block, s, min(cap, best[0]))
        if not np.isfinite(a):
            break
        best = (a, s)
        _, g = _critical(fs, chan_block, nb, a * s)
        s_new = np.where(np.abs(g) > 1e-12 * np.max(np.abs(g)), np.sign(g), s)
        if np.array_equal(s_new, s):
            break
        s = s_new
    return best


def destabilise(fs, reps, n_random: int = 20, seed: int = 0, near=None) -> Destabilising:
    """Search the smallest destabilising real perturbation of the closed loop.

    Parameters
    ----------
    fs : FactoredSystem
        Closed-loop Delta channels (stable at ``delta = 0``).
    reps : sequence of int
        Repetition of each real scalar block (channel order).
    n_random : int
        Random sign patterns tried besides the one from each closed-loop pole.
    seed : int
        Random seed (deterministic results).
    near : float, optional
        Only start from the poles nearest this frequency (rad/s), e.g. the peak of the
        upper bound (refinement).

    Returns
    -------
    Destabilising
    """
    nb = len(reps)
    chan_block = np.repeat(np.arange(nb), reps)
    rng = np.random.default_rng(seed)
    lam0 = np.linalg.eigvals(fs.A)
    poles = lam0[lam0.imag >= 0]
    order = np.argsort(-poles.real / np.maximum(np.abs(poles), 1e-300))   # least damped first
    if near is not None:
        order = np.argsort(np.abs(np.abs(poles.imag) - near))[:4]
    starts = []
    for p in poles[order]:
        _, g = _critical(fs, chan_block, nb, np.zeros(nb), pick=p)
        if np.any(g):
            starts.append(np.where(g != 0, np.sign(g), 1.0))
    starts += list(rng.choice([-1.0, 1.0], size=(n_random, nb)))
    best_a, best_s = np.inf, np.zeros(nb)
    for s in starts:
        a, s_fix = _sign_iteration(fs, chan_block, nb, np.asarray(s, float), best_a)
        if a < best_a:
            best_a, best_s = a, s_fix
    if np.isfinite(best_a) and nb > 1:         # single sign flips of the weakest parameters
        _, g = _critical(fs, chan_block, nb, best_a * best_s)
        for i in np.argsort(np.abs(g))[:min(nb, 8)]:
            s = best_s.copy()
            s[i] = -s[i]
            a, s_fix = _sign_iteration(fs, chan_block, nb, s, best_a, iters=3)
            if a < best_a:
                best_a, best_s = a, s_fix
    if not np.isfinite(best_a):
        return Destabilising(np.inf, np.zeros(nb), np.nan)
    delta = best_a * best_s
    lam, _ = _critical(fs, chan_block, nb, delta)
    return Destabilising(float(best_a), delta, float(abs(lam.imag)))
