"""Scaling of complex modes that the collocated pairs do not observe (thesis 3.24, 3.40, 3.58).

The scaling ``kappa_j^2 = z_j`` of mode ``j`` (3.24) comes from its collocated residues
``R_j[s, a] = (c_s psi_j)^2``.  A mode that hardly moves at any collocated pair (a localised
mode of a cluster, far from every shaker) has collocated residues within the test's noise:
its ``z_j`` is noise then, in magnitude and in phase.  A phase set by the noise makes the
scaled mode far from proper (3.40): the identified mass of the set is not positive definite
(3.45) or (3.52) has no small root, and the mode, though well identified elsewhere, cannot
become a normal mode.

What the data do not give, properness does for the phase: a lightly damped mode scaled by
``mu = I`` (2.6) is ``psi_j = phi_j / sqrt(2 i w_dj)`` with ``phi_j`` real, so that
``z_j u_j^T u_j`` (``u_j`` the mode's unit observability, 3.23) is ``-i`` times a positive
number -- the phase that makes the mode proper on its own and its mass positive
(``2 Re(lambda_j z_j u_j^T u_j) > 0``).  For the modes whose collocated residues are all within
:data:`SCALING_SIGMAS` standard deviations (3.58) :func:`sdctrl.normal_modes` takes that
phase and keeps the least-squares magnitude of (3.24), which the test does not determine
either: the normal mode still reproduces the identified residue at the tested I/O (``phib`` is
fitted to it, step 5 of :func:`sdctrl.normal_modes`), but its mass scale -- ``cphi`` and the
collocation ``phib[:, a] = cphi[s]`` -- is not measured, and a warning says so.

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["SCALING_SIGMAS", "proper_phase", "unscaled_poles"]

#: a mode's scaling is determined by the test when one of its collocated residues exceeds
#: this many standard deviations (3.58): the usual three-sigma significance
SCALING_SIGMAS = 3.0


def unscaled_poles(cm, pairs, candidates) -> np.ndarray:
    """Candidate poles whose collocated residues are all within :data:`SCALING_SIGMAS` std
    (3.58), with a warning naming them.

    Parameters
    ----------
    cm : ComplexModeModel
        Identified model; without statistics no pole is reported (nothing tells the noise).
    pairs : sequence of (int, int)
        Collocated (sensor, actuator) index pairs.
    candidates : ndarray of int
        The poles to be made normal modes.

    Returns
    -------
    ndarray of int
        Indices of the poles of ``cm`` whose scaling (3.24) the test does not determine.
    """
    if cm.statistics is None or not len(pairs):
        return np.zeros(0, int)
    si, ai = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        std = np.asarray(cm.residue_std())[:, si, ai]
    size = np.abs(np.asarray(cm.residues)[:, si, ai])
    known = np.isfinite(std) & (std > 0)
    z = np.where(known, size / np.where(known, std, 1.0), np.inf)      # unknown std: trusted
    free = np.intersect1d(np.flatnonzero(np.all(z <= SCALING_SIGMAS, axis=1)), candidates)
    if free.size:
        warnings.warn("normal_modes: pole(s) " + ", ".join(
            f"{j} ({cm.frequency[j]:.4g} Hz)" for j in free) + " have collocated residues "
            f"within {SCALING_SIGMAS:g} standard deviations (3.58): their scaling's phase is "
            "that of a proper mode (3.40), their mass scale is not measured", RuntimeWarning,
            stacklevel=3)
    return free


def proper_phase(cpsi: np.ndarray, psib: np.ndarray, z: np.ndarray, which: np.ndarray):
    """Scaled modes (3.24) whose scaling ``z`` takes the phase of a proper mode where ``which``.

    ``cpsi[:, j] = sqrt(z_j) u_j`` and ``psib[j] = w_j / sqrt(z_j)`` become the same with
    ``z'_j = |z_j| exp(i (-pi/2 - arg(u_j^T u_j)))`` (module notes); the product ``cpsi_j
    psib_j^T``, the residue's dyad, is unchanged.

    Parameters
    ----------
    cpsi : ndarray, shape (ns, n), complex
    psib : ndarray, shape (n, na), complex
    z : ndarray, shape (n,), complex
        The scalings ``kappa^2`` of (3.24).
    which : ndarray of bool, shape (n,)
        Modes whose phase is set by properness.

    Returns
    -------
    cpsi, psib : ndarray
        New arrays (the inputs are not modified).
    """
    cpsi, psib = np.array(cpsi, complex), np.array(psib, complex)
    for j in np.flatnonzero(which):
        if not np.isfinite(z[j]) or z[j] == 0:
            continue                              # reported unscalable by the caller
        uu = np.sum(cpsi[:, j] ** 2) / z[j]       # u^T u
        new = np.abs(z[j]) * np.exp(1j * (-0.5 * np.pi - np.angle(uu)))
        r = np.sqrt(new) / np.sqrt(complex(z[j]))
        cpsi[:, j] *= r
        psib[j] /= r
    return cpsi, psib
