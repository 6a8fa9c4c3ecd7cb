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

__all__ = ["Resolvent", "StaticTerms", "dynamic_stiffness", "screen_chunk", "static_terms",
           "woodbury"]

#: a complex-mode factorisation whose response differs from a direct solve by more than this
#: (relative) is replaced by direct solves
FACTOR_RTOL = 1e-7
#: relative splitting of exactly critically damped (defective) pairs
DEFECT_SPLIT = 1e-7
#: floor of |H / Hd|^2 in the screen (single precision)
_TINY = np.float32(1e-30)


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
    """Static corrections (4.23) of unit loads on candidate DOFs, w.r.t. a model's shapes.

    Parameters
    ----------
    Psi : ndarray, shape (N, nd)
        Static correction of a unit load on each candidate DOF.
    Fdd : ndarray, shape (nd, nd)
        ``Psi`` on the candidate DOFs (residual flexibility between them).
    Fyd : ndarray, shape (ns, nd)
        ``Psi`` at the model's sensors.
    Fdu : ndarray, shape (nd, na)
        ``Psi^T b_u`` for the model's actuators.
    flexibility : ndarray, shape (nd, nd)
        Full static flexibility ``K^-1`` between the candidate DOFs.
    """

    Psi: np.ndarray
    Fdd: np.ndarray
    Fyd: np.ndarray
    Fdu: np.ndarray
    flexibility: np.ndarray


def _pinv_sym(A, rtol=1e-10):
    d, U = np.linalg.eigh(0.5 * (A + A.T))
    keep = np.abs(d) > rtol * max(np.abs(d).max(), 1e-300)
    return (U[:, keep] / d[keep]) @ U[:, keep].T


def static_terms(fe, shapes, dof_idx, sensor_rows, actuator_cols) -> StaticTerms:
    """Static corrections of unit loads at ``dof_idx`` with respect to ``span(shapes)``.

    ``psi = K^-1 e - T (T^T K T)^+ T^T e`` (4.23): one solve with the model's cached
    factorisation (inertia relief for free structures), whatever the number of DOFs.

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
    N = fe.N
    E = np.zeros((N, dof_idx.size))
    E[dof_idx, np.arange(dof_idx.size)] = 1.0
    X = fe.static_response(E)
    T = shapes
    Kt = T.T @ np.asarray(fe.K @ T)
    Psi = X - T @ (_pinv_sym(Kt) @ (T.T @ E))
    Fyd = np.zeros((sensor_rows.size, dof_idx.size))
    ok = sensor_rows >= 0
    Fyd[ok] = Psi[sensor_rows[ok]]
    Fdu = np.zeros((dof_idx.size, actuator_cols.size))
    ok = actuator_cols >= 0
    Fdu[:, ok] = Psi[actuator_cols[ok]].T
    Fdd = Psi[dof_idx]
    return StaticTerms(Psi, 0.5 * (Fdd + Fdd.T), Fyd, Fdu, X[dof_idx])


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


def screen_chunk(task) -> np.ndarray:
    """Log-magnitude logLS costs of a chunk of candidates over their size grids.

    The screen runs in single precision on a subset of lines: it ranks candidates, the
    finalists are fitted again on all the data (:mod:`sdctrl.diagnosis._candidate_scan`).

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
    with single_thread():
        A, iHd, s = task["A"], task["iHd"], task["s"]
        Gyk, Gkk, Gku = task["Gyk"], task["Gkk"], task["Gku"]
        sizes = task["sizes"]
        nc, m = sizes.shape
        k = Gkk.shape[-1]
        D = dynamic_stiffness(task["kind"], s, sizes, task["extra"]).astype(np.complex64)
        out = np.empty((nc, m))
        if k == 1:
            P = (Gyk[..., :, :1] * Gku[..., :1, :]) * iHd          # (nc, nf, ns, na)
            for j in range(m):
                g = D[:, j] / (1.0 + D[:, j] * Gkk[:, :, 0, 0])    # (nc, nf)
                Q = A - g[:, :, None, None] * P
                a = np.log(np.maximum(Q.real**2 + Q.imag**2, _TINY))
                out[:, j] = np.mean(a * a, axis=(1, 2, 3), dtype=np.float64) / 4.0
            return out
        eye = np.eye(k, dtype=np.complex64)
        for j in range(m):
            d = D[:, j][:, :, None, None]
            X = np.linalg.solve(eye + d * Gkk, Gku)                # (nc, nf, k, na)
            Q = A - (d * (Gyk @ X)) * iHd
            a = np.log(np.maximum(Q.real**2 + Q.imag**2, _TINY))
            out[:, j] = np.mean(a * a, axis=(1, 2, 3), dtype=np.float64) / 4.0
        return out
