"""Residual mass of the low modes of a hybrid model (thesis 2.23, 5.1.1).

The identified residual mass ``F`` (2.23) of the test stands for the modes below the band;
in a hybrid model those are FE modes (suspension, rigid-body) whose modal masses the FE
model may get wrong.  :func:`mass_fit` corrects their inverse modal masses by a symmetric
``P`` fitted to the identified FRF at the tested I/O (with a constant ``E``),
:func:`mass_bounded` keeps its eigenvalues within :data:`MASS_CORRECTION`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MASS_CORRECTION", "MASS_REG", "MassSystem", "mass_bounded", "mass_fit",
           "mass_solve", "mass_system"]

#: bounds of the eigenvalues of the modal-mass correction of the low modes
MASS_CORRECTION = (0.25, 4.0)
#: regularisation of the residual-mass fit toward the FE masses (relative)
MASS_REG = 1e-4


def mass_fit(X, Z, w2, zeta, w, target, W):
    """Symmetric ``P`` correcting the modal inverse masses of the low modes.

    Parameters
    ----------
    X : ndarray, shape (ns, k)
        Observabilities of the low modes at the tested sensors.
    Z : ndarray, shape (k, na)
        Their controllabilities.
    w2 : ndarray, shape (k,)
        Their ``omega^2`` (rad/s)^2.
    zeta : float
        Their damping ratio.
    w : ndarray
        Lines (rad/s).
    target : ndarray, shape (nw, ns, na)
        What the low modes and a constant ``E`` must give.
    W : ndarray, shape (nw, ns, na)
        Weights (inverse squared magnitudes of the identified FRF).

    Returns
    -------
    ndarray, shape (k, k)

    Notes
    -----
    Minimises ``sum W |target - sum_kl P_kl X_k Z_l g_kl(w) - E|^2`` over ``P`` and a real
    constant ``E`` (eliminated), ``P`` regularised toward ``I``; ``g_kl`` is the geometric
    mean of the modes' dynamic factors (the modes lie below the band: ``g ~ -1/w^2``).
    The normal equations do not depend on ``target``: :func:`mass_system` forms them once
    for the variants of one build, :func:`mass_solve` solves them for each target.
    """
    return mass_solve(mass_system(X, Z, w2, zeta, w, W), target)


@dataclass(frozen=True, eq=False)
class MassSystem:
    """The part of :func:`mass_fit` independent of its target: lines kept every ``step``,
    the fitted entries ``iu`` of the ``k x k`` ``P``, the weighted design ``rows``, the
    response ``y0`` of ``P = I``, the weights and the regularised normal matrix ``lhs``."""

    step: int
    k: int
    iu: tuple
    rows: np.ndarray
    y0: np.ndarray
    W: np.ndarray
    sw: np.ndarray
    wsum: np.ndarray
    lhs: np.ndarray


def mass_system(X, Z, w2, zeta, w, W) -> MassSystem:
    """Normal equations of :func:`mass_fit` (arguments as there, without ``target``)."""
    k = X.shape[1]
    iu = np.triu_indices(k)
    diag = iu[0] == iu[1]
    # few lines suffice for a handful of parameters; bound the work on large tests
    step = max(1, int(np.ceil(w.size * iu[0].size * X.shape[0] * Z.shape[1] / 2e6)))
    w, W = w[::step], W[::step]
    g = 1.0 / (w2[None, :] - w[:, None] ** 2 + 2j * zeta * w[:, None] * np.sqrt(w2))
    gab = -np.sqrt(g[:, iu[0]] * g[:, iu[1]])                       # (nw, p), below band
    T = np.einsum("ip,pj->pij", X[:, iu[0]], Z[iu[1]])
    T[~diag] += np.einsum("ip,pj->pij", X[:, iu[1][~diag]], Z[iu[0][~diag]])
    B = gab[:, :, None, None] * T[None]                              # (nw, p, ns, na)
    sw = np.sqrt(W)
    wsum = np.sum(W, axis=0)
    Br = B.real - (np.einsum("wij,wpij->pij", W, B.real) / wsum)[None]
    rows = np.concatenate([(Br * sw[:, None]).reshape(w.size, iu[0].size, -1),
                           (B.imag * sw[:, None]).reshape(w.size, iu[0].size, -1)], axis=2)
    rows = rows.transpose(1, 0, 2).reshape(iu[0].size, -1).T
    RtR = rows.T @ rows
    scale = float(np.linalg.eigvalsh(RtR)[-1])                      # ||rows||_2^2
    return MassSystem(step, k, iu, rows, B[:, diag].sum(axis=1), W, sw, wsum,
                      RtR + MASS_REG * scale * np.eye(rows.shape[1]))


def mass_solve(system: MassSystem, target) -> np.ndarray:
    """``P`` of :func:`mass_fit` for ``target`` (nw, ns, na) from its normal equations."""
    W, sw, wsum = system.W, system.sw, system.wsum
    y = target[::system.step] - system.y0                           # P = I part

    def centred(Y):                     # real part less its weighted mean over lines
        return Y - np.sum(W * Y, axis=0) / wsum

    rhs = np.concatenate([(centred(y.real) * sw).reshape(y.shape[0], -1),
                          (y.imag * sw).reshape(y.shape[0], -1)], axis=1).ravel()
    dp = np.linalg.solve(system.lhs, system.rows.T @ rhs)
    P = np.eye(system.k)
    P[system.iu] += dp
    P[(system.iu[1], system.iu[0])] = P[system.iu]
    return P


def mass_bounded(P):
    """The inverse-mass correction ``P`` with its eigenvalues within :data:`MASS_CORRECTION`.

    Parameters
    ----------
    P : ndarray, shape (k, k)

    Returns
    -------
    ndarray, shape (k, k)
    """
    ev, V = np.linalg.eigh(0.5 * (P + P.T))
    return (V * np.clip(ev, *MASS_CORRECTION)) @ V.T
