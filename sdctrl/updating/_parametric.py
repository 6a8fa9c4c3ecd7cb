"""Parametric reduced model (4.17) and its fast frequency response.

On a Ritz basis ``T`` (:mod:`sdctrl.updating._ritz_basis`) the model at parameter values ``p`` is

``(Mr + sum_i p_i dM_i) p'' + (Cr + sum_i p_i dC_i) p' + (Kr + sum_i p_i dK_i) p = T^T b u``,
``y = c T p``,

with every matrix projected once (``dK_i = T^T dK_i T``, ...): a prediction costs a small
eigenproblem and a product over the frequency lines, independent of the FE model's size.
The response is computed exactly on the reduced model's complex modes (one small
eigenproblem, then one product over the frequency lines).  :func:`perturbation` is the
first-order approximation (4.19) of the same projected equations, for comparison.

:class:`ReducedModel` holds only small arrays (no FE model), so it pickles cheaply to the
workers of an executor.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sla
from sdctrl._lib.frozen import FrozenState

__all__ = ["ReducedModel", "damping_from_modal", "perturbation", "reduced_model"]


@dataclass(frozen=True, eq=False)
class ReducedModel(FrozenState):
    """Parametric reduced model (4.17) for given sensors and actuators.

    Parameters
    ----------
    Mr, Cr, Kr : ndarray, shape (n, n)
        Reduced mass, damping (rad/s units after mass normalisation) and stiffness at
        ``p = 0``.
    dM, dC, dK : ndarray, shape (npar, n, n)
        Reduced parameter matrices (zeros where a parameter has none).
    c : ndarray, shape (ns, n)
        Reduced displacement sensors ``c T``.
    b : ndarray, shape (n, na)
        Reduced inputs ``T^T b``.
    names : tuple of str
        Parameter names.
    """

    Mr: np.ndarray
    Cr: np.ndarray
    Kr: np.ndarray
    dM: np.ndarray
    dC: np.ndarray
    dK: np.ndarray
    c: np.ndarray
    b: np.ndarray
    names: tuple

    @property
    def n(self) -> int:
        """Size of the reduced model."""
        return self.Kr.shape[0]

    @property
    def npar(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def with_damping(self, Cr) -> ReducedModel:
        """Copy with another nominal reduced damping matrix.

        Parameters
        ----------
        Cr : ndarray, shape (n, n)
            Reduced damping.

        Returns
        -------
        ReducedModel
        """
        return replace(self, Cr=np.asarray(Cr, float))

    def matrices(self, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reduced ``(M, C, K)`` at parameter values ``p``.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        tuple of ndarray, shape (n, n)
        """
        p = np.asarray(p, float).reshape(-1)
        M = self.Mr + np.tensordot(p, self.dM, 1)
        C = self.Cr + np.tensordot(p, self.dC, 1)
        K = self.Kr + np.tensordot(p, self.dK, 1)
        return M, C, K

    def modes(self, p) -> tuple[np.ndarray, np.ndarray]:
        """Normal modes of the reduced model at ``p``: ``(w2 (rad/s)^2, X)``, ``X^T M X = I``.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        w2 : ndarray, shape (n,)
        X : ndarray, shape (n, n)

        Raises
        ------
        ValueError
            The mass ``M + sum p dM`` is not positive definite at ``p``.
        """
        M, _, K = self.matrices(p)
        return _eigh(K, M, p)

    def frf(self, p, omega) -> np.ndarray:
        """Displacement FRF ``(nf, ns, na)`` at ``omega`` (rad/s) for parameter values ``p``.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.
        omega : ndarray, shape (nf,)
            Frequencies in rad/s.

        Returns
        -------
        ndarray, complex
        """
        M, C, K = self.matrices(p)
        w2, X = _eigh(K, M, p)
        return modal_frf(w2, X.T @ C @ X, self.c @ X, X.T @ self.b, omega)


def _eigh(K, M, p):
    try:
        return sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T))
    except np.linalg.LinAlgError:
        raise ValueError(f"the reduced mass is not positive definite at p = "
                         f"{np.round(np.asarray(p, float), 6).tolist()}: narrow the bounds of "
                         "the mass parameters") from None


def modal_frf(w2, G, cX, Xb, omega) -> np.ndarray:
    """Displacement FRF of ``(s^2 I + s G + diag(w2)) r = Xb u``, ``y = cX r``, exactly.

    Diagonal ``G`` (modal damping): the sum over modes.  Full ``G``: the complex modes of
    the first-order form, ``H(s) = sum_i R_i / (s - lambda_i)`` (one small eigenproblem and
    one product over the lines), checked against a direct solve at the band centre; a
    defective or ill-conditioned case falls back to batched direct solves.

    Parameters
    ----------
    w2 : ndarray, shape (n,)
        Modal stiffness (rad/s)^2.
    G : ndarray, shape (n, n)
        Modal damping (rad/s).
    cX : ndarray, shape (ns, n)
        Modal observability.
    Xb : ndarray, shape (n, na)
        Modal controllability.
    omega : ndarray, shape (nf,)
        Frequencies (rad/s).

    Returns
    -------
    ndarray, shape (nf, ns, na), complex
    """
    s = 1j * np.asarray(omega, float)
    n, ns, na = w2.size, cX.shape[0], Xb.shape[1]
    if not np.any(G - np.diag(np.diag(G))):
        d = w2[None, :] + s[:, None] ** 2 + s[:, None] * np.diag(G)[None, :]
        R = (cX[:, :, None] * Xb[None, :, :]).transpose(1, 0, 2).reshape(n, ns * na)
        return ((1.0 / d) @ R).reshape(-1, ns, na)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -np.diag(w2)
    A[n:, n:] = -G
    lam, V = sla.eig(A)
    try:
        W = np.linalg.solve(V, np.vstack([np.zeros((n, na)), Xb]))          # (2n, na)
    except np.linalg.LinAlgError:
        return _direct_frf(w2, G, cX, Xb, s)
    CV = cX @ V[:n]                                                          # (ns, 2n)
    R = (CV[:, :, None] * W[None, :, :]).transpose(1, 0, 2).reshape(2 * n, ns * na)
    H = ((1.0 / (s[:, None] - lam[None, :])) @ R).reshape(-1, ns, na)
    k = s.size // 2
    ref = _direct_frf(w2, G, cX, Xb, s[k:k + 1])[0]
    if np.abs(H[k] - ref).max() > 1e-8 * max(np.abs(ref).max(), 1e-300):
        return _direct_frf(w2, G, cX, Xb, s)
    return H


