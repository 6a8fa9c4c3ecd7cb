"""The record of how :func:`sdctrl.normal_modes` built a normal-mode model (thesis 3.3):
``nm.properness``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.records import freeze_arrays
from sdctrl.identification._collocated_passivity import CollocatedPassivity

__all__ = ["Properness"]


@dataclass(frozen=True, eq=False)
class Properness(FrozenState):
    """How :func:`normal_modes` built a normal-mode model from complex modes (3.3).

    Read as ``nm.properness``; None for models built otherwise (matrices, FE, hybrid).
    Every field may be None in files written before it existed.

    Attributes
    ----------
    collocated : tuple of (int, int)
        Collocated (sensor, actuator) index pairs that scaled the modes (3.24).
    cpsi : ndarray, shape (ns, n), complex
        Scaled complex modal observability (3.24)-(3.25).
    psib : ndarray, shape (n, na), complex
        Scaled complex modal controllability.
    c_T : ndarray, shape (ns, n)
        Reduced coordinates ``q_T`` (3.46)-(3.47): the identity when ``ns == n``.
    sensor_eigenvalues : ndarray, shape (ns,) or None
        Spectrum of ``2 Re(cpsi Lambda cpsi^T)`` (3.47), kept ones first; None when
        ``ns == n``.
    psi_proper : ndarray, shape (n, n), complex
        The proper complex modes (3.51) in the reduced coordinates.
    properness_before, properness_after : float
        ``||psi psi^T|| / ||psi psi^H||`` (3.40) before and after the correction.
    delta, delta_eigenvalues, delta_radius, riccati_residual, newton_iterations
        The correction (3.51)-(3.52)
        (:class:`~sdctrl.identification._properness.RiccatiCorrection`); ``delta_radius`` must be
        well below 1 (3.54).
    M_T, C_T, K_T : ndarray, shape (n, n)
        Mass, damping and stiffness of the reduced coordinates (3.44).
    mass_eigenvalues, stiffness_eigenvalues, damping_eigenvalues : ndarray, shape (n,)
        Their spectra (damping relative to mass, rad/s).
    positive_definite : dict of str to bool
        ``{"mass", "stiffness", "damping"}`` definiteness (3.45).
    pole_error : float
        Max relative deviation of the model's poles from the identified ones.
    residue_error : float
        Relative misfit of the model's residues to the identified ones.
    collocation_error : float
        Max relative ``||phib[:, a] - cphi[s]||`` over the collocated pairs.
    E_relative_size, F_relative_size : float
        Size of ``E`` and ``F / w_min^2`` relative to the modal flexibility scale (dropped
        below ``1e-10``).
    in_band : ndarray of bool, shape (n,)
        Per normal mode, the ``in_band`` flag of the identified pole it matches.
    band : (float, float) or None
        Band (Hz) of the complex-mode model.
    poles_used : ndarray of int
        Poles of the complex-mode model transformed.
    poles_left_out : ndarray of int
        Poles neither made modes nor kept as residual dynamics (``modes=`` left them out;
        :func:`sdctrl.hybrid` warns about them).  The residual ones are ``nm.residual.source``.
    poles_left_out_hz : ndarray
        Their frequencies (Hz).
    passivity : CollocatedPassivity
        How passive the model is at the collocated pairs, and whether the collocated
        blocks of its residual dynamics, ``E`` and ``F`` were refitted to make it so
        (step 8, :mod:`~sdctrl.identification._collocated_passivity`).
    """

    collocated: tuple | None = None
    cpsi: np.ndarray | None = None
    psib: np.ndarray | None = None
    c_T: np.ndarray | None = None
    sensor_eigenvalues: np.ndarray | None = None
    psi_proper: np.ndarray | None = None
    properness_before: float | None = None
    properness_after: float | None = None
    delta: np.ndarray | None = None
    delta_eigenvalues: np.ndarray | None = None
    delta_radius: float | None = None
    riccati_residual: float | None = None
    newton_iterations: int | None = None
    M_T: np.ndarray | None = None
    C_T: np.ndarray | None = None
    K_T: np.ndarray | None = None
    mass_eigenvalues: np.ndarray | None = None
    stiffness_eigenvalues: np.ndarray | None = None
    damping_eigenvalues: np.ndarray | None = None
    positive_definite: dict | None = None
    pole_error: float | None = None
    residue_error: float | None = None
    collocation_error: float | None = None
    E_relative_size: float | None = None
    F_relative_size: float | None = None
    in_band: np.ndarray | None = None
    band: tuple | None = None
    poles_used: np.ndarray | None = None
    poles_left_out: np.ndarray | None = None
    poles_left_out_hz: np.ndarray | None = None
    passivity: CollocatedPassivity | None = None

    def __post_init__(self):
        freeze_arrays(self)
