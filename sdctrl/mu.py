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
of an uncertain modal model read and drive a few signals, see :mod:`sdctrl.robust`) is handled
without forming ``M``: the eigenvalue of (1) is that of a matrix of the size of ``K``, so a bound
on hundreds of channels costs little more than one on a few.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

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

KINDS = ("real", "complex", "full")


@dataclass(frozen=True, eq=False)
class Factored:
    """``M = L @ K @ R`` (``L``: (N, p), ``K``: (p, m), ``R``: (m, N)); ``L = R = None`` means ``M = K``.

    Parameters
    ----------
    K : ndarray
        Core matrix (the whole ``M`` when ``L`` and ``R`` are None).
    L, R : ndarray or None
        Output and input factors.
    """

    K: np.ndarray
    L: np.ndarray | None = None
    R: np.ndarray | None = None

    @property
    def N(self) -> int:
        """Number of channels."""
        return self.K.shape[0] if self.L is None else self.L.shape[0]

    @property
    def low_rank(self) -> bool:
        """Whether the factored path (small core) is used."""
        return self.L is not None and self.K.shape[0] + self.K.shape[1] < self.N

    def dense(self) -> np.ndarray:
        """``M`` as an (N, N) array."""
        return self.K if self.L is None else self.L @ self.K @ self.R