def _direct_frf(w2, G, cX, Xb, s):
    """Batched direct solves ``(s^2 I + s G + diag(w2))^-1`` (robust reference)."""
    n = w2.size
    Z = s[:, None, None] ** 2 * np.eye(n) + s[:, None, None] * G + np.diag(w2)
    rhs = np.broadcast_to(Xb.astype(complex), (s.size,) + Xb.shape)
    return cX @ np.linalg.solve(Z, rhs)


def damping_from_modal(M, X, Gamma) -> np.ndarray:
    """Reduced damping matrix whose modal projection on ``X`` is ``Gamma``: ``M X Gamma X^T M``.

    Parameters
    ----------
    M : ndarray, shape (n, n)
        Reduced mass (``X^T M X = I``).
    X : ndarray, shape (n, n)
        Reduced normal modes.
    Gamma : ndarray, shape (n, n)
        Modal damping (rad/s), e.g. ``diag(2 zeta_j omega_j)``.

    Returns
    -------
    ndarray, shape (n, n)
    """
    MX = M @ X
    C = MX @ Gamma @ MX.T
    return 0.5 * (C + C.T)


def reduced_model(basis, parameters, sensors, actuators, C=None) -> ReducedModel:
    """Project a model's matrices and parameters on a basis, for given point sensors/inputs.

    Parameters
    ----------
    basis : ReducedBasis
        The Ritz basis ``T``.
    parameters : sequence of Parameter
        The parameters (their ``dM, dC, dK`` projected once; ``dC`` with their Rayleigh law
        when the model's own ``C`` is given, without it under modal damping).
    sensors : ndarray of int, shape (ns,)
        DOF indices of the point displacement sensors.
    actuators : ndarray of int, shape (na,)
        DOF indices of the point forces.
    C : ndarray or sparse matrix, shape (N, N), optional
        Physical damping, projected; zeros when None (set later with
        :meth:`ReducedModel.with_damping`).

    Returns
    -------
    ReducedModel
    """
    n, npar = basis.n, len(parameters)
    d = {k: np.zeros((npar, n, n)) for k in ("dM", "dC", "dK")}
    for i, par in enumerate(parameters):
        for key, X in zip(("dM", "dC", "dK"), par.matrices(law=C is not None)):
            if X is not None:
                d[key][i] = basis.project(X)
    Cr = np.zeros((n, n)) if C is None else basis.project(C)
    T = basis.T
    return ReducedModel(basis.Mr, Cr, basis.Kr, d["dM"], d["dC"], d["dK"],
                        T[np.asarray(sensors, int)], T[np.asarray(actuators, int)].T,
                        tuple(p.name for p in parameters))


def perturbation(lam, dmu, dOmega) -> tuple[np.ndarray, np.ndarray]:
    """First-order perturbation of normal modes (4.19) on a truncated basis of normal modes.

    ``omega_j^2 = omega_j0^2 - omega_j0^2 dmu_jj + dOmega_jj`` and
    ``phi_j = phi_j0 + sum_{k != j} (-omega_j0^2 dmu_kj + dOmega_kj) /
    (omega_j0^2 - omega_k0^2) phi_k``, with ``dmu = phi^T dM phi``, ``dOmega = phi^T dK phi``.

    Parameters
    ----------
    lam : ndarray, shape (n,)
        Nominal ``omega_j0^2`` (rad/s)^2 of the retained modes.
    dmu : ndarray, shape (n, n)
        Projected mass change.
    dOmega : ndarray, shape (n, n)
        Projected stiffness change.

    Returns
    -------
    w2 : ndarray, shape (n,)
        Perturbed ``omega_j^2``.
    A : ndarray, shape (n, n)
        Perturbed shapes in the nominal modal coordinates (``phi_new = phi A``); singular
        for multiple eigenvalues (the coefficients of equal pairs are set to 0).

    Examples
    --------
    >>> import numpy as np
    >>> w2, A = perturbation(np.array([1.0, 4.0]), np.zeros((2, 2)), np.diag([0.1, 0.0]))
    >>> w2.tolist()
    [1.1, 4.0]
    """
    lam = np.asarray(lam, float)
    F = -lam[None, :] * dmu + dOmega                  # F[k, j] = -l_j dmu_kj + dOmega_kj
    w2 = lam + np.diag(F)
    gap = lam[None, :] - lam[:, None]                 # gap[k, j] = l_j - l_k
    with np.errstate(divide="ignore", invalid="ignore"):
        A = np.where(np.abs(gap) > 1e-12 * max(np.abs(lam).max(), 1e-300), F / gap, 0.0)
    np.fill_diagonal(A, 1.0)
    return w2, A
