"""Calibration of ``nm.std.phib`` for the rows refitted by step 6 of ``normal_modes``
(issue 24; :func:`sdctrl.identification._proper_terms.fitted_to_frf`).

The truss's close pair (15.79/15.87 Hz) is the family member whose rows of ``phib`` are
refitted to the identified FRF.  Over noise draws at 1% (400 lines, each draw's poles
searched from the noiseless fit's, as in tests/test_statistics_family.py: the model
structure is fixed so that the test measures the statistics, not the choice of order) the
empirical scatter of the refitted rows is compared with the median predicted std (thesis
3.4, (3.56)-(3.59)); the scatter needs no truth (the draws' own mean is their centre).

Measured (12 draws, this branch), empirical / predicted: refitted rows, median entry ratio
1.37 and RMS ratio 1.35 (the std of steps 1-5, which they kept before this change: 1.94 and
1.97); the other rows (std of steps 1-5) 0.97.  Since identify's default keeps the truss's
level-weighted fit (a434751) that refit's std, with the normal modes of steps 1-5 held, gave
2.39 / 2.44 (1.42 / 1.40 on the unweighted fit); propagated through steps 1-5 as well
(``_refit_std``'s ``steps``) it gives 0.97 / 0.95 (unweighted 0.98 / 0.88); other rows
0.90.  The draws are fitted unweighted (:data:`WEIGHTING`): level-weighted, step 6 ran on 9
of the 12 draws only (the others keep the pair's improper parts).  58 s on one core while
the machine was shared (about 4.5 s per draw, most of it the two std propagations).
"""

import importlib
import warnings

import numpy as np
import pytest

import sdctrl as sd

N_DRAWS = 12
N_LINES = 400
NOISE = 0.01
PAIR = (15.5, 16.1)            # Hz: the truss's close pair (normal-mode frequencies)
#: one line weighting for every draw: the default ("auto") keeps the level-weighted fit on
#: some draws and the unweighted one on others, and where it keeps the level-weighted one the
#: pair's improper parts may be kept as residual dynamics instead of refitted (step 6 not run)
WEIGHTING = "none"


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


@pytest.fixture(scope="module")
def draws():
    """Noiseless reference, the refitted rows, and per draw phib (signs of the reference),
    its predicted std and the std of steps 1-5 (what the refitted rows kept before)."""
    terms = importlib.import_module("sdctrl.identification._proper_terms")
    propagate, before = terms._refit_std, []

    def recording(nm, cm, fit, *steps):
        before.append(np.array(nm.std["phib"]))
        return propagate(nm, cm, fit, *steps)

    s = sd.testbeds.structure("truss")
    ref = _quiet(sd.identify, s.frf(n=N_LINES), progress=False)
    nm0 = _quiet(sd.normal_modes, ref, std=False)
    f = np.sqrt(np.diag(nm0.Omega)) / (2 * np.pi)
    rows = np.flatnonzero((f > PAIR[0]) & (f < PAIR[1]))
    phib, std = [], []
    terms._refit_std = recording
    try:
        for k in range(N_DRAWS):
            cm = _quiet(sd.identify, s.frf(n=N_LINES, noise=NOISE, seed=k), poles=ref.poles,
                        progress=False, weighting=WEIGHTING)
            nm = _quiet(sd.normal_modes, cm)
            d = np.sign(np.sum(nm.cphi * nm0.cphi, axis=0))
            phib.append(d[:, None] * nm.phib)
            std.append(nm.std["phib"])
    finally:
        terms._refit_std = propagate
    return nm0, rows, np.array(phib), np.array(std), np.array(before)


def test_the_pair_is_refitted(draws):
    """Step 6 ran once per draw and changed the std of the pair's rows only."""
    nm0, rows, _, std, before = draws
    assert rows.size == 2 and len(before) == N_DRAWS
    changed = np.any(std != before, axis=(0, 2))
    assert changed.tolist() == np.isin(np.arange(nm0.n), rows).tolist()


def _ratios(phib, std, rows):
    emp = phib[:, rows].std(axis=0, ddof=1)
    pred = np.median(std[:, rows], axis=0)
    assert np.all(np.isfinite(pred)) and np.all(pred > 0)
    return float(np.median(emp / pred)), float(np.sqrt(np.mean(emp**2) / np.mean(pred**2)))


def test_refitted_rows_std_calibrated(draws):
    """Empirical scatter of the refitted rows against the median predicted std: the median
    of the entrywise ratios and the ratio of the RMS over the entries within [0.67, 1.5];
    the std of steps 1-5 (before this change) missed both by about 2x."""
    _, rows, phib, std, before = draws
    med, rms = _ratios(phib, std, rows)
    med0, rms0 = _ratios(phib, before, rows)
    print(f"refitted rows: median {med:.3f}, rms {rms:.3f} (steps 1-5: {med0:.3f}, {rms0:.3f})")
    assert 0.67 <= med <= 1.5
    assert 0.67 <= rms <= 1.5
    assert med0 > 1.5 and rms0 > 1.5


def test_other_rows_keep_their_std(draws):
    """The rows not refitted keep the std of steps 1-5: their calibration as before."""
    nm0, rows, phib, std, _ = draws
    other = np.setdiff1d(np.arange(nm0.n), rows)
    emp = phib[:, other].std(axis=0, ddof=1)
    pred = np.median(std[:, other], axis=0)
    med = float(np.median(emp / pred))
    print(f"other rows: median entry ratio {med:.3f}")
    assert 0.67 <= med <= 1.5