@dataclass(frozen=True, eq=False)
class BlockStructure:
    """Block-diagonal uncertainty structure, blocks in channel order.

    Parameters
    ----------
    sizes : tuple of int
        Size ``r`` of each block.
    kinds : tuple of str
        ``"real"``, ``"complex"`` (repeated scalars ``delta I_r``) or ``"full"`` (``r x r``).
    """

    sizes: tuple
    kinds: tuple
    groups: list = field(init=False, repr=False)
    nv: int = field(init=False, repr=False)
    scalar: tuple | None = field(init=False, repr=False)

    def __post_init__(self):
        sizes = tuple(int(r) for r in self.sizes)
        kinds = tuple(str(k) for k in self.kinds)
        if len(sizes) != len(kinds) or any(r < 1 for r in sizes) or any(
                k not in KINDS for k in kinds):
            raise ValueError(f"blocks must be positive sizes with kinds in {KINDS}")
        object.__setattr__(self, "sizes", sizes)
        object.__setattr__(self, "kinds", kinds)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(int)
        groups, off = [], 0
        for key in sorted(set(zip(sizes, kinds))):
            r, kind = key
            ids = np.array([i for i, s in enumerate(zip(sizes, kinds)) if s == key])
            idx = starts[ids][:, None] + np.arange(r)[None, :]          # (K, r) channels
            nf = 1 if kind == "full" else r * r
            ng = r * r if kind == "real" else 0
            il = np.tril_indices(r, -1)
            groups.append({"r": r, "kind": kind, "blocks": ids, "idx": idx, "nf": nf, "ng": ng,
                           "off": off, "il": il, "m": len(il[0]), "ar": np.arange(r)})
            off += len(ids) * (nf + ng)
        object.__setattr__(self, "groups", groups)
        object.__setattr__(self, "nv", off)
        scalar = None
        if all(r == 1 for r in sizes):           # parameter index of each channel's scalings
            s_idx, g_idx, g_chan = np.zeros(len(sizes), int), [], []
            for g in groups:
                step = g["nf"] + g["ng"]
                s_idx[g["idx"][:, 0]] = g["off"] + step * np.arange(len(g["blocks"]))
                if g["ng"]:
                    g_chan += list(g["idx"][:, 0])
                    g_idx += list(g["off"] + 1 + step * np.arange(len(g["blocks"])))
            scalar = (s_idx, np.array(g_idx, int), np.array(g_chan, int))
        object.__setattr__(self, "scalar", scalar)

    @classmethod
    def real_repeated(cls, reps, eps: float = 0.0) -> BlockStructure:
        """Repeated real scalars, followed by their complex copies when ``eps > 0``.

        Parameters
        ----------
        reps : sequence of int
            Repetition of each real scalar.
        eps : float
            Regularisation ``delta + eps delta_c``: complex copies are appended when positive
            (the matrix then is ``[[M, M], [eps M, eps M]]``).

        Returns
        -------
        BlockStructure
        """
        reps = tuple(int(r) for r in reps)
        kinds = ("real",) * len(reps) + (("complex",) * len(reps) if eps > 0 else ())
        return cls(reps + (reps if eps > 0 else ()), kinds)

    @property
    def N(self) -> int:
        """Number of channels."""
        return int(sum(self.sizes))

    @property
    def block_of_channel(self) -> np.ndarray:
        """Block index of every channel."""
        return np.repeat(np.arange(len(self.sizes)), self.sizes)

    # ---------------------------------------------------------------- scalings
    def start(self, d=None) -> np.ndarray:
        """Parameter vector of the scalings ``D = diag(d_i I)``, ``G = 0``.

        Parameters
        ----------
        d : array_like, optional
            Positive scaling of each block (default 1).

        Returns
        -------
        ndarray (nv,)
        """
        x = np.zeros(self.nv)
        if d is None:
            return x
        s = 0.5 * np.log(np.asarray(d, float))
        for g in self.groups:
            K, r = len(g["blocks"]), g["r"]
            p = np.zeros((K, g["nf"] + g["ng"]))
            p[:, :1 if g["kind"] == "full" else r] = s[g["blocks"]][:, None]
            x[g["off"]:g["off"] + p.size] = p.ravel()
        return x

    def unpack(self, x):
        """Scalings of each group of equal blocks from the parameter vector.

        ``D = F F^H`` with ``F`` lower triangular (log of its diagonal and its strictly lower
        part are parameters), ``G = F Gh F^H`` with ``Gh`` Hermitian (real blocks only).

        Parameters
        ----------
        x : ndarray (nv,)
            Parameter vector.

        Returns
        -------
        list of tuple
            ``(F, F^-1, Gh)`` per group, arrays (K, r, r) or (K,) for scalar blocks; ``Gh``
            is None on complex and full blocks.
        """
        out = []
        for g in self.groups:
            K, r, nf, ng = len(g["blocks"]), g["r"], g["nf"], g["ng"]
            p = x[g["off"]:g["off"] + K * (nf + ng)].reshape(K, nf + ng)
            if r == 1:
                F = np.exp(p[:, 0])
                out.append((F, 1.0 / F, p[:, 1] if ng else None))
                continue
            if g["kind"] == "full":
                e = np.exp(p[:, 0])
                eye = np.eye(r)
                out.append((e[:, None, None] * eye, (1 / e)[:, None, None] * eye, None))
                continue
            il, m, ar = g["il"], g["m"], g["ar"]
            F = np.zeros((K, r, r), complex)
            F[:, ar, ar] = np.exp(p[:, :r])
            F[:, il[0], il[1]] = p[:, r:r + m] + 1j * p[:, r + m:r + 2 * m]
            Fi = np.linalg.inv(F)
            Gh = None
            if ng:
                q = p[:, nf:]
                Gh = np.zeros((K, r, r), complex)
                Gh[:, ar, ar] = q[:, :r]
                Gh[:, il[0], il[1]] = q[:, r:r + m] + 1j * q[:, r + m:r + 2 * m]
                Gh[:, il[1], il[0]] = np.conj(Gh[:, il[0], il[1]])
            out.append((F, Fi, Gh))
        return out

    def apply(self, mats, X, which: int, herm: bool = False) -> np.ndarray:
        """Block-diagonal product ``B @ X``.

        Parameters
        ----------
        mats : list
            Output of :meth:`unpack`.
        X : ndarray (N,) or (N, q)
            Operand.
        which : int
            0: ``F``, 1: ``F^-1``, 2: ``Gh`` (zero on blocks without ``G``).
        herm : bool
            Use ``B^H``.

        Returns
        -------
        ndarray
        """
        Y = np.zeros(X.shape, complex)
        for g, m in zip(self.groups, mats):
            B = m[which]
            if B is None:
                continue
            if g["r"] == 1:
                i0 = g["idx"][:, 0]
                Y[i0] = (B if X.ndim == 1 else B[:, None]) * X[i0]
                continue
            if herm:
                B = np.conj(np.swapaxes(B, 1, 2))
            if X.ndim == 1:
                Y[g["idx"]] = (B @ X[g["idx"]][..., None])[..., 0]
            else:
                Y[g["idx"]] = B @ X[g["idx"]]
        return Y

    def gradient(self, mats, xv, u, yv, v) -> np.ndarray:
        """Gradient of the largest eigenvalue of (1) with respect to the parameters.

        In scaled coordinates, ``d lambda = Re tr(A dF) + Re tr(C dGh)`` blockwise with
        ``A = 2 (u yv^H - xv v^H)^H F^-1`` and ``C = j (u xv^H - xv u^H)``.

        Parameters
        ----------
        mats : list
            Output of :meth:`unpack`.
        xv : ndarray (N,)
            Unit eigenvector of the scaled matrix.
        u, yv, v : ndarray (N,)
            ``Mh xv``, ``u - j Gh xv`` and ``Mh^H yv``.

        Returns
        -------
        ndarray (nv,)
        """
        grad = np.zeros(self.nv)
        for g, (F, Fi, _Gh) in zip(self.groups, mats):
            K, r, nf, ng = len(g["blocks"]), g["r"], g["nf"], g["ng"]
            if r == 1:
                i0 = g["idx"][:, 0]
                xi, ui, yi, vi = xv[i0], u[i0], yv[i0], v[i0]
                A = 2 * np.conj(ui * np.conj(yi) - xi * np.conj(vi)) * Fi
                gk = np.zeros((K, nf + ng))
                gk[:, 0] = np.real(A) * F
                if ng:
                    gk[:, 1] = -2 * np.imag(ui * np.conj(xi))
                grad[g["off"]:g["off"] + gk.size] = gk.ravel()
                continue
            xi, ui, yi, vi = (a[g["idx"]] for a in (xv, u, yv, v))          # (K, r)
            P = ui[:, :, None] * yi.conj()[:, None, :] - xi[:, :, None] * vi.conj()[:, None, :]
            A = 2 * np.conj(np.swapaxes(P, 1, 2)) @ Fi
            gk = np.zeros((K, nf + ng))
            if g["kind"] == "full":
                gk[:, 0] = np.real(np.einsum("kii->k", A @ F))
            else:
                il, m, ar = g["il"], g["m"], g["ar"]
                gk[:, :r] = np.real(A[:, ar, ar]) * np.real(F[:, ar, ar])
                At = A[:, il[1], il[0]]
                gk[:, r:r + m] = np.real(At)
                gk[:, r + m:r + 2 * m] = -np.imag(At)
                if ng:
                    C = 1j * (ui[:, :, None] * xi.conj()[:, None, :]
                              - xi[:, :, None] * ui.conj()[:, None, :])
                    gk[:, nf:nf + r] = np.real(C[:, ar, ar])
                    Cl = C[:, il[0], il[1]]
                    gk[:, nf + r:nf + r + m] = 2 * np.real(Cl)
                    gk[:, nf + r + m:] = 2 * np.imag(Cl)
            grad[g["off"]:g["off"] + gk.size] = gk.ravel()
        return grad

    def dense_scalings(self, x):
        """The scalings as dense matrices.

        Parameters
        ----------
        x : ndarray (nv,)
            Parameter vector.

        Returns
        -------
        D, G : ndarray (N, N)
        """
        N = self.N
        D = np.zeros((N, N), complex)
        G = np.zeros((N, N), complex)
        for g, (F, _Fi, Gh) in zip(self.groups, self.unpack(x)):
            if g["r"] == 1:
                i0 = g["idx"][:, 0]
                D[i0, i0] = F ** 2
                if Gh is not None:
                    G[i0, i0] = F * Gh * F
                continue
            Fh = np.conj(np.swapaxes(F, 1, 2))
            for k, idx in enumerate(g["idx"]):
                D[np.ix_(idx, idx)] = F[k] @ Fh[k]
                if Gh is not None:
                    G[np.ix_(idx, idx)] = F[k] @ Gh[k] @ Fh[k]
        return D, G


