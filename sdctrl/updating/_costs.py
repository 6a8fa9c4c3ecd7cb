"""FRF cost functions and modal correlation criteria (thesis 3.11, 3.12, 4.9).

All FRF costs accept :class:`~sdctrl.FRF` objects or arrays of the same shape
``(nf, ns, na)`` and are averaged over entries so that they compare across tests.
"""

from __future__ import annotations

import numpy as np

from sdctrl._lib.logratio import log_magnitude_ratio

__all__ = ["comac", "logls", "mac", "quadratic", "relative_error"]


def _pair(model, test):
    from sdctrl.data._frf import FRF

    a = model.H if isinstance(model, FRF) else np.asarray(model)
    b = test.H if isinstance(test, FRF) else np.asarray(test)
    if isinstance(model, FRF) and isinstance(test, FRF):
        if model.quantity != test.quantity:
            a = model.to(test.quantity).H
        if model.freq.shape != test.freq.shape or not np.allclose(model.freq, test.freq):
            raise ValueError("model and test must share the same frequency lines")
    if a.shape != b.shape:
        raise ValueError(f"model and test must have the same shape, got {a.shape} and {b.shape}")
    return a, b


def quadratic(model, test) -> float:
    """Quadratic FRF cost (3.11), ``mean |H_model - H_test|^2``.

    Parameters
    ----------
    model, test : FRF or array_like
        Predicted and measured FRFs (same lines, sensors, actuators).

    Returns
    -------
    float
    """
    a, b = _pair(model, test)
    return float(np.mean(np.abs(a - b) ** 2))


def relative_error(model, test) -> float:
    """Relative quadratic FRF error ``||H_model - H_test||_F / ||H_test||_F``.

    Invariant to a common scaling of both FRFs (from 1e-300 to 1e300: the norms are taken
    after an exact division by a power of two near ``max |H_test|``).

    Parameters
    ----------
    model, test : FRF or array_like
        Predicted and measured FRFs.

    Returns
    -------
    float
    """
    a, b = _pair(model, test)
    peak = float(np.abs(b).max()) if b.size else 0.0
    if np.isfinite(peak) and peak > 0:          # a power of two: exact, no under/overflow
        k = 2.0 ** -int(np.frexp(peak)[1])
        a, b = a * k, b * k
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def logls(model, test, phase: bool = False) -> float:
    """Log-least-squares FRF cost (3.12), ``mean |ln H_model - ln H_test|^2``.

    The logarithm weighs all amplitude levels alike (resonances and
    anti-resonances), which is what makes the cost suited to FE update and to
    comparing predictions (chapter IV, section 5.1.2).

    Parameters
    ----------
    model, test : FRF or array_like
        Predicted and measured FRFs.
    phase : bool
        Include the wrapped phase difference (complex logarithm); by default only
        the log-magnitudes are compared.

    Returns
    -------
    float
    """
    a, b = _pair(model, test)
    d = log_magnitude_ratio(a, b)
    if phase:
        dphi = np.angle(a * np.conj(b))
        return float(np.mean(d**2 + dphi**2))
    return float(np.mean(d**2))


def mac(phi_a, phi_b) -> np.ndarray:
    """Modal assurance criterion matrix (4.9) between the columns of two shape sets.

    Parameters
    ----------
    phi_a : array_like, shape (ns, na)
        First set of shapes (real or complex), one per column.
    phi_b : array_like, shape (ns, nb)
        Second set, on the same sensors.

    Returns
    -------
    ndarray, shape (na, nb)
        ``|a_j^H b_k|^2 / (|a_j|^2 |b_k|^2)`` in [0, 1].
    """
    A = np.asarray(phi_a)
    B = np.asarray(phi_b)
    if A.ndim == 1:
        A = A[:, None]
    if B.ndim == 1:
        B = B[:, None]
    if A.shape[0] != B.shape[0]:
        raise ValueError(f"phi_a and phi_b must have the same number of rows (sensors), "
                         f"got {A.shape[0]} and {B.shape[0]}")
    num = np.abs(A.conj().T @ B) ** 2
    den = np.outer(np.sum(np.abs(A) ** 2, axis=0), np.sum(np.abs(B) ** 2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, 0.0)


def comac(phi_a, phi_b) -> np.ndarray:
    """Coordinate MAC: correlation of paired shapes sensor by sensor.

    Parameters
    ----------
    phi_a, phi_b : array_like, shape (ns, n)
        Paired shapes (same column order), real.

    Returns
    -------
    ndarray, shape (ns,)
        ``(sum_j |a_ij b_ij|)^2 / (sum_j a_ij^2 sum_j b_ij^2)``; low values point at
        sensors where the two shape sets disagree.
    """
    A = np.real(np.asarray(phi_a, dtype=complex))
    B = np.real(np.asarray(phi_b, dtype=complex))
    if A.shape != B.shape:
        raise ValueError(f"phi_a and phi_b must have the same shape, got {A.shape} and {B.shape}")
    num = np.sum(np.abs(A * B), axis=1) ** 2
    den = np.sum(A**2, axis=1) * np.sum(B**2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, 0.0)
