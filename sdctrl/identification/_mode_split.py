"""Which identified poles become normal modes, which stay residual dynamics, and why (3.3).

:func:`sdctrl.normal_modes` enforces properness (3.40)-(3.52) and applies the exact
transformation (3.44) to a set of poles; it is never all or nothing.  :func:`split_modes`
tries the candidate poles one by one (a pole that cannot be scaled at the collocated pairs
(3.24), lies out of double-precision reach or cannot be made proper on its own stays
residual), keeps at most ``ns`` of them (the reduced coordinates 3.46-3.47 hold ``ns``
modes), then the whole set; when the set fails it leaves out the one pole whose removal
makes it succeed (worst single-mode properness first), and as a last resort adds the poles
one at a time, best first.  The poles left over are kept as complex-mode residual dynamics
(:class:`~sdctrl.modal.ResidualDynamics`) with the reason of each and, when the model
carries statistics, the standard deviations of their poles and residues (3.56), (3.58).

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl.identification._pole_statistics import part_std
from sdctrl.modal._residual_dynamics import ResidualDynamics

__all__ = ["OUT_OF_BAND", "residual_block", "split_modes"]

#: reason recorded for the poles fitted outside the band
OUT_OF_BAND = ("out of band: a pole fitted to absorb out-of-band modes (it may stand for "
               "several), not scaled as a mode by collocated residues it does not have")


def _try(attempt, sel):
    """``(model, None)`` when ``attempt(sel)`` succeeds, else ``(None, reason)``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return attempt(np.asarray(sel, int)), None
        except (ValueError, np.linalg.LinAlgError) as exc:
            return None, str(exc)


def split_modes(candidates, ns: int, attempt):
    """Split ``candidates`` into poles that become normal modes and poles that stay residual.

    Parameters
    ----------
    candidates : ndarray of int
        Indices of the poles to turn into normal modes.
    ns : int
        Number of sensors (at most ``ns`` modes, 3.46).
    attempt : callable
        ``attempt(indices) -> NormalModeModel`` (without statistics); raises ``ValueError``
        when the transformation fails on that set.

    Returns
    -------
    modes : ndarray of int
        Sorted indices of the poles that become normal modes.
    reasons : dict of int to str
        Why each other candidate stays residual.
    """
    reasons, quality = {}, {}
    for j in candidates:
        nm, why = _try(attempt, [j])
        if nm is None:
            reasons[int(j)] = f"cannot be a normal mode on its own: {why}"
        else:
            quality[int(j)] = float(nm.properness.properness_before)
    order = sorted(quality, key=quality.get)                    # most nearly proper first
    for j in order[ns:]:
        reasons[j] = (f"fewer sensors ({ns}) than modes: the reduced coordinates (3.46)-"
                      "(3.47) hold at most ns modes; this one is the least proper")
    ok = order[:ns]
    if not ok:
        return np.zeros(0, int), reasons
    nm, why = _try(attempt, sorted(ok))
    if nm is not None:
        return np.array(sorted(ok), int), reasons
    for j in reversed(ok):                                      # least proper first
        rest = [i for i in ok if i != j]
        if rest and _try(attempt, sorted(rest))[0] is not None:
            reasons[j] = f"properness cannot be enforced with the other modes: {why}"
            return np.array(sorted(rest), int), reasons
    kept = []
    for j in ok:
        _, fail = _try(attempt, sorted(kept + [j]))
        if fail is None:
            kept.append(j)
        else:
            reasons[j] = f"properness cannot be enforced with the other modes: {fail}"
    return np.array(sorted(kept), int), reasons


def residual_block(cm, reasons: dict) -> ResidualDynamics | None:
    """The poles of ``reasons`` as complex-mode residual dynamics of ``cm`` (3.7), or None.

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.
    reasons : dict of int to str
        Index of each pole kept as residual dynamics and why.

    Returns
    -------
    ResidualDynamics or None
    """
    idx = np.array(sorted(reasons), int)
    if idx.size == 0:
        return None
    kw = {}
    if cm.statistics is not None:                  # the uncertainty the test leaves (3.58)
        pole, res = part_std(cm.statistics, np.shape(cm.residues))
        kw = {"pole_std": pole[idx], "residue_std": res[idx]}
    return ResidualDynamics(np.asarray(cm.poles)[idx], np.asarray(cm.residues)[idx],
                            sensors=cm.sensors, actuators=cm.actuators,
                            reasons=tuple(reasons[int(j)] for j in idx), source=idx, **kw)
