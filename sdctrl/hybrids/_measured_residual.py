"""Appended FE modes that the test measured as residual dynamics (thesis 5.1.1, beyond it).

The normal-mode step keeps an in-band mode as a complex mode when it cannot be made a normal
mode (its collocated residues do not scale it, 3.45; properness cannot be enforced with the
other modes, 3.52): the mode is in the test, with its pole, but not among the hybrid's
measured modes.  Its FE mode is then appended (5.1.1) with the FE frequency times ``kappa``,
the median measured/FE ratio of the paired modes -- the FE's *global* error.  Where the FE's
error is local (one component's stiffness, as the family's wrong models have), a mode that
does not involve that component has its FE frequency about right and ``kappa`` moves it off:
a tail mode seen only by the shaker a fold leaves out, 27.52 Hz in the FE, was appended at
30.8 Hz while the test had measured it at 27.53 Hz.

Rule: such a test mode is paired, by its shape at the tested sensors (the dominant left
singular vector of its residue, ``c psi`` of 3.20-3.22), with the appended FE mode of
highest MAC, within the pairing's frequency factor and at the pairing's MAC threshold; the
paired FE mode takes the measured frequency.  Shapes and damping are left as they are.
"""

from __future__ import annotations

import numpy as np

from sdctrl.hybrids._expansion import PAIR_RATIO
from sdctrl.identification._mode_split import IMPROPER, OUT_OF_BAND

__all__ = ["measured_appended_w2"]


def measured_appended_w2(nm, c, phi_fe, f_fe, appended_w2, mac_min: float):
    """Measured ``omega^2`` of the appended FE modes the test kept as residual dynamics.

    Parameters
    ----------
    nm : NormalModeModel
        The identified model; its ``residual`` holds the complex modes with their reasons.
    c : ndarray, shape (ns, N)
        Test sensors on the FE DOFs (rows in ``nm.sensors`` order).
    phi_fe : ndarray, shape (N, m)
        FE modes up to ``fmax``.
    f_fe : ndarray, shape (m,)
        Their frequencies (Hz).
    appended_w2 : ndarray, shape (ka,)
        FE ``omega^2`` of the appended modes (before ``kappa``).
    mac_min : float
        MAC threshold of the pairing.

    Returns
    -------
    ndarray, shape (ka,)
        The measured ``omega^2`` (rad/s)^2 of each appended mode paired with such a test
        mode, NaN for the others.
    """
    out = np.full(np.shape(appended_w2), np.nan)
    r = nm.residual
    if r is None or not out.size or (r.sensors is not None
                                     and tuple(r.sensors) != tuple(nm.sensors)):
        return out
    lam_fe = (2 * np.pi * np.asarray(f_fe)) ** 2
    # each appended column is an FE mode (same omega^2, 5.1.1)
    fe_of = np.array([int(np.argmin(np.abs(lam_fe - w2))) for w2 in appended_w2])
    cphi = c @ phi_fe[:, fe_of]
    for pole, R, why in zip(r.poles, r.residues, r.reasons):
        if why in (OUT_OF_BAND, IMPROPER):
            continue
        u = np.linalg.svd(np.asarray(R))[0][:, 0]
        mac = np.abs(u.conj() @ cphi) ** 2 / (
            np.vdot(u, u).real * np.maximum(np.sum(cphi ** 2, axis=0), 1e-300))
        f = abs(pole) / (2 * np.pi)
        mac[np.abs(np.log(np.sqrt(appended_w2) / (2 * np.pi) / f)) > np.log(PAIR_RATIO)] = 0
        mac[~np.isnan(out)] = 0                        # each FE mode once
        k = int(np.argmax(mac))
        if mac[k] >= mac_min:
            out[k] = abs(pole) ** 2
    return out
