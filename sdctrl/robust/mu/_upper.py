"""Upper bounds of the structured singular value (mixed real/complex mu) of one matrix.

The uncertainty is ``Delta = diag(Delta_1, ..., Delta_b)`` with blocks of three kinds:
``"real"`` (a repeated real scalar ``delta I_r``), ``"complex"`` (a repeated complex scalar) and
``"full"`` (a full complex ``r x r`` block).  The bound is that of Fan, Tits and Doyle (1991):
``mu(M) <= beta`` when scalings ``D > 0`` and ``G = G^H`` commuting with ``Delta`` (``G = 0`` on the
complex blocks) satisfy

    M^H D M + j (G M - M^H G) - beta^2 D <= 0,                                    (1)

so the certified value for given ``(D, G)`` is the square root of the largest generalised
eigenvalue of ``(M^H D M + j(G M - M^H G), D)``.  It is minimised over ``(D, G)`` by BFGS on that
eigenvalue (a quasi-convex, non-smooth function; Lewis and Overton's weak-Wolfe BFGS), from the
Osborne-balanced ``D`` (the cheap complex bound).  Every returned value is the exact eigenvalue of
the returned scalings: a certificate, never a solver's claim.

A matrix of the form ``M = L K R`` with few columns in ``L`` and rows in ``R`` (the Delta channels
of an uncertain modal model read and drive a few signals, see :mod:`sdctrl.robust._stability`) is
handled without forming ``M``: the eigenvalue of (1) is that of a matrix of the size of ``K``, so a
bound on hundreds of channels costs little more than one on a few.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from sdctrl.robust.mu._lmi import certify_dg, lmi_bound
from sdctrl.robust.mu._structure import BlockStructure, Factored

__all__ = [
    "BlockStructure",
    "Factored",
    "block_norms",
    "block_norms_squared",
    "certify_dg",
    "dg_upper",
    "evaluate",
    "mu_upper",
    "osborne",
]


# -------------------------------------------------------------------- evaluation of (1)
def evaluate(fm: Factored, st: BlockStructure, x, grad: bool = True, exact: bool = True):
    """Largest eigenvalue ``lam`` (``bound^2``) of (1) for the scalings ``x``, and its gradient.

    In scaled form ``Mh = F^H M F^-H``, ``Gh`` (``D = F F^H``, ``G = F Gh F^H``) the eigenvalue
    is that of ``Mh^H Mh + j (Gh Mh - Mh^H Gh) = U Q U^H`` with ``U = [Rh^H, Gh Lh]``,
    ``Lh = F^H L``, ``Rh = R F^-H`` and ``Q = [[K^H Lh^H Lh K, -j K^H], [j K, 0]]``; with the
    QR factorisation ``U = V T`` it is the largest eigenvalue of the small ``T Q T^H`` (exact).

    Parameters
    ----------
    fm : Factored
        Matrix.
    st : BlockStructure
        Structure.
    x : ndarray
        Scalings (parameter vector).
    grad : bool
        Also return the gradient with respect to ``x``.
    exact : bool
        False allows the Cholesky factor of ``U^H U`` in place of the QR factorisation (ten
        times faster on hundreds of channels, slightly less accurate: used inside the search,
        never for the returned bound).

    Returns
    -------
    lam : float
    grad : ndarray or None
    """
    if st.scalar is not None and not fm.low_rank:
        return _evaluate_scalar(fm.dense(), st, x, grad)
    mats = st.unpack(x)
    if fm.low_rank:
        Lh = st.apply(mats, fm.L, 0, herm=True)                  # F^H L
        RhH = st.apply(mats, fm.R.conj().T, 1)                   # (R F^-H)^H = F^-1 R^H
        U = np.hstack([RhH, st.apply(mats, Lh, 2)])
        m, p = fm.K.shape[1], fm.K.shape[0]
        LK = Lh @ fm.K
        Q = np.zeros((m + p, m + p), complex)
        Q[:m, :m] = LK.conj().T @ LK
        Q[:m, m:] = -1j * fm.K.conj().T
        Q[m:, :m] = 1j * fm.K
        C = None if exact else _gram_factor(U)
        if C is None:
            V, T = np.linalg.qr(U)
            S = T @ Q @ T.conj().T
        else:
            S = C.conj().T @ Q @ C
        lam, y = _top_eigenpair(S)
        if not grad:
            return lam, None
        if C is None:
            xv = V @ y
        else:                        # U C^-H z is the unit eigenvector of U Q U^H
            xv = U @ sla.solve_triangular(C, y, lower=True, trans="C")
        u = LK @ (RhH.conj().T @ xv)
        yv = u - 1j * st.apply(mats, xv, 2)
        v = RhH @ (LK.conj().T @ yv)
    else:
        M = fm.dense()
        Mh = st.apply(mats, st.apply(mats, M.conj().T, 1).conj().T, 0, herm=True)
        T = st.apply(mats, Mh, 2)
        S = Mh.conj().T @ Mh + 1j * (T - T.conj().T)
        lam, xv = _top_eigenpair(S)
        if not grad:
            return lam, None
        u = Mh @ xv
        yv = u - 1j * st.apply(mats, xv, 2)
        v = Mh.conj().T @ yv
    return lam, st.gradient(mats, xv, u, yv, v)


def _top_eigenpair(S):
    """Largest eigenvalue and its unit eigenvector of the Hermitian part of ``S``."""
    w, Y = np.linalg.eigh(0.5 * (S + S.conj().T))
    return float(w[-1]), Y[:, -1]


def _gram_factor(U):
    """Lower Cholesky factor of ``U^H U`` when well conditioned (else None: use QR)."""
    try:
        C = np.linalg.cholesky(U.conj().T @ U)
    except np.linalg.LinAlgError:
        return None
    d = np.abs(np.diag(C))
    return C if d.min() > 1e-5 * d.max() else None


def _evaluate_scalar(M, st: BlockStructure, x, grad: bool):
    """:func:`evaluate` for scalar blocks only (diagonal scalings), vectorised."""
    s_idx, g_idx, g_chan = st.scalar
    f = np.exp(x[s_idx])
    gh = np.zeros(len(f))
    gh[g_chan] = x[g_idx]
    Mh = M * (f[:, None] / f[None, :])
    T = gh[:, None] * Mh
    S = Mh.conj().T @ Mh + 1j * (T - T.conj().T)
    lam, xv = _top_eigenpair(S)
    if not grad:
        return lam, None
    u = Mh @ xv
    yv = u - 1j * gh * xv
    v = Mh.conj().T @ yv
    g = np.zeros(st.nv)
    g[s_idx] = 2 * np.real(np.conj(u) * yv - np.conj(xv) * v)
    g[g_idx] = -2 * np.imag(u * np.conj(xv))[g_chan]
    return lam, g


def _bfgs(f, x, fx, g, stop: float, rtol: float, maxiter: int, window: int = 30,
          max_step: float = 8.0, dense_max: int = 1500, memory: int = 40):
    """BFGS with a weak Wolfe line search (Lewis-Overton, for non-smooth quasi-convex ``f``).

    Stops when ``f <= stop``, when ``f`` decreased by less than ``rtol`` relative over the last
    ``window`` iterations, or after ``maxiter`` iterations.  Up to ``dense_max`` variables the
    inverse Hessian is kept and updated in place (BLAS ``dsyr2``/``dsyr`` on its upper
    triangle); above, the last ``memory`` pairs are (L-BFGS, bounded memory).
    """
    from scipy.linalg import blas
    n = x.size
    hist = [fx]
    if fx <= stop:
        return x, fx
    dense = n <= dense_max
    H = np.asfortranarray(np.eye(n)) if dense else None
    pairs = []
    for _ in range(maxiter):
        if fx <= stop:
            break
        d = -blas.dsymv(1.0, H, g) if dense else -_two_loop(g, pairs)
        gd = g @ d
        if not gd < 0:
            H = np.asfortranarray(np.eye(n)) if dense else None
            pairs = []
            d, gd = -g, -(g @ g)
            if not gd < 0:
                break
        tmax = max_step / max(np.max(np.abs(d)), 1e-300)    # scalings change by <= e^max_step
        lo, hi, t = 0.0, np.inf, min(1.0, tmax)
        for _ in range(40):
            xt = x + t * d
            ft, gt = f(xt)
            if not ft <= fx + 1e-4 * t * gd:
                hi = t
            elif gt @ d < 0.9 * gd and t < tmax:
                lo = t
            else:
                break
            t = 0.5 * (lo + hi) if np.isfinite(hi) else min(2.0 * lo, tmax)
        else:
            if not ft < fx:
                break
        s, y = xt - x, gt - g
        x, fx, g = xt, ft, gt
        hist.append(fx)
        sy = s @ y
        if sy > 1e-12 * np.linalg.norm(s) * np.linalg.norm(y):
            if dense:
                Hy = blas.dsymv(1.0, H, y)
                H = blas.dsyr2(-1.0 / sy, Hy, s, a=H, overwrite_a=True)
                H = blas.dsyr((sy + y @ Hy) / sy ** 2, s, a=H, overwrite_a=True)
            else:
                pairs = [*pairs[-memory + 1:], (s, y, 1.0 / sy)]
        if len(hist) > window and hist[-window - 1] - fx <= rtol * abs(hist[-window - 1]):
            break
    return x, fx


def _two_loop(g, pairs):
    """L-BFGS product ``H g`` from the stored ``(s, y, 1 / s.y)`` pairs."""
    q = g.copy()
    alpha = []
    for s, y, rho in reversed(pairs):
        a = rho * (s @ q)
        alpha.append(a)
        q -= a * y
    if pairs:
        s, y, _ = pairs[-1]
        q *= (s @ y) / (y @ y)
    for (s, y, rho), a in zip(pairs, reversed(alpha)):
        q += (a - rho * (y @ q)) * s
    return q


def dg_upper(fm: Factored, st: BlockStructure, x0=None, stop: float = 0.0, rtol: float = 1e-4,
             maxiter: int = 3000, polish: bool = False):
    """Mixed mu upper bound of ``M`` by optimised D-G scalings (1).

    Parameters
    ----------
    fm : Factored or array_like, shape (N, N)
        The matrix, complex (possibly factored as ``L K R``).
    st : BlockStructure
        Uncertainty structure (``st.N`` channels).
    x0 : ndarray, optional
        Starting scalings (parameter vector, e.g. from a neighbouring frequency); default the
        Osborne-balanced ``D`` with ``G = 0``.
    stop : float
        Stop as soon as the certified bound is at or below this value.
    rtol : float
        Relative decrease of ``bound^2`` over 30 iterations below which the search stops.
    maxiter : int
        Maximum BFGS iterations.
    polish : bool
        Then solve the LMI (1) by an interior-point method below the BFGS bound
        (:func:`sdctrl.robust.mu._lmi.lmi_bound`, bisection to ``1e-5``) and keep its scalings when
        they certify less: the optimal D-G bound up to the bisection step.  Small problems
        only (measured on a loaded 2-core machine: 0.1-0.9 s at 4-8 channels, 2 s at 14,
        20 s at 24).

    Returns
    -------
    bound : float
        Certified upper bound (square root of the largest eigenvalue of (1)).
    x : ndarray
        Scalings (parameter vector) that certify it; :meth:`BlockStructure.dense_scalings`.
    """
    if not isinstance(fm, Factored):
        fm = Factored(np.asarray(fm, complex))
    if x0 is None:
        x0 = st.start(osborne(block_norms(fm, st)[None])[0])
    x0 = np.array(x0, float)
    lam0, g0 = evaluate(fm, st, x0)
    if lam0 <= stop ** 2:
        return float(np.sqrt(max(lam0, 0.0))), x0
    scale = max(lam0, 1e-300)

    def f(x):
        try:
            lam, g = evaluate(fm, st, x, exact=False)
        except (FloatingPointError, np.linalg.LinAlgError):
            return np.inf, np.zeros_like(x)
        return lam / scale, g / scale

    with np.errstate(over="raise", invalid="raise"):     # runaway scalings: a failed step
        x, _ = _bfgs(f, x0, lam0 / scale, g0 / scale, stop ** 2 / scale, rtol, maxiter)
    lam = evaluate(fm, st, x, grad=False)[0]              # the certificate, exactly
    if lam > lam0:
        x, lam = x0, lam0
    bound = float(np.sqrt(max(lam, 0.0)))
    if polish and bound > stop:
        return _polish(fm, st, bound, x, stop)
    return bound, x


def _polish(fm: Factored, st: BlockStructure, bound: float, x, stop: float):
    """The LMI optimum below ``bound`` (:func:`lmi_bound`), kept when it certifies less.

    The LMI's bounded range of scalings is centred on the BFGS ones (``D0``).
    """
    D0, _ = st.dense_scalings(x)
    try:
        res = lmi_bound(fm.dense(), st, hi=bound, lo=stop, D0=D0)
        if res.D is None or not res.bound < bound:
            return bound, x
        xl = st.params(res.D, res.G)
    except np.linalg.LinAlgError:            # a scaling not numerically positive definite
        return bound, x
    lam = evaluate(fm, st, xl, grad=False)[0]             # certified through x, as returned
    b = float(np.sqrt(max(lam, 0.0)))
    return (b, xl) if b < bound else (bound, x)


def block_norms(fm: Factored, st: BlockStructure) -> np.ndarray:
    """Frobenius norms of the blocks ``M_kl`` (through the factors when there are).

    Parameters
    ----------
    fm : Factored
        Matrix.
    st : BlockStructure
        Structure.

    Returns
    -------
    ndarray (nb, nb)
    """
    return np.sqrt(block_norms_squared(fm.K[None], fm.L, fm.R, st)[0])


def block_norms_squared(Ks, L, R, st: BlockStructure) -> np.ndarray:
    """Squared block norms (nf, nb, nb) of ``M = L K R`` for a stack of cores ``Ks`` (nf, p, m).

    Exact when every channel reads one signal and drives one (one non-zero per row of ``L`` and
    per column of ``R``, as in :meth:`UncertainModel.compact_lft`), an estimate otherwise (it
    only starts the balancing; bounds are always certified by the scalings themselves).

    Parameters
    ----------
    Ks : ndarray (nf, p, m)
        Cores.
    L, R : ndarray or None
        Channel factors; ``None`` means ``M = K``.
    st : BlockStructure
        Structure.

    Returns
    -------
    ndarray (nf, nb, nb)
    """
    starts = np.concatenate([[0], np.cumsum(st.sizes)[:-1]]).astype(int)
    if L is None:
        M2 = np.abs(Ks) ** 2
        return np.add.reduceat(np.add.reduceat(M2, starts, axis=1), starts, axis=2)
    Lb = np.add.reduceat(np.abs(L) ** 2, starts, axis=0)          # (nb, p)
    Rb = np.add.reduceat(np.abs(R) ** 2, starts, axis=1)          # (m, nb)
    return Lb @ (np.abs(Ks) ** 2) @ Rb


def osborne(B, sweeps: int = 40) -> np.ndarray:
    """Osborne balancing of non-negative block norms ``B`` (nf, nb, nb).

    Returns ``d`` (nf, nb) such that the scaled blocks ``B_kl sqrt(d_k / d_l)`` have equal
    off-diagonal row and column sums of squares (``D = diag(d_k I)``, the scaled matrix is
    ``D^(1/2) M D^(-1/2)``), which nearly minimises the Frobenius norm, hence the cheap
    complex-mu bound ``||D^(1/2) M D^(-1/2)||``.

    Parameters
    ----------
    B : array_like (nf, nb, nb)
        Block norms.
    sweeps : int
        Maximum number of (simultaneous, damped) balancing sweeps.

    Returns
    -------
    ndarray (nf, nb)
    """
    B2 = np.asarray(B, float) ** 2
    nf, nb, _ = B2.shape
    B2 = B2 * (1 - np.eye(nb))[None]
    tiny = 1e-300
    logd = np.zeros((nf, nb))
    for _ in range(sweeps):
        e = np.exp(logd - logd.max(axis=1, keepdims=True))
        row = np.einsum("fkl,fl->fk", B2, 1 / e) * e
        col = np.einsum("flk,fl->fk", B2, e) / e
        step = 0.25 * (np.log(col + tiny) - np.log(row + tiny))
        step[(row <= tiny) | (col <= tiny)] = 0.0
        logd += np.clip(step, -5, 5)
        if np.max(np.abs(step), initial=0.0) < 1e-3:
            break
    logd -= logd.mean(axis=1, keepdims=True)
    return np.exp(logd)


def mu_upper(M, reps, eps: float = 0.01, rtol: float = 0.005, lower: float = 0.0,
             polish: bool = False):
    """Mixed real mu upper bound of ``M`` for repeated real scalar blocks (D-G scalings).

    Each real ``delta`` is regularised as ``delta + eps*delta_c`` (a small complex part), so the
    bound is continuous in frequency (conservatism about ``1 + eps``).  The D-G scalings of (1)
    are optimised by BFGS on the certified eigenvalue (:func:`dg_upper`).

    Parameters
    ----------
    M : ndarray (r, r)
        Complex matrix (closed-loop Delta-channel response at one frequency).
    reps : sequence of int
        Repetition of each real scalar block (channel order).
    eps : float
        Relative complex regularisation.
    rtol : float
        Relative tolerance on the bound (the search stops when it improves by less).
    lower : float
        Value of interest: the search stops as soon as the bound is certified at or below it.
    polish : bool
        Polish the bound by the LMI (small problems only; see :func:`dg_upper`).

    Returns
    -------
    bound : float
        Certified upper bound.
    scalings : tuple
        ``(Maug, D, G)`` certifying the bound on the augmented matrix.
    """
    M = np.asarray(M, complex)
    n = int(sum(reps))
    if M.shape != (n, n):
        raise ValueError(f"M must be {n} x {n} (the channels of reps), got shape {M.shape}")
    Maug = np.block([[M, M], [eps * M, eps * M]]) if eps > 0 else M
    st = BlockStructure.real_repeated(reps, eps)
    if not np.any(Maug):
        return 0.0, (Maug, np.eye(st.N), np.zeros((st.N, st.N)))
    bound, x = dg_upper(Factored(Maug), st, stop=lower, rtol=min(rtol, 1e-3) * 0.1,
                        polish=polish)
    D, G = st.dense_scalings(x)
    return bound, (Maug, D, G)
