"""Where to put a D-strut? A hybrid test/FE model, a placement study and the RMS gain.

The workflow of thesis chapter V.1 for a control engineer:

1. the modal test gives the normal modes of the 8-60 Hz band at the test sensors (here
   made from the built-in testbed, standing for the lab structure; with real data use
   ``sd.normal_modes(sd.identify(frf), collocated)``);
2. the analyst's FE model is not exact (here: plate masses 10% heavy, a softened bay);
3. ``sd.hybrid`` keeps the measured frequencies and damping, expands the measured shapes
   onto the FE DOFs (4.7) and appends FE modes outside the band (5.1);
4. ``sd.placement_study`` closes a D-strut ``F = -kv y'`` on every truss bar (5.3-5.4) and
   ranks the bars by the band-limited RMS reduction of the plate sensors;
5. the best strut is closed on the hybrid model (``with_feedback``, the one route to a
   D-strut), its StateSpace keeps the sensor names, and the RMS before/after is printed,
   checked against the exact FE solution of the lab structure, and locked in an RMS
   snapshot (``sdctrl.testing``).

Usage: ``python damper_placement.py [outdir]`` (a Bode plot and the snapshot JSON are
written to ``outdir`` when given).  Runs headless in a few seconds.
"""
import os
import pathlib
import sys

import numpy as np
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.testbeds import SENSORS, SHAKERS, TESTBED_BAND
from sdctrl.testing import record_rms

BAND = TESTBED_BAND                      # 8-60 Hz
KV = 4e4                                 # D-strut dashpot, N s/m
PSD = 1.0                                # disturbance force PSD on each shaker, N^2/Hz
OUTPUTS = [s for s in SENSORS if s.startswith(("N32", "N33", "N34", "N35",      # plate A
                                               "N39", "N40", "N41", "N42"))]    # plate B
quiet = bool(os.environ.get("SDCTRL_QUIET"))

# 1. the lab structure and its "identified" in-band normal modes (31 sensors, 6 shakers)
lab = sd.testbed()
full = lab.normal_mode_model(list(SHAKERS), list(SENSORS), 20)
band_modes = np.flatnonzero((full.frequency > BAND[0]) & (full.frequency < BAND[1]))
ix = np.ix_(band_modes, band_modes)
measured = sd.NormalModeModel(full.Omega[ix], full.Gamma[ix], full.cphi[:, band_modes],
                              full.phib[band_modes], sensors=full.sensors,
                              actuators=full.actuators)

# 2. the analyst's FE model: heavier plates, one truss bay 30% softer
d = np.zeros(lab.N)
for node in ("N31", "N38", "N45"):
    d[lab.dof_index([f"{node}.{ax}" for ax in "xyz"])] = 0.6
dK = sp.csr_matrix((lab.N, lab.N))
k_longeron = 70e9 * np.pi * (0.025**2 - 0.022**2) / 4 / 0.5
for a, b in (("N9", "N13"), ("N10", "N14"), ("N11", "N15"), ("N12", "N16")):
    s = lab.strut(a, b)
    dK = dK - 0.3 * k_longeron * sp.csr_matrix(s @ s.T)
fe = sd.FEModel(lab.M + sp.diags(d), lab.K + dK, lab.C, dofs=lab.dofs,
                nodes=dict(lab.nodes), elements=lab.elements)

# 3. hybrid model
h = sd.hybrid(fe, measured, list(SENSORS), list(SHAKERS))
pair = h.construction.pairing
print(f"hybrid model: {h.n} modes ({int(h.measured.sum())} measured, "
      f"{int(np.sum(h.kind == 'fe'))} FE); FE/test MAC "
      f"{pair.mac.min():.3f}-{pair.mac.max():.3f}, FE frequency errors up to "
      f"{100 * np.abs(pair.fe_hz / pair.test_hz - 1).max():.1f} %")

# 4. placement study over the truss bars
truss = [e for e in fe.elements if max(int(e[0][1:]), int(e[1][1:])) <= 28]
study = sd.placement_study(h, fe, BAND, kv=KV, candidates=truss, outputs=OUTPUTS, psd=PSD,
                        progress=not quiet)
print(f"\nD-strut kv = {KV:g} N s/m on each of {len(truss)} truss bars, "
      f"RMS of {len(OUTPUTS)} plate sensors in {BAND[0]:g}-{BAND[1]:g} Hz:")
print(study.table(5))
bar = study.best.bar

# 5. close the best strut on the hybrid model and compare RMS before/after
s = fe.strut(*bar)
closed_model = h.with_feedback(s, s.T, kv=KV)             # + the strut's static correction
plant, closed = h.to_statespace(), closed_model.to_statespace()
out_idx = [list(h.sensors).index(o) for o in OUTPUTS]    # rms: one value per sensor
assert closed.output_labels == plant.output_labels        # the loop keeps every name
before = sd.rms(plant, BAND, PSD)[out_idx]
after = sd.rms(closed, BAND, PSD)[out_idx]
# exact FE solution of the lab structure (all its modes) with the dashpot added to C
s_lab = lab.strut(*bar)
lab_strut = sd.FEModel(lab.M, lab.K, lab.C + KV * s_lab @ s_lab.T, dofs=lab.dofs)
exact_before = sd.rms(lab.normal_mode_model(list(SHAKERS), OUTPUTS, lab.N), BAND, PSD)
exact_after = sd.rms(lab_strut.normal_mode_model(list(SHAKERS), OUTPUTS, lab.N), BAND, PSD)
print(f"\nbest bar {bar[0]}-{bar[1]}: plate-sensor RMS (um), hybrid prediction vs lab FE")
print(f"{'sensor':>8} {'before':>9} {'after':>9} {'lab before':>11} {'lab after':>10}")
for o, b0, a0, b1, a1 in zip(OUTPUTS, before, after, exact_before, exact_after):
    print(f"{o:>8} {1e6 * b0:9.3f} {1e6 * a0:9.3f} {1e6 * b1:11.3f} {1e6 * a1:10.3f}")
gain = 1 - np.linalg.norm(after) / np.linalg.norm(before)
gain_lab = 1 - np.linalg.norm(exact_after) / np.linalg.norm(exact_before)
print(f"overall RMS reduction: {100 * gain:.1f} % predicted, {100 * gain_lab:.1f} % on the lab "
      "structure")
# the hybrid (like any truncated modal model) misses the residual flexibility of the modes
# above its range at the strut, so it slightly overestimates the strut's effect (5.1.2)
f_cl, z_cl = sd.closedloop.modal_damping(closed_model, BAND)
print("closed-loop damping in band (%):", np.round(100 * z_cl, 2))
assert gain > 0 and abs(gain - gain_lab) < 0.05

if len(sys.argv) > 1:
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    snap = record_rms(closed[out_idx, :], BAND, PSD, out / "dstrut_rms.json",
                      name=f"D-strut {bar[0]}-{bar[1]}", note="examples/damper_placement.py")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = np.linspace(*BAND, 1500)
    j = out_idx[0]
    H0 = np.abs(plant[j, 0](2j * np.pi * f))
    H1 = np.abs(closed[j, 0](2j * np.pi * f))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogy(f, H0, label="open loop")
    ax.semilogy(f, H1, label=f"D-strut on {bar[0]}-{bar[1]}")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|{OUTPUTS[0]} / {SHAKERS[0]}| (m/N)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "damper_placement.png", dpi=100)
    print(f"wrote {out / 'damper_placement.png'} and {out / 'dstrut_rms.json'}")
