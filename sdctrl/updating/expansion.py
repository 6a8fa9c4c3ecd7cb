"""Expansion of measured modes onto FE DOFs (thesis 4.1.1, eq. 4.7) and FE/test mode
pairing by the MAC (4.9).

The test measures the modal observabilities ``(c phi)_ID`` at its sensors only; the FE
model gives shapes on all its DOFs.  Pairing matches each test mode with the FE mode of
largest MAC (one FE mode per test mode, maximal total MAC); the geometric expansion (4.7)
combines the paired FE shapes to fit the measured ones at the sensors,
``phi_Ex = phi_FE (c phi_FE)^+ (c phi)_ID``.  Both serve the hybrid models of chapter V
(:func:`sdctrl.hybrid`) and the correlation of FE and test modes in updating.
"""

from __future__ import annotations

import numpy as np

from sdctrl._validate import as_array
from sdctrl.updating.costs import mac

__all__ = ["MAC_POOR", "expand", "pair_modes"]

#: MAC below which a FE/test pair is reported as poor (with a warning)
MAC_POOR = 0.8


def expand(phi_fe, c, cphi_id, rcond: float = 1e-10):
    """Geometric expansion of measured modes onto all FE DOFs, eq. (4.7).

    ``A = argmin ||c phi_FE A - (c phi)_ID||_F = (c phi_FE)^+ (c phi)_ID`` and the
    expanded shapes are ``phi_Ex = phi_FE A``.  With more sensors than modes the
    pseudo-inverse smooths the measured observabilities towards the span of the FE
    shapes (section 4.1.1); the scaling of ``(c phi)_ID`` (mass normalisation of the true
    structure) is kept.

    Parameters
    ----------
    phi_fe : array_like, shape (N, m)
        FE mode shapes spanning the expansion (e.g. the FE modes paired with the test).
    c : array_like, shape (ns, N)
        Test sensors placed on the FE DOFs.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities (displacement sensors).
    rcond : float
        Relative cut-off of small singular values of ``c phi_FE`` in the pseudo-inverse.

    Returns
    -------
    shapes : ndarray, shape (N, n)
        Expanded shapes ``phi_FE A``.
    A : ndarray, shape (m, n)
        Combination coefficients.

    Examples
    --------
    >>> import numpy as np
    >>> phi = np.eye(4)[:, :2]
    >>> c = np.eye(4)[:3]
    >>> shapes, A = expand(phi, c, np.array([[1.0], [0.5], [0.0]]))
    >>> shapes.ravel().tolist()
    [1.0, 0.5, 0.0, 0.0]
    """
    P = as_array(phi_fe, "phi_fe", ndim=2)
    Cm = as_array(c, "c", ndim=2)
    Y = as_array(cphi_id, "cphi_id", ndim=2)
    if Cm.shape[1] != P.shape[0]:
        raise ValueError(f"c must have shape (ns, N={P.shape[0]}), got {Cm.shape}")
    if Y.shape[0] != Cm.shape[0]:
        raise ValueError(f"cphi_id must have shape (ns={Cm.shape[0]}, n), got {Y.shape}")
    A = np.linalg.pinv(Cm @ P, rcond=rcond) @ Y
    return P @ A, A


def pair_modes(cphi_fe, cphi_id):
    """Pair test modes with FE modes by maximal total MAC (4.9), one FE mode per test mode.

    Parameters
    ----------
    cphi_fe : array_like, shape (ns, m)
        FE modal observabilities at the test sensors, ``m >= n``.
    cphi_id : array_like, shape (ns, n)
        Identified modal observabilities.

    Returns
    -------
    index : ndarray of int, shape (n,)
        FE mode paired with each test mode.
    mac : ndarray, shape (n,)
        MAC of each pair.
    macs : ndarray, shape (m, n)
        The full MAC matrix.
    """
    from scipy.optimize import linear_sum_assignment

    macs = mac(cphi_fe, cphi_id)
    rows, cols = linear_sum_assignment(-macs)
    index = np.empty(macs.shape[1], int)
    index[cols] = rows
    return index, macs[index, np.arange(macs.shape[1])], macs