# -------------------------------------------------------------------- evaluation of (1)
def evaluate(fm: Factored, st: BlockStructure, x, grad: bool = True):
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
        GL = st.apply(mats, Lh, 2)
        m, p = fm.K.shape[1], fm.K.shape[0]
        LK = Lh @ fm.K
        Q = np.zeros((m + p, m + p), complex)
        Q[:m, :m] = LK.conj().T @ LK
        Q[:m, m:] = -1j * fm.K.conj().T
        Q[m:, :m] = 1j * fm.K
        V, T = np.linalg.qr(np.hstack([RhH, GL]))
        S = T @ Q @ T.conj().T
        w, Y = np.linalg.eigh(0.5 * (S + S.conj().T))
        lam = float(w[-1])
        if not grad:
            return lam, None
        xv = V @ Y[:, -1]
        u = LK @ (RhH.conj().T @ xv)
        yv = u - 1j * st.apply(mats, xv, 2)
        v = RhH @ (LK.conj().T @ yv)
    else:
        M = fm.dense()
        Mh = st.apply(mats, st.apply(mats, M.conj().T, 1).conj().T, 0, herm=True)
        T = st.apply(mats, Mh, 2)
        S = Mh.conj().T @ Mh + 1j * (T - T.conj().T)
        w, Y = np.linalg.eigh(0.5 * (S + S.conj().T))
        lam = float(w[-1])
        if not grad:
            return lam, None
        xv = Y[:, -1]
        u = Mh @ xv
        yv = u - 1j * st.apply(mats, xv, 2)
        v = Mh.conj().T @ yv
    return lam, st.gradient(mats, xv, u, yv, v)


