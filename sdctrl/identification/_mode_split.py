"""Which identified poles become normal modes, which stay residual dynamics, and why (3.3).

:func:`sdctrl.normal_modes` enforces properness (3.40)-(3.52) and applies the exact
transformation (3.44) to a set of poles; it is never all or nothing.  :func:`split_modes`
tries the candidate poles one by one (a pole that cannot be scaled at the collocated pairs
(3.24), lies out of double-precision reach or cannot be made proper on its own stays
residual), keeps at most ``ns`` of them (the reduced coordinates 3.46-3.47 hold ``ns``
modes), then the whole set.  When the set fails it leaves out the fewest poles that let the
others be made proper -- one, else two (:data:`LEAVE_OUT_MAX`), every removal of that many
tried -- and of those removals the one whose kept modes need the smallest correction
(``delta_radius`` of (3.51)-(3.54): the kept modes closest to a normal-mode set).  As a last
resort it adds the poles one at a time, best first.  Which poles go matters: measured against
the truth, the kept modes' ``cphi`` (mean relative error) on the family's truss tested with
one shaker at 1% (seed 2) is 0.130 (N33.x) and 0.351 (N41.y), the best single removal's 0.130
and 0.344, the former rule's (the least proper single mode, one of the close pair) 0.329 and
0.504; on a held-out structure with a close trio and two shakers it picked the most accurate
set on each of three variants.  The poles left over are kept as complex-mode residual dynamics
(:class:`~sdctrl.modal.ResidualDynamics`) with the reason of each and, when the model
carries statistics, the standard deviations of their poles and residues (3.56), (3.58).

:func:`improper_terms` keeps, at an in-band pole made a mode, the part of the identified
residue that the proper normal mode does not reproduce (identified residue minus the normal-mode
model's residue at that pole, 3.7 against 2.15), as a complex-mode term at the same pole --
where the thesis' assumption of section 3.3 (damping couples the identified modes only; 3.3.2,
"the assumption of normal mode decoupling from higher frequency modes may not be good enough")
is contradicted by the data: the identified model holds poles kept as residual dynamics
(dynamics outside the normal-mode set the in-band modes can couple to: out-of-band poles, or
an in-band pole whose properness cannot be enforced with the others) and the improper part
exceeds ``IMPROPER_SIGMAS`` standard deviations of the residue (3.58).  Each kept part adds
two states per dyad to the realisation (3.26-3.33).  Otherwise the improper part is
identification error or noise, and the proper modes are the better estimate.  Close modes
(:func:`~sdctrl.identification._close_modes.close_groups`) are judged together: the test
determines the sum of their residues better than each, and the properness correction trades
residue between them, so that keeping the improper part of one without the others upsets their
balance (the response between and away from their resonances, where their contributions nearly
cancel).  A group's improper parts are kept, all of them, when one is significant or when their
sum is, against the standard deviation of the group's summed residue (3.58, with the
covariances between the modes).

:func:`mode_selection` validates the ``modes=`` argument of :func:`sdctrl.normal_modes`.

Internal module: the functions trust their inputs (but :func:`mode_selection`).
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from sdctrl.identification._close_modes import close_groups, summed_residue_std
from sdctrl.identification._pole_statistics import part_std
from sdctrl.modal._residual_dynamics import ResidualDynamics

__all__ = ["IMPROPER", "IMPROPER_SIGMAS", "OUT_OF_BAND", "improper_terms", "modal_factors",
           "mode_selection", "residual_block", "residues_at", "split_modes"]

#: reason recorded for the poles fitted outside the band
OUT_OF_BAND = ("out of band: a pole fitted to absorb out-of-band modes (it may stand for "
               "several), not scaled as a mode by collocated residues it does not have")


#: reason recorded for the improper part of an in-band residue kept at its pole
IMPROPER = ("improper part: the identified residue minus the proper normal mode's at this pole "
            "(3.7 against 2.15), significant against the residue's standard deviation (3.58) "
            "with poles kept as residual dynamics the in-band modes may couple to (3.3)")

#: at most this many poles are left out together before the poles are added one at a time
#: (:func:`split_modes`): the removals of one pole, then of two, are tried exhaustively (a few
#: milliseconds each)
LEAVE_OUT_MAX = 2

#: an improper part is kept when its norm exceeds this many standard deviations of the residue
#: (norm of the per-entry standard deviations, 3.58): the usual three-sigma significance
IMPROPER_SIGMAS = 3.0


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
    for k in range(1, LEAVE_OUT_MAX + 1):
        best = _fewest_left_out(ok, k, attempt)
        if best is not None:
            for j in best:
                reasons[j] = (f"properness cannot be enforced with the other modes: {why}; "
                              f"of the {k}-pole removals that allow it, the one that needs "
                              "the smallest correction (3.54)")
            return np.array(sorted(set(ok) - set(best)), int), reasons
    kept = []
    for j in ok:
        _, fail = _try(attempt, sorted(kept + [j]))
        if fail is None:
            kept.append(j)
        else:
            reasons[j] = f"properness cannot be enforced with the other modes: {fail}"
    return np.array(sorted(kept), int), reasons


def _fewest_left_out(ok, k: int, attempt):
    """The ``k`` poles of ``ok`` whose removal lets the others be made proper; of all such
    removals, the one that needs the smallest properness correction (``delta_radius``,
    (3.51)-(3.54)): the kept modes closest to a normal-mode set.  ``None`` when no removal of
    ``k`` poles does."""
    best, radius = None, np.inf
    for out in itertools.combinations(ok, k):
        rest = sorted(set(ok) - set(out))
        nm = _try(attempt, rest)[0] if rest else None
        if nm is not None and nm.properness.delta_radius < radius:
            best, radius = out, nm.properness.delta_radius
    return best


def modal_factors(nm, poles):
    """``X`` (ns, k) and ``Y`` (n, k) with the residue (2.9) of the normal modes of ``nm`` at
    the pole matching ``poles[j]`` one to one (nearest) ``X[:, j] (Y[:, j]^T phib)``."""
    from scipy.optimize import linear_sum_assignment

    n = nm.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-nm.Omega, -nm.Gamma]])
    lam, V = np.linalg.eig(A)
    W = np.linalg.inv(V)
    up = np.flatnonzero(lam.imag > 0)
    _, col = linear_sum_assignment(np.abs(poles[:, None] - lam[up][None, :]))
    return (nm.cphi @ V[:n, up])[:, col], W[up, n:][col].T


def residues_at(nm, poles):
    """Residues (2.9) of the normal modes of ``nm`` at the tested I/O, at the poles matching
    ``poles`` one to one (nearest), shape (len(poles), ns, na)."""
    X, Y = modal_factors(nm, poles)
    return np.einsum("ij,jk->jik", X, Y.T @ nm.phib)


def improper_terms(cm, nm, sel, reasons: dict):
    """The significant improper parts of the residues of the poles ``sel`` made modes in ``nm``.

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model (its statistics give the residue standard deviations, 3.58).
    nm : NormalModeModel
        The normal-mode model of the poles ``sel``.
    sel : ndarray of int
        Poles of ``cm`` made normal modes, in the order of ``nm``'s construction.
    reasons : dict of int to str
        The poles kept as residual dynamics (out-of-band ones among them).

    Returns
    -------
    index : ndarray of int
        Poles of ``cm`` whose improper part is kept (sorted).
    residues : ndarray, shape (len(index), ns, na), complex
        ``R_j - R_nm(lambda_j)``, the identified residue minus the normal mode's (3.7, 2.15),
        kept where its norm exceeds ``IMPROPER_SIGMAS`` times the norm of the residue's
        standard deviations (3.58) -- for each group of close modes, at all of its modes when
        one of them, or the group's summed improper part against the summed residue's
        standard deviations, does.
    """
    sel = np.asarray(sel, int)
    none = np.zeros(0, int), np.zeros((0, cm.ns, cm.na), complex)
    if not reasons or cm.statistics is None or sel.size == 0:
        return none
    lam, R = np.asarray(cm.poles)[sel], np.asarray(cm.residues)[sel]
    D = R - residues_at(nm, lam)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        std = np.asarray(cm.residue_std())[sel]
    size = np.sqrt(np.sum(np.abs(D) ** 2, axis=(1, 2)))
    scale = np.sqrt(np.sum(std**2, axis=(1, 2)))
    keep = np.isfinite(scale) & (size > IMPROPER_SIGMAS * scale)
    group, shape = close_groups(lam), np.shape(cm.residues)
    for g in np.unique(group[group != np.arange(sel.size)]):            # groups of 2 or more
        m = group == g
        scale_m = np.linalg.norm(summed_residue_std(cm.statistics, sel[m], shape))
        keep[m] = keep[m].any() or np.linalg.norm(D[m].sum(axis=0)) > IMPROPER_SIGMAS * scale_m
    order = np.argsort(sel[keep])
    return sel[keep][order], D[keep][order]


def residual_block(cm, reasons: dict, improper=None) -> ResidualDynamics | None:
    """The poles of ``reasons`` as complex-mode residual dynamics of ``cm`` (3.7), or None.

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model.
    reasons : dict of int to str
        Index of each pole kept as residual dynamics and why.
    improper : (ndarray of int, ndarray), optional
        :func:`improper_terms`: poles of modes whose improper part is kept, and those parts;
        appended after the poles of ``reasons`` (reason :data:`IMPROPER`).

    Returns
    -------
    ResidualDynamics or None
    """
    idx = np.array(sorted(reasons), int)
    extra, D = improper if improper is not None else (np.zeros(0, int), None)
    if idx.size + extra.size == 0:
        return None
    kw = {}
    if cm.statistics is not None:                  # the uncertainty the test leaves (3.58)
        pole, res = part_std(cm.statistics, cm.poles, np.shape(cm.residues))
        # an improper part's pole is its mode's, whose uncertainty the modes carry (0 here)
        kw = {"pole_std": np.concatenate([pole[idx], np.zeros(extra.size, complex)]),
              "residue_std": np.concatenate([res[idx], res[extra]])}
    R = np.asarray(cm.residues)[idx]
    if extra.size:
        R = np.concatenate([R, D])
    return ResidualDynamics(np.asarray(cm.poles)[np.concatenate([idx, extra])], R,
                            sensors=cm.sensors, actuators=cm.actuators,
                            reasons=tuple(reasons[int(j)] for j in idx)
                            + (IMPROPER,) * extra.size, source=np.concatenate([idx, extra]),
                            **kw)


def mode_selection(modes, n: int) -> np.ndarray:
    """Validated integer indices of the selected modes (``modes`` indices or boolean mask)."""
    try:
        m = np.array(modes, copy=True)
    except (TypeError, ValueError) as exc:
        raise TypeError("modes must be an array of mode indices or a boolean mask") from exc
    if m.dtype == bool:
        if m.shape != (n,):
            raise ValueError(f"modes as a boolean mask must have {n} entries, got {m.shape}")
        idx = np.flatnonzero(m)
    elif m.ndim == 1 and (m.size == 0 or np.issubdtype(m.dtype, np.integer)):
        idx = m.astype(int)
        if np.any(idx < 0) or np.any(idx >= n):
            raise ValueError(f"modes: index out of range [0, {n})")
        if np.unique(idx).size != idx.size:
            raise ValueError("modes: repeated index")
    else:
        raise TypeError("modes must be a 1-D array of mode indices or a boolean mask")
    if idx.size == 0:
        raise ValueError("modes selects no mode")
    return idx
