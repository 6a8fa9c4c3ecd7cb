"""Diagnose an undeclared effect: the model no longer matches a new test -- what changed?

The built-in testbed was modelled and validated (its FE model is right).  Months later it
is tested again, and in between a bolted joint at one end of a truss longeron
(``N14``-``N18``) worked loose: the bar has lost half its axial stiffness.  Nobody
declared it.  ``sd.diagnose(model, frf, fe=fe)`` traces the misfit between the model and
the new test to the effects the model lacks -- it scans candidate mass, stiffness and
damper changes on the FE model's own nodes and elements, missing modes, residual terms
and delays -- fits the size of the best ones in SI units and applies them, with the
logLS error (3.12) before and after.

The example checks the diagnosis against the truth: the first effect is a stiffness
change on that element, of the planted size, and the error falls more than tenfold.
Usage: ``python diagnose_effect.py [outdir]`` (the report and a figure are written to
``outdir`` when given).  The candidate scan accepts ``executor=`` (any
``concurrent.futures.Executor``, a Dask client's included).
"""
import pathlib
import sys

import numpy as np

import sdctrl as sd
from sdctrl.testbeds import SENSORS, SHAKERS, TESTBED_BAND

out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else None
BAR = ("N14", "N18")                                   # the longeron whose joint worked loose
EA_L = 70e9 * np.pi * (0.025**2 - 0.022**2) / 4 / 0.5   # its axial stiffness (N/m)
DK = -0.5 * EA_L                                       # half of it lost

# the validated model: the FE model's modes on the test's sensors and shakers
fe = sd.testbed()
model = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 40, static=True)

# the new test, on the changed structure (simulated here: 1% noise)
s = fe.strut(*BAR)                                     # unit axial load shape of the bar
lab = sd.FEModel(fe.M, fe.K + DK * (s @ s.T), fe.C, dofs=fe.dofs, nodes=dict(fe.nodes),
                 elements=fe.elements)
freq = np.linspace(*TESTBED_BAND, 1000)
H = lab.normal_mode_model(list(SHAKERS), list(SENSORS), 40, static=True).frf(
    freq, "acceleration").H
rng = np.random.default_rng(1)
H = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / 2**0.5)
retest = sd.FRF(freq, H, "acceleration", sensors=list(SENSORS), actuators=list(SHAKERS),
                collocated=[(i, i) for i in range(len(SHAKERS))])

d = sd.diagnose(model, retest, fe=fe)
print(d.report())
top = d.effects[0]
print(f"first effect: {top.kind} at {top.location} {top.parameters}")
print(f"planted:      stiffness_change at {BAR} {{'dk': {DK:.4g}}}")
print(f"logLS error {d.error_before:.3g} -> {d.error_after:.3g} "
      f"({d.error_before / d.error_after:.0f} times smaller)")
assert top.kind == "stiffness_change"
assert set(top.location) == set(BAR)
assert abs(top.parameters["dk"] / DK - 1) < 0.1
assert d.error_after < d.error_before / 10

if out is not None:
    import matplotlib

    matplotlib.use("Agg")
    (out / "diagnosis.md").write_text(d.report())
    sd.plot.bode([retest, model, d.model], labels=["new test", "model", "model + diagnosis"],
                 channels=[("N32.z", "N32.z"), ("N41.y", "N41.y")], path=out / "diagnosis.png")
    print(f"wrote the report and figure to {out}")
