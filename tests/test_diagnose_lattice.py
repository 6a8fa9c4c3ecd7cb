"""sd.diagnose names the right bar of a lattice (issue 23).

On the scalable lattice plate (``sd.testbeds.lattice``), a 30% loss of the axial stiffness of
one bar of the layer away from the sensors (the bench's 10^4-DOF case named its neighbour on
the sensors' layer: the screen projects each candidate's own flexibility on the static
corrections of the tested DOFs, which miss most of it for a bar far from them, so the planted
bar ranked 14th of 16,474 and was never fitted; its exact error was 7.7e-10, the neighbour's
2.1e-7).  The model is the lattice's reduced model (modes below 3 x the band top + static
correction modes of the shakers), the data the same reduction of the perturbed FE model with
the static correction of the bar's load path, 600 lines.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.diagnosis._candidates import _axial_stiffness
from sdctrl.testbeds._measurement_noise import relative_noise

DOFS = 1500


@functools.cache
def case():
    """(model, fe, noise-free data, bar, dk)."""
    s = sd.testbeds.lattice(DOFS)
    fe = s.fe()
    f, phi = fe.modes(40)
    n = int(np.sum(f < 3 * s.band[1]))
    B = fe.point(list(s.shakers))
    acts = list(s.shakers)
    model = fe.normal_mode_model(B, list(s.sensors), n, static=True,
                                 static_damping="projected", actuators=acts)
    # the bar: of the most visible quarter of the far layer's bars (first-order damping
    # added to an in-band mode per unit dashpot), the farthest from the sensors
    inb = (f > s.band[0]) & (f < s.band[1])
    w = 2 * np.pi * f[inb]
    layer = {n_[-2:] for n_ in (lab.split(".")[0] for lab in s.sensors)}
    dofs = set(fe.dofs)
    els = [e for e in fe.elements if all(f"{n_}.{a}" in dofs for n_ in e for a in "xyz")
           and not any(n_[-2:] in layer for n_ in e)]
    eff = np.array([np.max((fe.strut(a, b).T @ phi[:, inb])[0] ** 2 / (2 * w))
                    for a, b in els])
    sens = np.array([fe.nodes[lab.split(".")[0]] for lab in s.sensors])
    dist = np.array([min(np.linalg.norm(sens - np.asarray(fe.nodes[x]), axis=1).min()
                         for x in e) for e in els])
    vis = np.flatnonzero(eff >= np.quantile(eff, 0.75))
    bar = tuple(els[int(vis[np.argmax(dist[vis])])])
    b = fe.strut(*bar)
    dk = -0.3 * _axial_stiffness(fe)[frozenset(bar)]
    fe2 = sd.FEModel(fe.M, fe.K + sp.csr_matrix(dk * (b @ b.T)), fe.C, dofs=fe.dofs,
                     nodes=dict(fe.nodes), elements=fe.elements, assembly=fe.assembly)
    freq = np.linspace(*s.band, 600)
    data = fe2.normal_mode_model(np.hstack([B, b]), list(s.sensors), n, static=True,
                                 static_damping="projected", actuators=acts + ["bar"]
                                 ).frf(freq, "acceleration").select(actuators=acts)
    return model, fe, data, bar, dk


def _diagnose(data):
    model, fe, *_ = case()
    return sd.diagnose(model, data, fe, reach=1e-9, max_effects=1, progress=False)


def test_lattice_bar_named_exactly_with_and_without_noise():
    """The planted bar exactly, dk within 3% noise-free (error / 30, the runner-up's exact
    error far above) and 10% at 1% noise, the truth within 3 std."""
    _, _, data, bar, dk = case()
    clean = _diagnose(data)
    e = clean.effects[0]
    assert (e.kind, set(e.location)) == ("stiffness_change", set(bar))
    assert e.parameters["dk"] == pytest.approx(dk, rel=0.03)
    assert e.parameters["relative"] == pytest.approx(-0.3, rel=0.03)
    assert clean.error_after <= clean.error_before / 30
    top, second = clean.steps[0]["candidates"][:2]
    assert second["cost"] > 30 * top["cost"]                # not indistinguishable
    bias = abs(e.parameters["dk"] - dk)
    assert bias <= 5e-3 * abs(dk)
    noisy = sd.FRF(data.freq, relative_noise(data.H, 0.01, 0), quantity=data.quantity,
                   sensors=data.sensors, actuators=data.actuators)
    d = _diagnose(noisy)
    e = d.effects[0]
    assert (e.kind, set(e.location)) == ("stiffness_change", set(bar))
    assert e.parameters["dk"] == pytest.approx(dk, rel=0.10)
    assert 0 < e.std["dk"] and abs(e.parameters["dk"] - dk) <= 3 * e.std["dk"] + bias
    assert d.noise == pytest.approx(1e-4, rel=0.05)
