"""Mass scale of the measured modes of a hybrid model: the test's and the FE's, combined.

The test scales each mode by its collocated residues (3.24).  A mode that the tested inputs
barely excite has tiny collocated residues, and its scale is "very sensitive to identification
errors" (thesis 3.3.4, Figure 3.7; the variances of 3.4.3 agree): its whole observability
vector may be off by a factor of several, with nothing at the tested I/O to show it (the
product ``cphi phib`` is what the test measures; the split between them is the scale).  The FE
model holds a second, independent estimate: for the true mass matrix the expanded shapes are
mass-orthonormal (4.1.1, "modeshape expansion does not change the scaling"), so ``phi_Ex^T M
phi_Ex`` of a mode expanded from its test observabilities is its squared scale error as the
FE's mass sees it.

Per kept measured mode ``j``, in logarithms:

- the test's scale error ``delta_j``, of standard deviation ``sigma_j`` -- the relative
  standard deviation of its observabilities, ``||std(cphi_j)|| / ||cphi_j||`` (``nm.std``,
  3.4; it includes the shape's noise, so it bounds the scale's from above);
- the FE's reading ``d_j = -1/2 log(phi_Ex,j^T M phi_Ex,j) = delta_j + b + e_j``: ``b`` an
  error common to every mode (a mass or density error of the FE), ``e_j ~ N(0, tau^2)`` the
  FE's own error for that mode.

``b`` and ``tau^2`` come from the modes themselves (a random-effects model, moment estimate
of DerSimonian and Laird): the well-measured modes show how far the FE's modal masses stray.
The posterior mean ``delta_j = (d_j - b) sigma_j^2 / (sigma_j^2 + tau^2)`` leaves a
well-measured mode as the test has it and gives a mode the test cannot scale the FE's scale.
No threshold: the weights are the two variances.  Its variance is ``sigma_j^2 tau^2 /
(sigma_j^2 + tau^2)`` plus that of ``b`` (``1 / sum_k 1/(sigma_k^2 + tau^2)``) carried by the
weight ``sigma_j^2 / (sigma_j^2 + tau^2)``.  ``tau`` is learnt from the well-measured modes
only (a mode the test cannot scale says nothing of the FE's spread): with one or two of them
it is poorly known, and the standard deviation understates the error when it comes out
small.

The factor ``a_j = exp(delta_j)`` scales the expanded shape only.  The tested I/O keep the
identified ``cphi`` and ``phib`` (the hybrid's offsets at the tested sensors, 5.1.2): with
non-proportional damping a rescaling of ``cphi`` and ``phib`` alone would change the tested
transfers.  What changes is what the shapes predict: untested inputs and outputs, struts,
modifications.  Without ``nm.std`` (``sd.normal_modes(..., std=False)``) nothing is
rescaled.
"""

from __future__ import annotations

import numpy as np

from sdctrl.hybrids._hybrid_records import MassScale

__all__ = ["fe_mass_scale", "measured_scale_std", "random_effects"]


def measured_scale_std(nm, kept) -> np.ndarray | None:
    """Relative standard deviation of the test's scale of each kept mode (module notes), or
    None when ``nm`` carries no statistics (or not for its observabilities)."""
    std = nm.std if isinstance(nm.std, dict) else None
    s = None if std is None else std.get("cphi")
    if s is None or np.shape(s) != np.shape(nm.cphi):
        return None
    num = np.linalg.norm(np.asarray(s, float)[:, kept], axis=0)
    den = np.linalg.norm(np.asarray(nm.cphi)[:, kept], axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return num / den


def random_effects(d, s2):
    """Common offset ``b`` and spread ``tau^2`` of readings ``d`` of variances ``s2`` (the
    moment estimate of DerSimonian and Laird, ``tau^2 >= 0``), ``b`` with weights
    ``1 / (s2 + tau^2)``.

    >>> b, tau2 = random_effects([0.1, 0.1, 0.1], [1e-4, 1e-4, 1e-4])
    >>> round(b, 6), tau2
    (0.1, 0.0)
    """
    d, s2 = np.asarray(d, float), np.asarray(s2, float)
    w = 1.0 / s2
    b0 = np.sum(w * d) / np.sum(w)
    q = np.sum(w * (d - b0) ** 2)
    den = np.sum(w) - np.sum(w ** 2) / np.sum(w)
    tau2 = max(0.0, (q - (d.size - 1)) / den) if den > 0 else 0.0
    ws = 1.0 / (s2 + tau2)
    return float(np.sum(ws * d) / np.sum(ws)), float(tau2)


def fe_mass_scale(M, expanded, sigma, modes, freq_error=None) -> MassScale | None:
    """The combined scale of the kept measured modes (module notes).

    Parameters
    ----------
    M : sparse matrix or ndarray, shape (N, N)
        The FE mass.
    expanded : ndarray, shape (N, n)
        The expanded shapes (4.7) of the kept measured modes, from the test's scale.
    sigma : ndarray, shape (n,), or None
        Relative standard deviation of each mode's test scale (:func:`measured_scale_std`).
    modes : ndarray of int, shape (n,)
        Indices of the modes in the identified model.
    freq_error : ndarray, shape (n,), optional
        Each mode's own FE frequency error, ``log(f_test / f_FE)`` less its median over the
        modes (``log kappa``): the FE's reading of that mode has this much more spread
        (module notes); default none.

    Returns
    -------
    MassScale or None
        None without statistics or with fewer than two usable modes (no spread to learn).
    """
    if sigma is None:
        return None
    mu = np.einsum("ij,ij->j", expanded, np.asarray(M @ expanded))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = -0.5 * np.log(mu)
    s2 = np.maximum(np.asarray(sigma, float) ** 2, np.finfo(float).tiny)
    e2 = np.zeros(d.size) if freq_error is None else np.asarray(freq_error, float) ** 2
    use = np.isfinite(d) & np.isfinite(s2) & np.isfinite(e2) & (mu > 0)
    if use.sum() < 2:
        return None
    b, tau2 = random_effects(d[use], s2[use] + e2[use])
    fe2 = tau2 + e2[use]                                 # the FE reading's variance
    g = s2[use] / (s2[use] + fe2)                        # the FE's weight
    var_b = 1.0 / np.sum(1.0 / (s2[use] + fe2))
    delta = np.zeros(d.size)
    post = np.full(d.size, np.nan)
    delta[use] = (d[use] - b) * g
    post[use] = np.sqrt(g * fe2 + g ** 2 * var_b)
    return MassScale(test_mode=np.asarray(modes, int), test_std=np.sqrt(s2), fe_log=d,
                     factor=np.exp(delta), std=post, bias=b, spread=float(np.sqrt(tau2)))