def _evaluate_scalar(M, st: BlockStructure, x, grad: bool):
    """:func:`evaluate` for scalar blocks only (diagonal scalings), vectorised."""
    s_idx, g_idx, g_chan = st.scalar
    f = np.exp(x[s_idx])
    gh = np.zeros(len(f))
    gh[g_chan] = x[g_idx]
    Mh = M * (f[:, None] / f[None, :])
    T = gh[:, None] * Mh
    S = Mh.conj().T @ Mh + 1j * (T - T.conj().T)
    w, Y = np.linalg.eigh(0.5 * (S + S.conj().T))
    lam = float(w[-1])
    if not grad:
        return lam, None
    xv = Y[:, -1]
    u = Mh @ xv
    yv = u - 1j * gh * xv
    v = Mh.conj().T @ yv
    g = np.zeros(st.nv)
    g[s_idx] = 2 * np.real(np.conj(u) * yv - np.conj(xv) * v)
    g[g_idx] = -2 * np.imag(u * np.conj(xv))[g_chan]
    return lam, g


def _bfgs(f, x, fx, g, stop: float, rtol: float, maxiter: int, window: int = 30,
          max_step: float = 8.0):
    """BFGS with a weak Wolfe line search (Lewis-Overton, for non-smooth quasi-convex ``f``).

    Stops when ``f <= stop``, when ``f`` decreased by less than ``rtol`` relative over the last
    ``window`` iterations, or after ``maxiter`` iterations.  The inverse Hessian is updated in place
    (BLAS ``dsyr2``/``dsyr`` on its upper triangle).
    """
    from scipy.linalg import blas
    n = x.size
    hist = [fx]
    if fx <= stop:
        return x, fx
    H = np.asfortranarray(np.eye(n))
    for _ in range(maxiter):
        if fx <= stop:
            break
        d = -blas.dsymv(1.0, H, g)
        gd = g @ d
        if not gd < 0:
            H = np.asfortranarray(np.eye(n))
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
            Hy = blas.dsymv(1.0, H, y)
            H = blas.dsyr2(-1.0 / sy, Hy, s, a=H, overwrite_a=True)
            H = blas.dsyr((sy + y @ Hy) / sy ** 2, s, a=H, overwrite_a=True)
        if len(hist) > window and hist[-window - 1] - fx <= rtol * abs(hist[-window - 1]):
            break
    return x, fx


