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
paired FE mode takes the measured frequency and, for a pole in the band, the measured
damping ratio (the appended modes the test did not measure take the measured modes' mean
damping ratio, 5.1.1, "for modes that are not (or not accurately) measured"; so does a mode
the test holds as an out-of-band pole, fitted to a resonance's flank, whose damping the band
does not determine).  Shapes are left as they are.  On a held-out structure whose 24.5 Hz
mode the normal-mode step kept as residual dynamics (properness with the others), its
appended FE mode had carried the mean ratio 0.020 -- pulled up by one heavily damped mode,
0.10 -- where the test had measured 0.0053 (truth 0.0056); the untested shaker's prediction
rose 10.8x -> 11.98x better than the wrong FE.
"""

from __future__ import annotations

import numpy as np

from sdctrl.hybrids._expansion import PAIR_RATIO
from sdctrl.identification._mode_split import IMPROPER, OUT_OF_BAND

__all__ = ["measured_appended_poles", "out_of_band_candidates"]


def measured_appended_poles(nm, c, phi_fe, f_fe, appended_w2, mac_min: float,
                            out_of_band=()):
    """Measured ``omega^2`` and damping ratios of the appended FE modes the test kept as
    residual dynamics.

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
    out_of_band : sequence of int
        Indices in ``nm.residual.poles`` of out-of-band poles paired as well, after the
        in-band ones (the poles :func:`out_of_band_candidates` offers and the hybrid's
        ``residual="auto"`` kept, :mod:`sdctrl.hybrids._out_of_band`).

    Returns
    -------
    (ndarray, ndarray), each of shape (ka,)
        The measured ``omega^2`` (rad/s)^2 of each appended mode paired with such a test
        mode, and its measured damping ratio where the pole lies in the band (an
        out-of-band pole is fitted to a resonance's flank: its damping is not measured);
        NaN for the others.
    """
    w2 = np.full(np.shape(appended_w2), np.nan)
    zeta = w2.copy()
    for i, k, pole in _pairs(nm, c, phi_fe, f_fe, appended_w2, mac_min, tuple(out_of_band)):
        w2[k] = abs(pole) ** 2
        if nm.residual.reasons[i] != OUT_OF_BAND:
            zeta[k] = -pole.real / abs(pole)
    return w2, zeta


def out_of_band_candidates(nm, c, phi_fe, f_fe, appended_w2, mac_min: float) -> tuple:
    """Out-of-band poles of ``nm.residual`` that pair with an appended FE mode left free by
    the in-band ones (same rule: the residue's shape at the tested sensors, MAC at least
    ``mac_min``, within the pairing's frequency factor): ``(index in nm.residual.poles,
    FE frequency in Hz)`` per pole.

    Such a pole may be a mode just outside the band, measured through its flank, or a term
    that stands for several modes (3.7); which ones take their measured frequency is
    decided on the test itself (:mod:`sdctrl.hybrids._out_of_band`).
    """
    r = nm.residual
    if r is None:
        return ()
    every = tuple(i for i, why in enumerate(r.reasons) if why == OUT_OF_BAND)
    return tuple((i, float(np.sqrt(appended_w2[k]) / (2 * np.pi)))
                 for i, k, _ in _pairs(nm, c, phi_fe, f_fe, appended_w2, mac_min, every)
                 if r.reasons[i] == OUT_OF_BAND)


def _pairs(nm, c, phi_fe, f_fe, appended_w2, mac_min, out_of_band):
    """``(pole index, appended column, measured pole)`` of the residual poles paired
    with appended FE modes: the in-band ones first, then ``out_of_band``; each FE mode
    once."""
    r = nm.residual
    if r is None or not np.size(appended_w2) or (r.sensors is not None
                                                and tuple(r.sensors) != tuple(nm.sensors)):
        return []
    lam_fe = (2 * np.pi * np.asarray(f_fe)) ** 2
    # each appended column is an FE mode (same omega^2, 5.1.1)
    fe_of = np.array([int(np.argmin(np.abs(lam_fe - w2))) for w2 in appended_w2])
    cphi = c @ phi_fe[:, fe_of]
    order = [i for i, why in enumerate(r.reasons) if why not in (OUT_OF_BAND, IMPROPER)]
    order += [i for i in out_of_band if r.reasons[i] == OUT_OF_BAND]
    taken, found = np.zeros(np.size(appended_w2), bool), []
    for i in order:
        pole = r.poles[i]
        u = np.linalg.svd(np.asarray(r.residues[i]))[0][:, 0]
        mac = np.abs(u.conj() @ cphi) ** 2 / (
            np.vdot(u, u).real * np.maximum(np.sum(cphi ** 2, axis=0), 1e-300))
        f = abs(pole) / (2 * np.pi)
        mac[np.abs(np.log(np.sqrt(appended_w2) / (2 * np.pi) / f)) > np.log(PAIR_RATIO)] = 0
        mac[taken] = 0                                  # each FE mode once
        k = int(np.argmax(mac))
        if mac[k] >= mac_min:
            taken[k] = True
            found.append((i, k, complex(pole)))
    return found
