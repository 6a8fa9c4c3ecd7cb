"""The mu upper bound over the whole frequency axis, certified on intervals.

For a stable system ``M(s) = L (Cc (sI - A)^-1 Bc + Dc) R`` (the Delta channels of a closed
loop through the few signals they read and drive), a scaling pair ``(D, G)`` that certifies
``mu(M(j w0)) < beta`` at one frequency certifies it on the whole interval around ``w0`` bounded
by the nearest imaginary eigenvalues of a Hamiltonian matrix of twice the state dimension
(:func:`interval`).  :func:`cover` covers ``[0, inf)`` with such intervals: the cheap
Osborne-balanced bound where it suffices, the D-G bound (:func:`sdctrl.robust.mu._upper.dg_upper`,
warm started from the nearest frequency done) elsewhere, new frequencies in the gaps until none is
left.  The level ``beta`` rises only where the bound at a frequency is above it, so the result
holds for every frequency, not only on a grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.statespace import ss_frf
from sdctrl._lib.threads import single_thread
from sdctrl.robust.mu._upper import (
    BlockStructure,
    Factored,
    block_norms_squared,
    dg_upper,
    evaluate,
    osborne,
)

__all__ = ["CoverResult", "FactoredSystem", "cheap_bounds", "cover", "interval"]


@dataclass(frozen=True, eq=False)
class FactoredSystem:
    """``M(s) = L (Cc (sI - A)^-1 Bc + Dc) R``: Delta-channel response through a small core.

    Parameters
    ----------
    A, Bc, Cc, Dc : ndarray
        Real state-space matrices of the core (``p`` outputs, ``m`` inputs).
    L, R : ndarray
        Channel factors (N, p) and (m, N).
    """

    A: np.ndarray
    Bc: np.ndarray
    Cc: np.ndarray
    Dc: np.ndarray
    L: np.ndarray
    R: np.ndarray

    def core(self, w) -> np.ndarray:
        """Core responses ``Cc (j w I - A)^-1 Bc + Dc``.

        Parameters
        ----------
        w : array_like
            Frequencies (rad/s).

        Returns
        -------
        ndarray (nw, p, m)
        """
        return ss_frf(self.A, self.Bc, self.Cc, self.Dc, np.atleast_1d(np.asarray(w, float)))

    def augmented(self, eps: float) -> FactoredSystem:
        """Channels of the regularised structure ``delta + eps delta_c``.

        Parameters
        ----------
        eps : float
            Relative size of the complex part.

        Returns
        -------
        FactoredSystem
            ``[[M, M], [eps M, eps M]]`` through the same core.
        """
        return FactoredSystem(self.A, self.Bc, self.Cc, self.Dc,
                              np.vstack([self.L, eps * self.L]), np.hstack([self.R, self.R]))


def cheap_bounds(Ks, L, R, st: BlockStructure):
    """Osborne-balanced complex bound on a stack of frequencies, vectorised.

    Parameters
    ----------
    Ks : ndarray (nf, p, m)
        Cores ``K`` at each frequency (``M = L K R``).
    L, R : ndarray
        Channel factors (N, p) and (m, N).
    st : BlockStructure
        Structure.

    Returns
    -------
    bounds : ndarray (nf,)
        Certified ``||D^(1/2) M D^(-1/2)||`` (an upper bound of mu for any block kinds).
    d : ndarray (nf, nb)
        The block scalings (``st.start(d[i])`` is the parameter vector).

    Notes
    -----
    Frequencies are taken in chunks so that no array exceeds a few million entries,
    whatever the number of channels.
    """
    nb, N = len(st.sizes), st.N
    chunk = max(1, int(4e6 // (nb * nb + N * (L.shape[1] + R.shape[0]))))   # bounded memory
    bounds, ds = [], []
    for i in range(0, len(Ks), chunk):
        K = Ks[i:i + chunk]
        d = osborne(np.sqrt(block_norms_squared(K, L, R, st)))
        sq = np.sqrt(d[:, st.block_of_channel])                      # (nf, N)
        T1 = np.linalg.qr(sq[:, :, None] * L[None])[1]
        T2 = np.linalg.qr(R.conj().T[None] / sq[:, :, None])[1]
        core = T1 @ K @ np.conj(np.swapaxes(T2, 1, 2))
        bounds.append(np.linalg.svd(core, compute_uv=False)[:, 0])
        ds.append(d)
    return np.concatenate(bounds), np.concatenate(ds)


def interval(fs: FactoredSystem, st: BlockStructure, x, beta: float, w0: float,
             tol: float = 1e-7):
    """Frequency interval around ``w0`` on which the scalings ``x`` certify ``mu <= beta``.

    In scaled form the condition (1) of :mod:`sdctrl.robust.mu._upper` reads
    ``Psi(w) = T Q(w) T^H - beta^2 I <= 0`` where only ``Q`` depends on the frequency, through the
    core: ``Q = N^H Pi N`` with ``N(s) = blkdiag(Mc(s), I) T^H``, ``Pi = [[W, -jI], [jI, 0]]``,
    ``W = Lh^H Lh``.  ``det Psi(j w) = 0`` exactly when ``j w`` is an eigenvalue of the Hamiltonian
    matrix of this Popov function, of size twice the state dimension; between two such frequencies
    ``Psi`` keeps its inertia.

    Parameters
    ----------
    fs : FactoredSystem
        The system (``fs.L``, ``fs.R`` with ``st.N`` channels).
    st : BlockStructure
        Structure.
    x : ndarray
        Scalings (parameter vector).
    beta : float
        Level.
    w0 : float
        Frequency (rad/s) where the scalings were computed.
    tol : float
        Eigenvalues with ``|Re| <= tol (|lambda| + ||A||)`` count as crossings (conservative).

    Returns
    -------
    (float, float)
        ``(w_lo, w_hi)`` in rad/s (``w_hi`` may be ``inf``); ``w_lo > w_hi`` (empty) when the
        scalings do not certify ``beta`` at ``w0``.
    """
    A, Bc, Cc, Dc = fs.A, fs.Bc, fs.Cc, fs.Dc
    mats = st.unpack(x)
    Lh = st.apply(mats, fs.L, 0, herm=True)
    T = np.linalg.qr(np.hstack([st.apply(mats, fs.R.conj().T, 1), st.apply(mats, Lh, 2)]))[1]
    m, p, k = Bc.shape[1], Cc.shape[0], T.shape[0]
    Th = T.conj().T
    T1, T2 = Th[:m], Th[m:]
    W = Lh.conj().T @ Lh
    Pi = np.block([[W, -1j * np.eye(p)], [1j * np.eye(p), np.zeros((p, p))]])

    def psi_max(ws):                 # largest eigenvalue of Psi at each frequency, vectorised
        Nw = np.concatenate([fs.core(ws) @ T1, np.broadcast_to(T2, (len(ws),) + T2.shape)], 1)
        P = np.conj(np.swapaxes(Nw, 1, 2)) @ Pi @ Nw
        return np.linalg.eigvalsh(0.5 * (P + np.conj(np.swapaxes(P, 1, 2))))[:, -1] - beta ** 2

    if psi_max([w0])[0] >= 0:
        return (w0, w0 - 1.0)
    DcT = Dc @ T1
    Dn = np.vstack([DcT, T2])
    Bn = Bc @ T1
    S = Cc.T @ (W @ DcT - 1j * T2)                                 # Cn^H Pi Dn
    Rm = Dn.conj().T @ Pi @ Dn
    Rm = 0.5 * (Rm + Rm.conj().T) - beta ** 2 * np.eye(k)
    try:
        Ri = np.linalg.inv(Rm)
    except np.linalg.LinAlgError:
        return (w0, w0)
    Ah = A - Bn @ Ri @ S.conj().T
    H = np.block([[Ah, -Bn @ Ri @ Bn.conj().T],
                  [-Cc.T @ W @ Cc + S @ Ri @ S.conj().T, -Ah.conj().T]])
    lam = np.linalg.eigvals(H)
    scale = np.linalg.norm(A, 1)
    for t in (tol, 1e3 * tol):
        cross = lam.imag[(np.abs(lam.real) <= t * (np.abs(lam) + scale)) & (lam.imag >= 0)]
        if cross.size:       # near-axis eigenvalues where Psi is clearly negative: no crossing
            cross = cross[psi_max(cross) >= -1e-6 * beta ** 2]
        below, above = cross[cross <= w0], cross[cross > w0]
        lo = float(below.max()) if below.size else 0.0
        hi = float(above.min()) if above.size else np.inf
        # independent check on samples of the interval (a missed crossing shows here)
        top = hi if np.isfinite(hi) else 1e4 * max(w0, scale, 1.0)
        frac = np.array([0.001, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999])
        ws = np.concatenate([w0 - (w0 - lo) * frac, w0 + (top - w0) * frac ** 2])
        if np.all(psi_max(ws) < 0):
            return (lo, hi)
    return (w0, w0)


@dataclass(frozen=True, eq=False)
class CoverResult:
    """Result of :func:`cover`.

    Parameters
    ----------
    level : float
        Certified bound: ``mu(M(j w)) <= level`` for every ``w >= 0``.
    certified : bool
        Whether the intervals cover the whole axis (False: stopped by ``max_points``).
    w, bound : ndarray
        Frequencies (rad/s, sorted) where a bound was computed, and that bound.
    peak_w : float
        Frequency of the largest computed bound.
    n_dg : int
        Number of D-G optimisations.
    intervals : ndarray (k, 2)
        The certified intervals (rad/s).
    """

    level: float
    certified: bool
    w: np.ndarray
    bound: np.ndarray
    peak_w: float
    n_dg: int
    intervals: np.ndarray


def _point(fs: FactoredSystem, st: BlockStructure, w: float, K, d, x0, level: float,
           stop: float):
    """Bound at one frequency (cheap start, D-G when needed) and its certified interval."""
    with single_thread():
        fm = Factored(K, fs.L, fs.R)
        xc = st.start(d)
        if x0 is not None and evaluate(fm, st, x0, grad=False)[0] > evaluate(
                fm, st, xc, grad=False)[0]:
            x0 = None                     # the balanced start is better than the neighbour's
        bound, x = dg_upper(fm, st, x0=xc if x0 is None else x0, stop=stop)
        span = interval(fs, st, x, level, w) if bound < level else (w, w - 1.0)
    return bound, x, span


def _nearest(dg_w, dg_x, w: float, wanted: bool):
    """Scalings of the D-G frequency nearest ``w`` (log scale), to warm start; None if none."""
    if not wanted or not dg_w:
        return None
    return dg_x[int(np.argmin(np.abs(np.log1p(np.array(dg_w)) - np.log1p(w))))]


def _gaps(intervals, w_max: float):
    """Uncovered parts of ``[0, inf)`` (closed intervals may touch)."""
    if not intervals:
        return [(0.0, np.inf)]
    iv = sorted(intervals)
    gaps, reach = [], 0.0
    for lo, hi in iv:
        if lo > reach * (1 + 1e-12):        # closed intervals touching up to rounding: no gap
            gaps.append((reach, lo))
        reach = max(reach, hi)
    if reach < np.inf:
        gaps.append((reach, np.inf))
    return gaps


def _pick(a: float, b: float, cand, cheap, w_ref: float) -> float:
    """Frequency to try in the gap ``(a, b)``: the start frequency of largest cheap bound
    strictly inside, else the middle (geometric for wide gaps, beyond ``a`` if unbounded)."""
    inside = (cand > a) & (cand < b)
    if np.any(inside):
        return float(cand[inside][np.argmax(cheap[inside])])
    if not np.isfinite(b):
        return max(2.0 * a, a + w_ref)
    if a > 0 and b / a > 1.5:
        return float(np.sqrt(a * b))
    return 0.5 * (a + b)


def cover(fs: FactoredSystem, st: BlockStructure, w_start, level: float, rtol: float = 0.01,
          executor=None, bar=None, max_points: int = 3000, warm=None) -> CoverResult:
    """Certify ``mu(M(j w)) <= level`` on ``[0, inf)``, raising ``level`` where needed.

    The cheap bound is computed at every ``w_start`` (vectorised) and certifies intervals
    where it is below the level (one interval per start frequency not already inside one).
    Then, in rounds, one frequency per uncovered gap (the start frequency of largest cheap
    bound in it, else its middle) gets the D-G bound, warm started from the nearest D-G
    frequency, and the interval its scalings certify.

    Parameters
    ----------
    fs : FactoredSystem
        Stable system (``st.N`` channels).
    st : BlockStructure
        Structure.
    w_start : array_like
        First frequencies (rad/s), e.g. the closed-loop modal frequencies.
    level : float
        Starting level; raised to ``(1 + rtol)`` times any bound found above it.
    rtol : float
        Relative slack between the bounds computed and the certified level: the D-G search at
        a frequency stops once below ``level / (1 + rtol)``.
    executor : concurrent.futures.Executor, optional
        Runs the frequencies of a round in parallel (results identical to the serial run).
    bar : progress bar, optional
        Updated once per frequency.
    max_points : int
        Give up (``certified=False``) after that many frequencies.
    warm : tuple, optional
        ``(w, x)``: scalings already optimised at ``w`` (warm start for its neighbours).

    Returns
    -------
    CoverResult
    """
    w_ref = float(np.max(np.abs(np.linalg.eigvals(fs.A)), initial=1.0))
    cand = np.unique(np.asarray(w_start, float))
    ws, bounds, intervals = [], [], []
    dg_w, dg_x = ([float(warm[0])], [warm[1]]) if warm is not None else ([], [])
    n_dg, certified = 0, True
    run = executor.map if executor is not None else map
    cheap_c, d_c = cheap_bounds(fs.core(cand), fs.L, fs.R, st)
    ok = cheap_c < level / (1 + rtol)
    for i in np.flatnonzero(ok):                    # cheap certificates: no optimisation
        if any(lo <= cand[i] <= hi for lo, hi in intervals):
            # already certified by a neighbour's interval: its cheap bound is kept (a bound
            # computed there) without a Hamiltonian of its own; a coverage this shortcut
            # loses is found as a gap below and filled like any other
            ws.append(float(cand[i]))
            bounds.append(float(cheap_c[i]))
            continue
        span = interval(fs, st, st.start(d_c[i]), level, cand[i])
        if span[0] <= span[1]:
            intervals.append(span)
            ws.append(float(cand[i]))
            bounds.append(float(cheap_c[i]))
    if bar is not None:
        bar.update(int(ok.sum()))
    while True:
        gaps = _gaps(intervals, w_ref)
        if not gaps:
            break
        todo = np.array([_pick(a, b, cand, cheap_c, w_ref) for a, b in gaps])
        Ks = fs.core(todo)
        cheap, d = cheap_bounds(Ks, fs.L, fs.R, st)
        stop = level / (1 + rtol)
        jobs = [(fs, st, float(w), Ks[i], d[i], _nearest(dg_w, dg_x, w, cheap[i] > stop), level,
                 stop) for i, w in enumerate(todo)]
        failed = []
        for (w, c), (b, x, span) in zip(zip(todo, cheap), run(_point, *zip(*jobs))):
            ws.append(float(w))
            bounds.append(b)
            if c > stop:
                n_dg += 1
                dg_w.append(float(w))
                dg_x.append(x)
            if span[0] <= span[1]:
                intervals.append(span)
            else:
                failed.append((float(w), b, x))
            if bar is not None:
                bar.update()
        if failed:                       # raise the level; certify these points at it
            level = max(b for _, b, _ in failed) * (1 + rtol)
            spans = [interval(fs, st, x, level, w) for w, _, x in failed]
            intervals += [sp for sp in spans if sp[0] <= sp[1]]
        if bar is not None:
            bar.set_postfix_str(f"mu <= {level:.4g}, {n_dg} D-G")
        if len(ws) >= max_points:
            certified = False
            break
    o = np.argsort(ws)
    w_arr, b_arr = np.array(ws)[o], np.array(bounds)[o]
    return CoverResult(float(level), certified, w_arr, b_arr, float(w_arr[np.argmax(b_arr)]),
                       n_dg, np.array(sorted(intervals)).reshape(-1, 2))
