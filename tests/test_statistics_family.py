"""Calibration of the identification statistics over the whole family of test structures
(issue 24): for every in-band mode identified on each member, the scatter of frequency and
damping over 50 noise draws against the predicted ``frequency_std``/``damping_std``, and
the coverage of the 95% intervals (thesis 3.4, (3.56)-(3.59)).

The truth of each mode is the fit of the member's exact data (its value without noise):
the statistics describe the noise's effect, not the bias of a truncated model.  Each draw
searches its poles from the noiseless fit's (``identify(frf, poles=ref.poles)``): the model
structure is fixed, so that the test measures the statistics, not the automatic choice of
model order.  With a fresh automatic identification per draw (``auto=True``) the choice of
order changes the estimates by more than the noise does on two members (measured on this
branch, 200 lines): on the ladder, a pole at 100 Hz (above the 90 Hz band) is kept in 4
draws of 16 at 1% noise and moves the 86 Hz mode by 9 of its standard deviations; on the
cluster, the noisy draws resolve the four blades near 10.2 Hz differently from the exact
data in 49 draws of 50.  The truss (1%) and the plate (1%, 5%) pass automatically.
"""

import warnings

import numpy as np
import pytest

import sdctrl as sd

N_DRAWS = 50
N_LINES = 200
NOISES = (0.01, 0.05)


def _identify(frf, poles=None, weighting="none"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.identify(frf, poles=poles, progress=False, weighting=weighting)


def family_draws(name, noise, n_draws=N_DRAWS, n_lines=N_LINES, seed=0, auto=False,
                 weighting="none"):
    """Reference fit of the exact data, and for each in-band reference pole its estimate and
    predicted std in each draw (NaN where the draw has no pole near it).

    ``name`` is a family member's name or a test structure (a held-out one).

    ``auto=False``: each draw's poles are searched from the reference's (the model
    structure of the noiseless fit); ``auto=True``: a fresh automatic identification, whose
    choice of model order may change from draw to draw.  ``weighting``: :func:`sd.identify`'s
    (the draws'; the reference is the noiseless fit weighted alike).

    Returns
    -------
    ref : ComplexModeModel
    d : dict of ndarray (n_draws, n_in_band): "f", "z", "fs", "zs"; and "same_order"
        (n_draws,): the draw's model has as many poles as the reference
    """
    s = sd.testbeds.structure(name) if isinstance(name, str) else name
    ref = _identify(s.frf(n=n_lines), weighting=weighting)
    lam = ref.poles[ref.in_band]
    # a draw's pole belongs to a reference pole when it is its nearest and closer than half
    # the distance to any other reference pole (and than 5 half-power bandwidths)
    gap = np.array([np.min(np.abs(np.delete(ref.poles, i) - p)) if ref.poles.size > 1
                    else np.inf for i, p in enumerate(ref.poles)])[ref.in_band]
    tol = np.minimum(0.5 * gap, 10 * np.abs(lam.real))
    d = {k: np.full((n_draws, lam.size), np.nan) for k in ("f", "z", "fs", "zs")}
    d["same_order"] = np.zeros(n_draws, bool)
    for k in range(n_draws):
        cm = _identify(s.frf(n=n_lines, noise=noise, seed=seed + k),
                       poles=None if auto else ref.poles, weighting=weighting)
        d["same_order"][k] = cm.poles.size == ref.poles.size
        for j, p in enumerate(lam):
            i = int(np.argmin(np.abs(cm.poles - p)))
            if abs(cm.poles[i] - p) < tol[j]:
                for key, arr in (("f", cm.frequency), ("z", cm.damping),
                                 ("fs", cm.frequency_std), ("zs", cm.damping_std)):
                    d[key][k, j] = arr[i]
    return ref, d


def calibration(ref, d):
    """Ratio of the empirical std to the median predicted std, coverage of the 95%
    intervals, and the fraction of draws that found each mode."""
    truth = {"f": ref.frequency[ref.in_band], "z": ref.damping[ref.in_band]}
    out = {"found": np.mean(np.isfinite(d["f"]), axis=0)}
    for key in ("f", "z"):
        est, std = d[key], d[key + "s"]
        out[key + "_ratio"] = np.nanstd(est, axis=0, ddof=1) / np.nanmedian(std, axis=0)
        hit = np.abs(est - truth[key]) <= 1.959964 * std          # NaN (missed): a miss
        out[key + "_cover"] = np.mean(hit, axis=0)
    return out


@pytest.mark.parametrize("name", sd.testbeds.family())
def test_statistics_calibrated_on_every_member(name):
    """50 draws at 1% and 5% noise, each draw's poles searched from the noiseless fit's (the
    model structure fixed: the automatic choice of model order is the estimator's, see the
    module notes).  Every in-band mode: empirical std of frequency and damping within
    [0.67, 1.5] of the median predicted one; the 95% intervals cover the truth in at least
    90% of the draws over the member's modes, and for each mode in at least 84% (with
    intervals of exactly 95%, 50 draws give a per-mode coverage below 0.9 with probability
    0.04 -- about three of the ~80 checks of the family -- and below 0.84 with 0.001).

    Measured (with the leverage-corrected second differences): ratios 0.75-1.25 over the
    family, per-mode coverage 0.88-1.0, except the truss's first mode (9.5 Hz, a peak of
    half-power bandwidth 0.04 Hz on 0.26 Hz lines): damping scatter 0.66 of the predicted std
    at 1% noise.  The cause was the noise level: a second difference's expectation is the
    stencil ``(|H_(k-1)|^2 + 4 |H_k|^2 + |H_(k+1)|^2) / 6`` of relative noise, not ``|H_k|^2``
    (``_pole_statistics._level``): 0.74 (0.82 with the true noise variance); and that mode
    sits at the band's start, where the running median repeated the edge line: with windows
    inside the data, 0.89.  The family's ratios are now 0.79-1.28, per-mode coverage
    0.86-1.0, and every ratio is held to [0.67, 1.5].
    """
    for noise in NOISES:
        ref, d = family_draws(name, noise, seed=1000 * int(100 * noise))
        c = calibration(ref, d)
        assert ref.in_band.sum() >= 2 and np.all(d["same_order"])
        assert np.all(c["found"] == 1.0), (noise, c["found"])
        for key in ("f", "z"):
            r = c[key + "_ratio"]
            assert np.all((r >= 0.67) & (r <= 1.5)), (noise, key, np.round(r, 2))
            cover = c[key + "_cover"]
            assert np.mean(cover) >= 0.9 - 1e-12 and np.all(cover >= 0.84), (noise, key, cover)
