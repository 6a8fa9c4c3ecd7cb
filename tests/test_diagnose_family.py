"""sd.diagnose over the family of test structures (issue 23): any structure, several effects
at once, nothing invented.

Each member's true FE model is the nominal model's source (``sd.testbeds.structure(name).fe()``,
reduced to its modes below 5 x the band top with static correction modes of the shakers,
projected damping).  Effects are planted on a copy of that FE model -- a dashpot along an
element, a point mass at a node, an axial spring change along an element (``dk b b^T`` with
``b`` the element's strut shape, what API.md calls ``dk``), a measurement delay -- and the
test is the same reduction of the perturbed model with the static correction of the change's
own load path (as tests/test_diagnose.py).  A missing in-band mode is the nominal model
with one of its in-band modes removed (proportional damping: the mode is uncoupled), the data
being the complete model's.  Every case runs on 220 lines of the member's band.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.diagnosis._candidates import _axial_stiffness

N_LINES = 220


@functools.cache
def member(name):
    """(structure, true FE, number of modes, lines (Hz))."""
    s = sd.testbeds.structure(name)
    fe = s.fe()
    f, _ = fe.modes(min(80, fe.N - 1))
    return s, fe, int(np.sum(f < 5 * s.band[1])), np.linspace(*s.band, N_LINES)


def _reduced(name, fe, extra=None, proportional=False):
    s, _, n, _ = member(name)
    B = fe.point(list(s.shakers))
    acts = list(s.shakers)
    if extra is not None:
        B = np.hstack([B, extra])
        acts += [f"extra{i}" for i in range(extra.shape[1])]
    nm = fe.normal_mode_model(B, list(s.sensors), n, static=True,
                              static_damping="projected", actuators=acts)
    if proportional:
        nm = nm.replace(Gamma=np.diag(np.diag(nm.Gamma)))
    return nm


@functools.cache
def nominal(name, proportional=False):
    return _reduced(name, member(name)[1], proportional=proportional)


def _copy(fe, dM=0, dK=0, dC=0):
    return sd.FEModel(fe.M + dM, fe.K + dK, fe.C + dC, dofs=fe.dofs, nodes=dict(fe.nodes),
                      elements=fe.elements, assembly=fe.assembly)


def axial(name, pair):
    """``EA/L`` of an element (N/m)."""
    return _axial_stiffness(member(name)[1])[frozenset(pair)]


def _modal(name):
    """(frequencies rad/s, damping ratios, shapes on FE DOFs) of the nominal in-band modes."""
    s, fe, _, _ = member(name)
    nm = nominal(name, True)
    w = np.sqrt(np.diag(nm.Omega))
    z = np.diag(nm.Gamma) / (2 * w)
    ok = (w / (2 * np.pi) > s.band[0]) & (w / (2 * np.pi) < s.band[1])
    return w[ok], z[ok], np.asarray(nm.shapes)[:, ok]


def sizes(name, kind, where, target):
    """The size that makes the largest first-order change of an in-band mode ``target``: an
    added damping ratio (dashpot), a relative frequency shift (mass, spring)."""
    _, fe, _, _ = member(name)
    w, _, phi = _modal(name)
    if kind == "mass_change":
        P = fe.point([f"{where}.{a}" for a in "xyz"])
        return target / np.max(0.5 * np.sum((P.T @ phi) ** 2, axis=0))
    b = fe.strut(*where)
    q = (b.T @ phi)[0] ** 2
    if kind == "added_damper":
        return target / np.max(q / (2 * w))
    return target / np.max(0.5 * q / w**2)


def in_band_mode(name, which):
    """Index of the ``which``-th mode of the nominal model inside the band (not too close to
    the edges: 3 half-power bandwidths)."""
    s, _, _, _ = member(name)
    nm = nominal(name, True)
    w = np.sqrt(np.diag(nm.Omega))
    f = w / (2 * np.pi)
    z = np.diag(nm.Gamma) / (2 * w)
    ok = np.flatnonzero((f > s.band[0] * (1 + 6 * z)) & (f < s.band[1] * (1 - 6 * z)))
    return int(ok[which])


def _without_mode(nm, j):
    keep = np.arange(nm.n) != j
    return nm.replace(Omega=nm.Omega[np.ix_(keep, keep)], Gamma=nm.Gamma[np.ix_(keep, keep)],
                      cphi=nm.cphi[:, keep], phib=nm.phib[keep],
                      shapes=None if nm.shapes is None else nm.shapes[:, keep])


def planted(name, effects):
    """(model, noise-free data) with the effects ``(kind, where, size)`` planted."""
    s, fe, _, freq = member(name)
    dM = dK = dC = 0
    extra, tau, model = [], 0.0, nominal(name)
    for kind, where, size in effects:
        if kind == "added_damper":
            b = fe.strut(*where)
            dC = dC + sp.csr_matrix(size * (b @ b.T))
            extra.append(b)
        elif kind == "mass_change":
            P = fe.point([f"{where}.{a}" for a in "xyz"])
            dM = dM + sp.csr_matrix(size * (P @ P.T))
            extra.append(P)
        elif kind == "stiffness_change":                      # size: dk (N/m)
            b = fe.strut(*where)
            dK = dK + sp.csr_matrix(size * (b @ b.T))
            extra.append(b)
        elif kind == "delay":
            tau += size
        elif kind == "missing_mode":                           # where: the mode index
            model = nominal(name, True)
    if any(k == "missing_mode" for k, _, _ in effects):
        j = effects[0][1]
        data = model.frf(freq, "acceleration")
        model = _without_mode(model, j)
    elif extra:
        data = _reduced(name, _copy(fe, dM, dK, dC), np.hstack(extra)).frf(
            freq, "acceleration").select(actuators=list(s.shakers))
    else:
        data = model.frf(freq, "acceleration")
    if tau:
        data = sd.FRF(freq, data.H * np.exp(-2j * np.pi * freq * tau)[:, None, None],
                      quantity="acceleration", sensors=data.sensors, actuators=data.actuators)
    return model, data


def noisy(frf, level=0.01, seed=0):
    """``H (1 + level e)``, ``e`` complex standard normal."""
    rng = np.random.default_rng(seed)
    e = (rng.standard_normal(frf.H.shape) + 1j * rng.standard_normal(frf.H.shape)) / np.sqrt(2)
    return sd.FRF(frf.freq, frf.H * (1 + level * e), quantity=frf.quantity,
                  sensors=frf.sensors, actuators=frf.actuators)


@functools.cache
def diagnosis(name, effects, noise=0.0, seed=0, max_effects=3):
    model, data = planted(name, effects)
    if noise:
        data = noisy(data, noise, seed)
    return sd.diagnose(model, data, member(name)[1], max_effects=max_effects, progress=False)
