"""Identify a vibration test: complex modes with no initial guess, then normal modes.

The workflow of thesis chapter III for a control engineer with a modal test:

1. the measured FRFs come as a UFF file (dataset 58; here the built-in testbed's simulated
   acceleration test, 31 sensors x 6 shakers, 8-60 Hz, 1% noise, written then read back);
2. ``sd.identify`` finds the poles with no initial guess (stabilisation over model orders,
   then a logLS fit of all channels with common poles, 3.2.1) and the residues;
3. ``sd.normal_modes`` scales the complex modes by the collocated pairs, enforces
   properness (3.52) and transforms them exactly to normal modes with a full damping
   matrix (3.44): the 15.6/16.0 Hz pair is coupled by a dashpot;
4. the model becomes a python-control ``StateSpace`` with signals named after the labels.

Each number is checked against the testbed's exact poles.  Usage:
``python identify_test.py [outdir]`` (figures are written to ``outdir`` when given).
"""
import os
import pathlib
import sys
import tempfile

import numpy as np

import sdctrl as sd
from sdctrl.testbeds import SENSORS, SHAKERS, TESTBED_BAND

quiet = bool(os.environ.get("SDCTRL_QUIET"))
out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else None
work = out or pathlib.Path(tempfile.mkdtemp())

# 1. the test, as a UFF file
sd.write_uff(sd.testbed_frf(noise=0.01, seed=0), work / "test.uff")
frf = sd.read_uff(work / "test.uff")
print(f"test: {frf.H.shape[1]} sensors x {frf.H.shape[2]} shakers, {frf.freq.size} lines "
      f"{frf.freq[0]:g}-{frf.freq[-1]:g} Hz ({frf.quantity}), collocated pairs: "
      f"{len(frf.collocated)}")

# 2. complex modes, no initial poles
cm = sd.identify(frf, progress=not quiet)
print(cm)
truth = sd.testbed().normal_mode_model(list(SHAKERS), list(SENSORS), 40).poles
f_true = np.abs(truth) / (2 * np.pi)
truth = truth[(f_true > TESTBED_BAND[0]) & (f_true < TESTBED_BAND[1])]
p = cm.poles[cm.in_band]
t = truth[[int(np.argmin(np.abs(np.abs(truth) - abs(x)))) for x in p]]
f_err = np.abs(np.abs(p) / np.abs(t) - 1)
z_err = np.abs((-p.real / np.abs(p)) / (-t.real / np.abs(t)) - 1)
print(f"{'f (Hz)':>8} {'f true':>8} {'zeta %':>7} {'true %':>7}")
for a, b in zip(p, t):
    print(f"{abs(a) / 2 / np.pi:8.3f} {abs(b) / 2 / np.pi:8.3f} {-100 * a.real / abs(a):7.3f} "
          f"{-100 * b.real / abs(b):7.3f}")
print(f"frequency errors <= {100 * f_err.max():.4f} %, damping errors <= {100 * z_err.max():.1f} %")
assert p.size == truth.size == 12 and f_err.max() < 1e-3 and z_err.max() < 0.05

# rank of each mode's residue: a clear rank one (3.22) says the mode is isolated and real
ratios = cm.singular_value_ratios()[cm.in_band]
print("second singular value / first, per mode:", np.round(ratios[:, 1], 3))

# 3. normal modes with the full damping matrix from the in-band poles; the one fitted just
# above the band carries the modes beyond it and is kept as it is, a complex mode in
# nm.residual (leaving it out would cost ~10% of the FRF near 60 Hz).
# With 1% noise its damping direction may come out very slightly negative: normal_modes
# then warns, with the size and what to do.
nm = sd.normal_modes(cm)
i = int(np.argmin(np.abs(nm.frequency - 15.64)))
g = nm.Gamma[i:i + 2, i:i + 2]
print(f"normal modes {np.round(nm.frequency, 2)} Hz")
print(f"damping matrix of the close pair (rad/s):\n{np.round(g, 3)}; coupling "
      f"{g[0, 1] / np.sqrt(g[0, 0] * g[1, 1]):.2f} of its bound")
fit = nm.frf(frf.freq, frf.quantity).H
err = np.linalg.norm(fit - frf.H) / np.linalg.norm(frf.H)
print(f"normal-mode model against the test: {100 * err:.2f} % relative error (noise 1 %)")
assert err < 0.03

# 4. a control-ready StateSpace, signals named after the labels
G = nm.to_statespace("acceleration")
print(f"StateSpace: {G.nstates} states, inputs {G.input_labels[:2]}..., outputs "
      f"{G.output_labels[:2]}...")
assert G.input_labels[0] == SHAKERS[0].replace(".", "_") + "_u"

if out is not None:
    import matplotlib

    matplotlib.use("Agg")
    st = cm.stabilisation
    sd.plot.stabilisation(st.poles, frf, orders=st.orders, path=out / "stabilisation.png")
    sd.plot.bode([frf, nm], labels=["test", "normal modes"],
                 channels=[(SENSORS[0], SHAKERS[0]), ("N32.z", SHAKERS[0])],
                 path=out / "identified_bode.png")
    sd.plot.complex_residues(cm, mode=i, path=out / "complex_residues.png")
    print(f"wrote the figures to {out}")
