"""Improper parts kept until the normal-mode model is as close to the identified model as the
identified model is to its data (3.3, 3.12).

:func:`~sdctrl.identification._mode_split.improper_terms` keeps, at an in-band pole made a
normal mode, the identified residue minus the proper mode's where that difference exceeds
three standard deviations of the residue (3.58) in norm.  The norm is the loud channels':
a difference of 1% of the loudest channel is far below that test, while on a channel a
thousand times quieter (a cross-axis response of a nearly symmetric structure) it is the
whole response.  The logLS cost (3.12), which judges the models, weighs every level alike,
and there the normal modes of a structure with a dashpot may miss the identified model by
several times the identified model's own error against the data (3.75x on a held-out
structure at 1% noise, 4.4x on the family's truss over 20-60 Hz).

So a second rule (:func:`closer_parts`): the improper parts that are significant entry by
entry (the root mean square of ``|D| / std(R)`` over the tested I/O above
:data:`~sdctrl.identification._mode_split.IMPROPER_SIGMAS`: the same three-sigma test in
whitened units) are candidates; while the normal-mode model's logLS against the identified
model, on the identification's lines, exceeds the identified model's against its data
(``cm.search.logls``), the candidate that removes the most of it is kept (close modes
together, :func:`~sdctrl.identification._close_modes.close_groups`).  Closer than that would
reproduce the identified model more precisely than it reproduces the test, and each part
costs two states per dyad of its residue.  A model without that record (built from matrices,
read from an older file) keeps the first rule alone.  Both rules apply where some pole is kept
as residual dynamics -- out of band, or in band with its properness failed (the in-band
modes may couple to either, 3.3); with none, the improper parts are identification error.
Keyed on out-of-band poles alone, they kept nothing on the family's cluster tested over 8-30
Hz at 1% (seed 1: no out-of-band pole found, the 10.29 Hz blade mode left residual as the
identified mass was not positive definite) and the normal modes missed the data by 1.16
mean logLS against the identified model's 0.099 (11.7x); 0.099 since (1.00x).

Internal module: the functions trust their inputs.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl.identification._close_modes import close_groups
from sdctrl.identification._complex_modes import frf_array
from sdctrl.identification._mode_split import IMPROPER_SIGMAS, residues_at
from sdctrl.identification._quality import mean_logls

__all__ = ["closer_parts"]


def _terms(poles, residues, s) -> np.ndarray:
    """Displacement FRF (nf, ns, na) of complex-mode terms (3.7) at ``s``."""
    zero = np.zeros(np.shape(residues)[1:])
    return frf_array(np.asarray(poles), np.asarray(residues), zero, None, s)


def closer_parts(cm, nm, sel, reasons: dict, improper):
    """The improper parts of :func:`~sdctrl.identification._mode_split.improper_terms`
    (``improper``) and those the logLS rule of the module notes adds.

    Parameters
    ----------
    cm : ComplexModeModel
        The identified model (its ``search.logls``, ``search.lines``, ``band``, statistics).
    nm : NormalModeModel
        Its normal modes (poles ``sel``), without residual dynamics.
    sel : ndarray of int
        Poles of ``cm`` made normal modes.
    reasons : dict of int to str
        The poles kept as residual dynamics.
    improper : (ndarray of int, ndarray)
        The parts kept by the first rule: poles of ``cm`` and residues.

    Returns
    -------
    (ndarray of int, ndarray)
        Poles (sorted) and their improper parts ``R_j - R_nm(lambda_j)``.
    """
    search = cm.search
    target = None if search is None else search.logls
    if target is None or not search.lines or cm.band is None or cm.statistics is None \
            or not reasons:
        return improper
    sel = np.asarray(sel, int)
    idx, D0 = improper
    free = sel[~np.isin(sel, idx)]
    if free.size == 0:
        return improper
    lines = np.linspace(cm.band[0], cm.band[1], int(search.lines))
    s = 2j * np.pi * lines
    ref = cm.frf(lines).H
    res = np.array(sorted(reasons), int)
    cur = nm.frf(lines).H + _terms(np.asarray(cm.poles)[res], np.asarray(cm.residues)[res], s) \
        + _terms(np.asarray(cm.poles)[idx], D0, s)
    lam = np.asarray(cm.poles)[free]
    D = np.asarray(cm.residues)[free] - residues_at(nm, lam)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        std = np.asarray(cm.residue_std())[free]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.sqrt(np.mean(np.abs(D) ** 2 / std**2, axis=(1, 2)))
    group = close_groups(lam)
    cand = {g: np.flatnonzero(group == g) for g in np.unique(group)
            if np.any(np.nan_to_num(z[group == g], nan=np.inf) > IMPROPER_SIGMAS)}
    terms = {g: _terms(lam[m], D[m], s) for g, m in cand.items()}
    added, err = [], mean_logls(cur, ref)
    while err > target and terms:
        trial = {g: mean_logls(cur + t, ref) for g, t in terms.items()}
        g = min(trial, key=trial.get)
        if trial[g] >= err:
            break
        cur, err = cur + terms.pop(g), trial[g]
        added.extend(cand[g].tolist())
    if not added:
        return improper
    index = np.concatenate([idx, free[added]])
    parts = np.concatenate([D0, D[added]])
    order = np.argsort(index)
    return index[order], parts[order]
