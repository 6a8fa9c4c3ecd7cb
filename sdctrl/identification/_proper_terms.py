"""The terms of a normal-mode model built from proper complex modes (thesis 3.3): the
asymptotic terms ``E`` and ``F`` kept when not negligible (3.7), the real input shapes
``phib`` fitted to the residues, the residues of the result and the check of its poles
against the identified ones (steps 4-5 of :func:`sdctrl.normal_modes`).

Internal module: the functions trust their inputs (validated by ``normal_modes``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["asymptotic_terms", "model_residues", "phib_from_residues", "pole_error"]


def asymptotic_terms(E, F, lam, R, rtol: float = 1e-10):
    """``E`` and ``F`` of the complex-mode model, None when negligible (round-off of a fit),
    and their relative sizes (``E_relative_size``, ``F_relative_size``).

    ``E`` is compared with the off-resonance flexibility scale of the modes,
    ``max_j max|R_j| / |lambda_j|``, and ``F`` through ``F / w^2`` at the lowest pole; a
    negligible ``F`` would otherwise add needless rigid-body states (2.24) to the
    state-space form.
    """
    ref = max(float(np.max(np.abs(R).max(axis=(1, 2)) / np.abs(lam))), 1e-300)
    wmin = float(np.abs(lam).min())
    out, sizes = [], {}
    for name, X, scale in (("E", E, 1.0), ("F", F, wmin**-2)):
        size = float(np.abs(X).max()) * scale if X is not None and np.size(X) else 0.0
        keep = size > rtol * ref
        sizes[f"{name}_relative_size"] = size / ref
        out.append(np.array(X, float) if keep else None)
    return out, sizes


def phib_from_residues(R: np.ndarray, cpsi_p: np.ndarray, Psi: np.ndarray) -> np.ndarray:
    """Real ``phib`` minimising ``sum_j ||R_j - cpsi_j Psi_j^T phib||^2`` (linear LS)."""
    n, ns, na = R.shape
    D = np.einsum("ij,kj->jik", cpsi_p, Psi).reshape(n * ns, Psi.shape[0])
    rhs = R.reshape(n * ns, na)
    A = np.vstack([D.real, D.imag])
    b = np.vstack([rhs.real, rhs.imag])
    return np.linalg.lstsq(A, b, rcond=None)[0]


def model_residues(cphi: np.ndarray, Psi: np.ndarray, phib: np.ndarray) -> np.ndarray:
    """Residues ``cphi Psi_j Psi_j^T phib`` of a normal-mode model, shape (n, ns, na)."""
    return np.einsum("ij,jk->jik", cphi @ Psi, Psi.T @ phib)


def pole_error(p_model: np.ndarray, p_id: np.ndarray) -> float:
    """Max relative distance of each identified pole to the model's matching pole."""
    from scipy.optimize import linear_sum_assignment

    p_model = p_model[p_model.imag > 0]
    if p_model.size != p_id.size:
        return float("inf")
    cost = np.abs(p_id[:, None] - p_model[None, :]) / np.abs(p_id)[:, None]
    r, c = linear_sum_assignment(cost)
    return float(cost[r, c].max()) if r.size else 0.0
