"""A real impact (hammer) test: FRF from five hits, modes, damping corrected for the window.

The records are a real measurement shipped with the examples (``data/impact_pyfrf/``, MIT
licence, from the pyFRF project of the University of Ljubljana; see the README and LICENSE
next to them): five hammer hits, each a force and an acceleration record of 1 s at 25.6 kHz.

1. ``sd.impact_frf`` averages the hits (H1, coherence per line) with a force window keeping
   the first 1% of the force record and an exponential window reaching 0.01 at the record's
   end; the FRF remembers the window's ``tau``;
2. ``sd.identify`` fits the strongest resonances (3.5-4.5 kHz) with common poles (3.2.1) and
   removes the decay rate ``1/tau`` the window added to every pole: the damping printed is
   the structure's, next to what the window alone would have made of it;
3. ``band=`` and ``.band()`` are one meaning of a band: the same model.

Usage: ``python impact_test.py [outdir]`` (the FRF is saved to ``outdir`` when given).
"""
import os
import pathlib
import sys

import numpy as np

import sdctrl as sd

quiet = bool(os.environ.get("SDCTRL_QUIET"))
out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else None
DATA = pathlib.Path(__file__).resolve().parent / "data" / "impact_pyfrf"
BAND = (3500.0, 4500.0)                       # Hz: the strongest resonances

# 1. five hits -> one FRF (force -> acceleration), windows as in the source's showcase
hits = []
for k in range(1, 6):
    _time, force, response = np.load(DATA / f"measurements_{k}.npy")
    hits.append((force, response))
frf = sd.impact_frf(hits, 25600.0, force_window=0.01, exponential=0.01,
                    quantity="accelerance", sensors=["response"], actuator="hammer")
coh = frf.band(10, 5000).coherence.mean()
assert coh > 0.99, coh                        # source: about 0.998 below 5 kHz
tau = frf.exponential_tau

# 2. modes of the band, corrected for the exponential window
cm = sd.identify(frf, band=BAND, progress=False)
assert cm.exponential_tau == tau
windowed = -(cm.poles.real - 1 / tau) / np.abs(cm.poles - 1 / tau)     # damping with the window
for f0 in (3669.0, 3689.0, 4128.0, 4164.0, 4392.0):                     # the source's peaks
    assert np.min(np.abs(cm.frequency - f0)) < 3.0, f0
assert np.all(cm.damping > 0) and np.all(cm.damping < windowed)
assert cm.cost < 0.1, cm.cost

# 3. one meaning of "band"
same = sd.identify(frf.band(*BAND), progress=False)
assert same.n == cm.n and np.allclose(same.frequency, cm.frequency, rtol=1e-4)

if not quiet:
    print(f"{frf!r}; mean coherence 10-5000 Hz {coh:.4f}; exponential window tau = "
          f"{tau * 1e3:.1f} ms (adds {1 / tau:.2f} rad/s to every decay rate)")
    print(f"{cm.n} modes in {BAND[0]:g}-{BAND[1]:g} Hz, fit error {100 * cm.cost:.1f}%")
    print(" frequency (Hz)   damping (%)   with the window (%)")
    for f0, z, zw in zip(cm.frequency, cm.damping, windowed, strict=True):
        print(f"  {f0:10.2f}      {100 * z:8.4f}       {100 * zw:8.4f}")
if out is not None:
    sd.save(frf, out / "impact_frf.npz")
    assert sd.load(out / "impact_frf.npz").exponential_tau == tau
