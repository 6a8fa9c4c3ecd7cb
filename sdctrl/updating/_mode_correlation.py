"""Correlation criteria of FE and test normal modes (thesis 4.1.2, eqs. 4.8-4.13).

With the MAC (4.9) and COMAC (:mod:`sdctrl.updating._costs`):

- :func:`frequency_error` -- relative errors of paired modal frequencies (4.8);
- :func:`observability_error` -- the error of *scaled* modal observabilities at the sensors
  (4.10), which, with (4.8), characterises the undamped I/O behaviour completely (the MAC
  ignores the scaling);
- :func:`mixed_orthogonality` -- ``phi_FE^T M phi_ID`` and ``phi_FE^T K phi_ID`` (4.12), close
  to ``I`` and ``Omega`` when the FE model is right;
- :func:`modal_energies` -- ``mu_s = phi_Ex^T M phi_Ex`` and ``Omega_s = phi_Ex^T K phi_Ex``
  (4.13): the FE model's kinetic and strain energies in the coordinates of the expanded
  test modes, close to ``I`` and ``diag(omega_ID^2)`` for an accurate model.

Mode shapes on FE DOFs come from :meth:`FEModel.modes`, expanded test modes from
:func:`sdctrl.hybrids._expansion.expand` (4.7) or a hybrid model's ``shapes``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.validate import as_array

__all__ = ["frequency_error", "mixed_orthogonality", "modal_energies", "observability_error"]


def frequency_error(f_fe, f_id) -> np.ndarray:
    """Relative errors ``f_FE / f_ID - 1`` of paired modal frequencies (4.8).

    Parameters
    ----------
    f_fe : array_like, shape (n,)
        FE frequencies of the modes paired with the test modes (Hz or rad/s).
    f_id : array_like, shape (n,)
        Identified frequencies, same units.

    Returns
    -------
    ndarray, shape (n,)
        The criterion (4.8) is ``sum(error**2)`` (relative form).

    Examples
    --------
    >>> import numpy as np
    >>> np.round(frequency_error([10.5, 19.0], [10.0, 20.0]), 6).tolist()
    [0.05, -0.05]
    """
    a = as_array(f_fe, "f_fe", ndim=1)
    b = as_array(f_id, "f_id", ndim=1)
    if a.shape != b.shape:
        raise ValueError(f"f_fe and f_id must have the same shape, got {a.shape} and {b.shape}")
    if np.any(b <= 0):
        raise ValueError("f_id must hold positive frequencies")
    return a / b - 1.0


def observability_error(cphi_fe, cphi_id) -> tuple[float, np.ndarray]:
    """Error of scaled modal observabilities at the sensors (4.10), per paired mode.

    ``sum_ij |(c phi)_ij - c_i phi_j|^2`` with each FE shape's sign aligned on the test
    shape (mode shapes are defined up to a sign); both sets must be scaled alike (mass
    normalisation: FE modes from :meth:`FEModel.modes`, identified ones from
    :func:`sdctrl.normal_modes`).

    Parameters
    ----------
    cphi_fe : array_like, shape (ns, n)
        FE observabilities ``c phi_FE`` of the modes paired with the test modes.
    cphi_id : array_like, shape (ns, n)
        Identified observabilities (real normal modes, or complex).

    Returns
    -------
    total : float
        The criterion (4.10).
    relative : ndarray, shape (n,)
        ``||(c phi)_ID,j - c phi_FE,j||^2 / ||(c phi)_ID,j||^2`` per mode.

    Examples
    --------
    >>> import numpy as np
    >>> total, rel = observability_error([[1.0], [-2.0]], [[-1.1], [2.0]])
    >>> round(total, 6), np.round(rel, 4).tolist()
    (0.01, [0.0019])
    """
    A = as_array(cphi_fe, "cphi_fe", ndim=2, dtype=complex)
    B = as_array(cphi_id, "cphi_id", ndim=2, dtype=complex)
    if A.shape != B.shape:
        raise ValueError(f"cphi_fe and cphi_id must have the same shape (paired modes), got "
                         f"{A.shape} and {B.shape}")
    sign = np.sign(np.real(np.einsum("ij,ij->j", A.conj(), B)))
    sign[sign == 0] = 1.0
    D = B - A * sign
    err = np.sum(np.abs(D) ** 2, axis=0)
    ref = np.sum(np.abs(B) ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(ref > 0, err / ref, np.inf)
    return float(err.sum()), rel


def _check(X, name, N):
    if sp.issparse(X):
        if X.shape != (N, N):
            raise ValueError(f"{name} must have shape ({N}, {N}), got {X.shape}")
        return X
    return as_array(X, name, shape=(N, N))


def mixed_orthogonality(phi_fe, phi_id, M, K=None):
    """Mixed orthogonality tables (4.12): ``phi_FE^T M phi_ID`` and ``phi_FE^T K phi_ID``.

    For a correct model (and correctly scaled, expanded test modes) they approach ``I`` and
    ``Omega``; the mass table alone says little more than the MAC (section 4.1.2), the two
    together characterise the modes.

    Parameters
    ----------
    phi_fe : array_like, shape (N, m)
        FE modes (mass-normalised).
    phi_id : array_like, shape (N, n)
        Test modes on the FE DOFs (expanded, 4.7).
    M : array_like or sparse matrix, shape (N, N)
        FE mass matrix.
    K : array_like or sparse matrix, shape (N, N), optional
        FE stiffness matrix.

    Returns
    -------
    mass : ndarray, shape (m, n)
    stiffness : ndarray, shape (m, n) or None
        None when ``K`` is not given.
    """
    P = as_array(phi_fe, "phi_fe", ndim=2)
    Q = as_array(phi_id, "phi_id", ndim=2)
    N = P.shape[0]
    if Q.shape[0] != N:
        raise ValueError(f"phi_id must have N={N} rows like phi_fe, got {Q.shape}")
    mass = P.T @ np.asarray(_check(M, "M", N) @ Q)
    stiff = None if K is None else P.T @ np.asarray(_check(K, "K", N) @ Q)
    return mass, stiff


def modal_energies(phi_ex, M, K):
    """FE modal mass and stiffness in the expanded test modes' coordinates (4.13).

    ``mu_s = phi_Ex^T M phi_Ex`` (kinetic energies) and ``Omega_s = phi_Ex^T K phi_Ex``
    (strain energies): close to ``I`` and ``diag(omega_ID^2)`` when the FE model is
    accurate; an updated model should match them better than the initial one.

    Parameters
    ----------
    phi_ex : array_like, shape (N, n)
        Expanded test modes (scaled as measured, 4.7).
    M, K : array_like or sparse matrix, shape (N, N)
        FE mass and stiffness.

    Returns
    -------
    mu_s, Omega_s : ndarray, shape (n, n)
    """
    P = as_array(phi_ex, "phi_ex", ndim=2)
    N = P.shape[0]
    mu = P.T @ np.asarray(_check(M, "M", N) @ P)
    om = P.T @ np.asarray(_check(K, "K", N) @ P)
    return 0.5 * (mu + mu.T), 0.5 * (om + om.T)
