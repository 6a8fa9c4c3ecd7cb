"""Low-rank modifications of a normal-mode model, evaluated on frequency lines by Woodbury.

A candidate effect between FE DOFs is a load shape ``b`` (N, k) and a dynamic stiffness
``D(s)``: a spring ``dk``, a dashpot ``s c``, a point mass ``s^2 dm`` (k = 3 translations), a
resonator ``s^2 m (k_r + s c_r) / (s^2 m + k_r + s c_r)`` along one axis.  Acting on the
structure as the feedback load ``-b D(s) b^T q`` (4.22), it changes the reduced model (4.17),
(5.2) by the rank-``k`` term ``phi^T b D b^T phi``, so that (Woodbury)

``H(s) = H_0(s) - G_yk D (I + G_kk D)^-1 G_ku``,

with ``G_yk = c Z^-1 b``, ``G_kk = b^T Z^-1 b``, ``G_ku = b^T Z^-1 b_u`` the transfers of the
model ``Z(s) = s^2 I + s Gamma + Omega`` between the sensors, the candidate's load and the
actuators.  They come from one complex-mode factorisation of the model,
``Z^-1 = V_t diag(1 / (s - lambda)) W_b`` (first-order form, (2.15) with full ``Gamma``):
a candidate costs a few products over the lines, never a new eigenproblem, whatever its size.

The modes of a truncated model miss the local flexibility of a load between two nodes.  The
static correction of the load with respect to the model's shapes, ``psi = (K^-1 - T (T^T K
T)^+ T^T) b`` (4.23), is added to the three transfers as a quasi-static (frequency
independent) term: ``G_kk += b^T psi``, ``G_yk += c psi``, ``G_ku += psi^T b_u``.  Corrected
models carry the same correction as appended quasi-static modes (2.20)-(2.22) (see
:mod:`sdctrl.diagnosis._apply`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from sdctrl._lib.threads import single_thread

__all__ = ["Resolvent", "StaticTerms", "dynamic_stiffness", "own_flexibility", "screen_chunk",
           "static_terms", "woodbury"]

#: a complex-mode factorisation whose response differs from a direct solve by more than this
#: (relative) is replaced by direct solves
FACTOR_RTOL = 1e-7
#: relative splitting of exactly critically damped (defective) pairs
DEFECT_SPLIT = 1e-7
#: floor of |H / Hd|^2 in the screen (single precision)
_TINY = np.float32(1e-30)
#: entries of a block of candidates in the screen (about 1 MB of complex64: in cache)
BLOCK = 2 ** 17


@dataclass(frozen=True, eq=False)
class Resolvent:
    """``Z(s)^-1 = (s^2 I + s Gamma + Omega)^-1`` of a normal-mode model, factored.

    Parameters
    ----------
    Omega, Gamma : ndarray, shape (n, n)
        Modal stiffness (rad/s)^2 and damping (rad/s).
    lam : ndarray, shape (2n,), or None
        Complex modes of the first-order form; None when the factorisation is
        ill-conditioned (direct solves are used instead).
    Vt : ndarray, shape (n, 2n), or None
        Displacement part of the right eigenvectors.
    Wb : ndarray, shape (2n, n), or None
        Force part of the left eigenvectors (rows of ``V^-1``).
    """

    Omega: np.ndarray
    Gamma: np.ndarray
    lam: np.ndarray | None
    Vt: np.ndarray | None
    Wb: np.ndarray | None

    @classmethod
    def of(cls, Omega, Gamma) -> Resolvent:
        """Factor a model; fall back on direct solves when the modes are ill-conditioned.

        Parameters
        ----------
        Omega, Gamma : ndarray, shape (n, n)
            Modal stiffness and damping.

        Returns
        -------
        Resolvent
        """
        Omega = np.asarray(Omega, float)
        Gamma = np.asarray(Gamma, float)
        n = Omega.shape[0]
        G = Gamma.copy()
        # exactly critically damped uncoupled modes (critically damped static correction
        # modes, 2.20) are defective: split them by a negligible damping change
        d = np.diag(G)
        w = np.sqrt(np.clip(np.diag(Omega), 0, None))
        crit = np.abs(d - 2 * w) <= 1e-9 * np.maximum(2 * w, 1e-300)
        G[crit, crit] *= 1.0 + DEFECT_SPLIT
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Omega
        A[n:, n:] = -G
        lam, V = sla.eig(A)
        try:
            W = np.linalg.inv(V)
        except np.linalg.LinAlgError:
            return cls(Omega, Gamma, None, None, None)
        out = cls(Omega, Gamma, lam, V[:n], W[:, n:])
        # check against a direct solve at a typical frequency
        wref = float(np.sqrt(max(np.abs(np.diag(Omega)).max(), 1e-12)))
        s = np.array([0.37j * wref])
        P = np.eye(n)
        ref = cls(Omega, Gamma, None, None, None).transfer(s, P, P)
        got = out.transfer(s, P, P)
        if np.abs(got - ref).max() > FACTOR_RTOL * np.abs(ref).max():
            return cls(Omega, Gamma, None, None, None)
        return out

    @property
    def n(self) -> int:
        """Number of modes."""
        return self.Omega.shape[0]

    def transfer(self, s, left, right) -> np.ndarray:
        """``left^T Z(s)^-1 right`` on lines ``s``.

        Parameters
        ----------
        s : ndarray, shape (nf,)
            Laplace points ``j w`` (rad/s).
        left : ndarray, shape (n, p)
        right : ndarray, shape (n, q)

        Returns
        -------
        ndarray, shape (nf, p, q), complex
        """
        if self.lam is not None:
            Rs = 1.0 / (s[:, None] - self.lam[None, :])                  # (nf, 2n)
            Lv = left.T @ self.Vt                                          # (p, 2n)
            Rv = self.Wb @ right                                           # (2n, q)
            if Lv.shape[0] > Rv.shape[1]:          # wide left: never form (nf, p, 2n)
                return Lv @ (Rs[:, :, None] * Rv[None])
            X = (Rs[:, None, :] * Lv[None]).reshape(-1, Rs.shape[1]) @ Rv
            return X.reshape(s.size, Lv.shape[0], Rv.shape[1])
        Z = (s[:, None, None] ** 2 * np.eye(self.n) + s[:, None, None] * self.Gamma
             + self.Omega)
        X = np.linalg.solve(Z, np.broadcast_to(right.astype(complex), (s.size,) + right.shape))
        return left.T @ X

    def diag_transfer(self, s, left, right) -> np.ndarray:
        """Column by column ``left[:, c]^T Z(s)^-1 right[:, c]``.

        Parameters
        ----------
        s : ndarray, shape (nf,)
            Laplace points.
        left, right : ndarray, shape (n, m)

        Returns
        -------
        ndarray, shape (nf, m), complex
        """
        if self.lam is not None:
            Rs = 1.0 / (s[:, None] - self.lam[None, :])
            coef = (left.T @ self.Vt) * (self.Wb @ right).T                # (m, 2n)
            return Rs @ coef.T
        Z = (s[:, None, None] ** 2 * np.eye(self.n) + s[:, None, None] * self.Gamma
             + self.Omega)
        X = np.linalg.solve(Z, np.broadcast_to(right.astype(complex), (s.size,) + right.shape))
        return np.einsum("nm,fnm->fm", left, X)


@dataclass(frozen=True, eq=False)
class StaticTerms:
    """Static corrections (4.23) with respect to a model's shapes ``T``.

    ``Psi = K^-1 - T (T^T K T)^+ T^T`` is symmetric: the static terms between the test's
    sensors/actuators and any candidate DOF are rows of the static corrections of the test's
    own unit loads, computed once (one solve per tested DOF, whatever the number of
    candidates).  A candidate's own local flexibility ``b^T Psi b`` needs its own solve: the
    screen uses its projection on the basis of the test's static corrections
    (:meth:`projected`), the finalists the exact value (:meth:`correction`).

    Parameters
    ----------
    fe : FEModel
        The FE model (its cached factorisation).
    T : ndarray, shape (N, n)
        The model's shapes on the FE DOFs.
    Kt_pinv : ndarray, shape (n, n)
        ``(T^T K T)^+``.
    dof_idx : ndarray of int, shape (nd,)
        Candidate DOFs.
    Fyd : ndarray, shape (ns, nd)
        ``Psi`` between the model's sensors and the candidate DOFs.
    Fdu : ndarray, shape (nd, na)
        ``Psi`` between the candidate DOFs and the model's actuators.
    Pd : ndarray, shape (nd, nio)
        Static corrections of the tested DOFs' unit loads at the candidate DOFs.
    Kio_pinv : ndarray, shape (nio, nio)
        Pseudo-inverse of their stiffness ``Psi_io^T K Psi_io``.
    """

    fe: object
    T: np.ndarray
    Kt_pinv: np.ndarray
    dof_idx: np.ndarray
    Fyd: np.ndarray
    Fdu: np.ndarray
    Pd: np.ndarray
    Kio_pinv: np.ndarray

    def correction(self, b) -> np.ndarray:
        """Exact static correction ``Psi b`` (N, k) of loads ``b`` (N, k): one solve.

        Parameters
        ----------
        b : ndarray, shape (N, k)

        Returns
        -------
        ndarray, shape (N, k)
        """
        return self.fe.static_response(b) - self.T @ (self.Kt_pinv @ (self.T.T @ b))

    def shapes_part(self, group) -> np.ndarray:
        """``(T^T b)^T (T^T K T)^+ (T^T b)`` of every candidate of ``group``: the part of
        ``b^T K^-1 b`` the model's shapes carry, from the shapes at the candidate DOFs only
        (never ``T^T b`` over all ``N`` DOFs, as :meth:`correction` forms).

        Parameters
        ----------
        group : Group
            Candidates (compact load shapes on the candidate DOFs).

        Returns
        -------
        ndarray, shape (nc, k, k)
        """
        P = group.project(self.T[self.dof_idx])                            # (nc, k, n)
        return np.einsum("cpn,nm,cqm->cpq", P, self.Kt_pinv, P)

    def kinv_quad(self, beta, k: int) -> np.ndarray:
        """``b_c^T K^-1 b_c`` (``K^-1``: the FE model's static response, inertia relief
        included) of loads given on the candidate DOFs, ``k`` columns each: one multi-load
        solve with the cached factorisation.

        Parameters
        ----------
        beta : ndarray, shape (nd, nc * k)
        k : int

        Returns
        -------
        ndarray, shape (nc, k, k)
        """
        nd = self.dof_idx.size
        b = np.zeros((self.fe.N, beta.shape[1]))
        b[self.dof_idx] = beta
        x = self.fe.static_response(b)[self.dof_idx]
        return np.einsum("dcp,dcq->cpq", beta.reshape(nd, -1, k), x.reshape(nd, -1, k))

    def projected(self, group) -> np.ndarray:
        """``b^T Psi_io (Psi_io^T K Psi_io)^+ Psi_io^T b`` of every candidate of ``group``.

        Parameters
        ----------
        group : Group
            Candidates (compact load shapes on the candidate DOFs).

        Returns
        -------
        ndarray, shape (nc, k, k)
        """
        P = group.project(self.Pd)                                         # (nc, k, nio)
        return np.einsum("cpi,ij,cqj->cpq", P, self.Kio_pinv, P)


def own_flexibility(static, group, keys, known: dict, batch: int) -> np.ndarray:
    """Exact ``b^T Psi b = b^T K^-1 b - (T^T b)^T (T^T K T)^+ (T^T b)`` (4.23) of the
    candidates of ``group`` (nc, k, k), symmetric.  Their ``b^T K^-1 b`` depends on the FE
    model only: it is solved (:meth:`StaticTerms.kinv_quad`, ``batch`` load columns per
    multi-load solve with the FE model's factorisation) for the candidates whose ``keys``
    (their indices in the diagnosis's group) are not in ``known`` (``{key: (k, k)}``, filled
    in place: a diagnosis keeps it for its later steps); the shapes' part needs no solve
    (:meth:`StaticTerms.shapes_part`)."""
    k, nd = group.rank, static.dof_idx.size
    keys = [int(c) for c in keys]
    todo = [i for i, c in enumerate(keys) if c not in known]
    per = max(1, batch // k)
    for a in range(0, len(todo), per):
        pos = todo[a:a + per]
        beta = np.stack([group.dense(i, nd) for i in pos], axis=1)          # (nd, nb, k)
        for i, q in zip(pos, static.kinv_quad(beta.reshape(nd, -1), k)):
            known[keys[i]] = q
    F = np.stack([known[c] for c in keys]) - static.shapes_part(group)
    return 0.5 * (F + F.transpose(0, 2, 1))


def _pinv_sym(A, rtol=1e-10):
    d, U = np.linalg.eigh(0.5 * (A + A.T))
    keep = np.abs(d) > rtol * max(np.abs(d).max(initial=0.0), 1e-300)
    return (U[:, keep] / d[keep]) @ U[:, keep].T


def static_terms(fe, shapes, dof_idx, sensor_rows, actuator_cols) -> StaticTerms:
    """Static corrections (4.23) of the test's unit loads with respect to ``span(shapes)``.

    ``psi = K^-1 e - T (T^T K T)^+ T^T e``: one solve with the model's cached factorisation
    (inertia relief for free structures) per tested DOF, whatever the number of candidates.

    Parameters
    ----------
    fe : FEModel
        The FE model.
    shapes : ndarray, shape (N, n)
        The model's shapes on the FE DOFs.
    dof_idx : ndarray of int, shape (nd,)
        Candidate DOFs.
    sensor_rows : ndarray of int, shape (ns,)
        FE DOF of each model sensor (-1: not an FE DOF, no static term).
    actuator_cols : ndarray of int, shape (na,)
        FE DOF of each model actuator (-1: none).

    Returns
    -------
    StaticTerms
    """
    T = shapes
    Ktp = _pinv_sym(T.T @ np.asarray(fe.K @ T))
    io = np.unique(np.r_[sensor_rows, actuator_cols])
    io = io[io >= 0]
    E = np.zeros((fe.N, io.size))
    E[io, np.arange(io.size)] = 1.0
    Psi = fe.static_response(E) - T @ (Ktp @ T[io].T) if io.size else E
    col = {int(r): j for j, r in enumerate(io)}
    Fyd = np.zeros((sensor_rows.size, dof_idx.size))
    for i, r in enumerate(sensor_rows):
        if r >= 0:
            Fyd[i] = Psi[dof_idx, col[int(r)]]
    Fdu = np.zeros((dof_idx.size, actuator_cols.size))
    for j, r in enumerate(actuator_cols):
        if r >= 0:
            Fdu[:, j] = Psi[dof_idx, col[int(r)]]
    Kio = Psi.T @ np.asarray(fe.K @ Psi) if io.size else np.zeros((0, 0))
    return StaticTerms(fe, T, Ktp, dof_idx, Fyd, Fdu, Psi[dof_idx], _pinv_sym(Kio))


def dynamic_stiffness(kind: str, s, sizes, extra=None) -> np.ndarray:
    """Dynamic stiffness ``D(s)`` of a candidate for each size.

    Parameters
    ----------
    kind : {"added_damper", "stiffness_change", "mass_change", "resonator"}
        The effect.
    s : ndarray, shape (nf,)
        Laplace points (rad/s).
    sizes : ndarray, shape (..., )
        ``c`` (N s/m), ``dk`` (N/m), ``dm`` (kg) or the resonator mass (kg).
    extra : (ndarray, ndarray), optional
        Resonator frequency (rad/s) and damping ratio, broadcast like ``sizes``.

    Returns
    -------
    ndarray, shape sizes.shape + (nf,), complex
    """
    x = np.asarray(sizes, float)[..., None]
    if kind == "added_damper":
        return x * s
    if kind == "stiffness_change":
        return x * np.ones_like(s)
    if kind == "mass_change":
        return x * s**2
    wr = np.asarray(extra[0], float)[..., None]
    zr = np.asarray(extra[1], float)[..., None]
    num = wr**2 + 2 * zr * wr * s
    return x * s**2 * num / (s**2 + num)


def woodbury(H0, Gyk, Gkk, Gku, D) -> np.ndarray:
    """``H0 - G_yk D (I + G_kk D)^-1 G_ku`` for a scalar dynamic stiffness per line.

    Parameters
    ----------
    H0 : ndarray, shape (nf, ns, na)
        Nominal response.
    Gyk : ndarray, shape (nf, ns, k)
    Gkk : ndarray, shape (nf, k, k)
    Gku : ndarray, shape (nf, k, na)
    D : ndarray, shape (nf,)
        ``D(s)`` on the lines (``D I_k``).

    Returns
    -------
    ndarray, shape (nf, ns, na)
    """
    k = Gkk.shape[1]
    if k == 1:
        g = D / (1.0 + D * Gkk[:, 0, 0])
        return H0 - g[:, None, None] * Gyk[:, :, :1] * Gku[:, :1, :]
    A = np.eye(k) + D[:, None, None] * Gkk
    X = np.linalg.solve(A, Gku)
    return H0 - D[:, None, None] * (Gyk @ X)


def _log_cost(Q, q, t, out_col):
    """``mean(log(|Q|^2)^2) / 4`` per candidate of a block, in place in ``q``, ``t``."""
    np.multiply(Q.real, Q.real, out=q)
    np.multiply(Q.imag, Q.imag, out=t)
    q += t
    np.maximum(q, _TINY, out=q)
    np.log(q, out=q)
    np.square(q, out=q)
    qq = q.reshape(q.shape[0], -1)
    out_col[:] = qq.sum(axis=1) / (4.0 * qq.shape[1])          # pairwise summation


def _screen_rank1(A, iHd, D, Gyk, Gkk, Gku, out):
    """Rank-1 candidates: ``Q = A - g P``, ``P = G_yk G_ku / H_d``, ``g = D / (1 + D G_kk)``."""
    nb = max(1, BLOCK // A.size)
    for a in range(0, out.shape[0], nb):
        sl = slice(a, a + nb)
        P = (Gyk[sl, :, :, :1] * Gku[sl, :, :1, :]) * iHd            # (b, nf, ns, na)
        Q = np.empty_like(P)
        q, t = np.empty(P.shape, np.float32), np.empty(P.shape, np.float32)
        for j in range(out.shape[1]):
            g = D[sl, j] / (1.0 + D[sl, j] * Gkk[sl, :, 0, 0])          # (b, nf)
            np.multiply(P, g[:, :, None, None], out=Q)
            np.subtract(A, Q, out=Q)
            _log_cost(Q, q, t, out[sl, j])


def _screen_rank_k(A, iHd, D, Gyk, Gkk, Gku, out):
    """Rank-k candidates: ``Q = A - D G_yk (I + D G_kk)^-1 G_ku / H_d``."""
    k = Gkk.shape[-1]
    eye = np.eye(k, dtype=np.complex64)
    nb = max(1, BLOCK // A.size)
    for a in range(0, out.shape[0], nb):
        sl = slice(a, a + nb)
        shape = (Gyk[sl].shape[0],) + A.shape
        Q = np.empty(shape, np.complex64)
        q, t = np.empty(shape, np.float32), np.empty(shape, np.float32)
        for j in range(out.shape[1]):
            d = D[sl, j][:, :, None, None]
            X = np.linalg.solve(eye + d * Gkk[sl], Gku[sl])             # (b, nf, k, na)
            np.matmul(Gyk[sl], d * X, out=Q)
            Q *= iHd
            np.subtract(A, Q, out=Q)
            _log_cost(Q, q, t, out[sl, j])


def screen_chunk(task) -> np.ndarray:
    """Log-magnitude logLS costs of a chunk of candidates over their size grids.

    The screen runs in single precision on a subset of lines: it ranks candidates, the
    finalists are fitted again on all the data (:mod:`sdctrl.diagnosis._candidate_scan`).
    The candidates are processed in blocks of about :data:`BLOCK` entries, in place, so
    that the arrays of a block stay in the processor's cache.

    Parameters
    ----------
    task : dict
        ``A`` (nf, ns, na) ``H0 / Hd``; ``iHd`` (nf, ns, na) ``1 / Hd``; ``s`` (nf,);
        ``kind``; ``sizes`` (nc, m); ``extra`` (resonator frequency and damping, (nc, m)
        each, or None); ``Gyk`` (nc, nf, ns, k); ``Gkk`` (nc, nf, k, k); ``Gku``
        (nc, nf, k, na).

    Returns
    -------
    ndarray, shape (nc, m)
        Mean squared log-magnitude residual of each candidate at each size.
    """
    # single precision: a size far off the candidate's scale may overflow or divide by
    # zero; such a point costs +inf (it never ranks), and no warning reaches the user
    with single_thread(), np.errstate(all="ignore"):
        A, iHd, s = task["A"], task["iHd"], task["s"]
        Gyk, Gkk, Gku = task["Gyk"], task["Gkk"], task["Gku"]
        sizes = task["sizes"]
        D = dynamic_stiffness(task["kind"], s, sizes, task["extra"]).astype(np.complex64)
        out = np.empty(sizes.shape)
        kernel = _screen_rank1 if Gkk.shape[-1] == 1 else _screen_rank_k
        kernel(A, iHd, D, Gyk, Gkk, Gku, out)
        out[~np.isfinite(out)] = np.inf
        return out