def dg_upper(fm: Factored, st: BlockStructure, x0=None, stop: float = 0.0, rtol: float = 1e-4,
             maxiter: int = 3000):
    """Mixed mu upper bound of ``M`` by optimised D-G scalings (1).

    Parameters
    ----------
    fm : Factored
        The matrix (possibly as ``L K R``).
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

    Returns
    -------
    bound : float
        Certified upper bound (square root of the largest eigenvalue of (1)).
    x : ndarray
        Scalings (parameter vector) that certify it; :meth:`BlockStructure.dense_scalings`.
    """
    if x0 is None:
        x0 = st.start(osborne(block_norms(fm, st)[None])[0])
    lam0, g0 = evaluate(fm, st, x0)
    scale = max(lam0, 1e-300)

    def f(x):
        try:
            lam, g = evaluate(fm, st, x)
        except (FloatingPointError, np.linalg.LinAlgError):
            return np.inf, np.zeros_like(x)
        return lam / scale, g / scale

    with np.errstate(over="raise", invalid="raise"):     # runaway scalings: a failed step
        x, lam = _bfgs(f, np.array(x0, float), lam0 / scale, g0 / scale, stop ** 2 / scale,
                       rtol, maxiter)
    return float(np.sqrt(max(lam * scale, 0.0))), x


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


def certify_dg(M, D, G) -> float:
    """Exact mu upper bound certified by scalings ``(D, G)``: the smallest ``beta`` with
    ``M^H D M + j(G M - M^H G) - beta^2 D <= 0`` (generalised eigenvalue).

    Parameters
    ----------
    M : ndarray (r, r)
        Complex matrix.
    D : ndarray (r, r)
        Hermitian positive definite scaling (block structure of Delta).
    G : ndarray (r, r)
        Hermitian scaling, zero on complex blocks.

    Returns
    -------
    float
    """
    X = M.conj().T @ D @ M + 1j * (G @ M - M.conj().T @ G)
    X = 0.5 * (X + X.conj().T)
    lam = sla.eigh(X, 0.5 * (D + D.conj().T), eigvals_only=True)
    return float(np.sqrt(max(lam[-1], 0.0)))


def mu_upper(M, reps, eps: float = 0.01, rtol: float = 0.005, lower: float = 0.0):
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

    Returns
    -------
    bound : float
        Certified upper bound.
    scalings : tuple
        ``(Maug, D, G)`` certifying the bound on the augmented matrix.
    """
    M = np.asarray(M, complex)
    if eps > 0:
        Maug = np.block([[M, M], [eps * M, eps * M]])
    else:
        Maug = M
    st = BlockStructure.real_repeated(reps, eps)
    if Maug.shape != (st.N, st.N):
        raise ValueError(f"M must be ({st.N // (2 if eps > 0 else 1)}, ...) to match reps")
    if not np.any(Maug):
        return 0.0, (Maug, np.eye(st.N), np.zeros((st.N, st.N)))
    bound, x = dg_upper(Factored(Maug), st, stop=lower, rtol=min(rtol, 1e-3) * 0.1)
    D, G = st.dense_scalings(x)
    return bound, (Maug, D, G)
