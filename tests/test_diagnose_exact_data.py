"""Issue 23 against the physical truth: data from the full FE model with the effect planted
(``FEModel.frf``, every DOF), not from a reduction of it.

The family tests (:mod:`test_diagnose_family`) build both the nominal model and the data as
the same kind of reduction (modes to 5x the band top, static modes of the shakers and of
the change's load path), so that the model's own truncation cancels.  A test of a real
structure has no such luck: the nominal model's truncation error is in the data.  On the
built-in truss over 20-60 Hz the plain reduction leaves 7.6e-4 (mean logLS) against the
full model, above the 1% noise (1e-4): the null case then "finds" a dashpot (N11-N13) and a
planted dashpot comes out 3.6% low with two invented effects.  The reduction that carries
the dashpots' load paths (``damping_paths=True``) leaves 1.2e-6, and every effect is found
at its place and size (measured below).

Measured (seed 0; relative size error, noise-free / 1%):
- dashpot N8-N46: -0.05% / -0.13% (std 0.04%); mass at N49: 0.00% / 0.00%; spring N23-N48:
  +0.03% / +0.03%; delay: 0.00% / 0.00%;
- mass at N46 and dashpot N8-N46 (the shared node whose test-reduction bias is locked in
  :mod:`test_diagnose_family_truss`, +1.17%): mass -0.12%, dashpot -0.15% / -0.17% (std
  0.03%): the +1.17% was the test reduction's, not the diagnosis's;
- the null case at 1%, five seeds: no effect.  The reduction's own floor (1.2e-6
  noise-free, from the modes above 300 Hz) is detectable against 33 x 6 x 200 entries (a
  chi-square excess of ~470 at 1% noise), and its best explanation was a "missing mode" at
  60.4-62.2 Hz, at and beyond the band's top, with a damping ratio of 3.6-6.2% +- 1.4-2.3%:
  a broadband trend whose size the data do not determine (within 3 standard deviations of
  zero), no longer accepted (``undetermined``, :mod:`sdctrl.diagnosis._effect_statistics`);
  nor is a lower-ranked effect in its place (they would absorb what it leaves: with them,
  2-3 effects per seed).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from test_diagnose_family import _copy, _truth, case, member, noisy

NAME = "truss_high"


@functools.cache
def _nominal():
    s, fe, n, _ = member(NAME)
    return fe.normal_mode_model(list(s.shakers), list(s.sensors), n, static=True,
                                static_damping="projected", damping_paths=True)


def _exact(effects):
    """The full model's response with the effects planted (accelerance)."""
    s, fe, _, freq = member(NAME)
    dM = dK = dC = 0
    tau = 0.0
    for kind, where, size in effects:
        if kind == "mass_change":
            P = fe.point([f"{where}.{a}" for a in "xyz"])
            dM = dM + sp.csr_matrix(size * (P @ P.T))
        elif kind == "delay":
            tau += size
        else:
            b = fe.strut(*where)
            X = sp.csr_matrix(size * (b @ b.T))
            dC, dK = (dC + X, dK) if kind == "added_damper" else (dC, dK + X)
    H = _copy(fe, dM, dK, dC).frf(freq, list(s.shakers), list(s.sensors), "acceleration").H
    return sd.FRF(freq, H * np.exp(-2j * np.pi * freq * tau)[:, None, None],
                  quantity="acceleration", sensors=s.sensors, actuators=s.shakers)


@functools.cache
def _diagnosis(effects, noise):
    data = _exact(effects)
    data = noisy(data, noise, 0) if noise else data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.diagnose(_nominal(), data, member(NAME)[1], max_effects=3, progress=False)


def _size(d, c):
    kind, where, _ = c
    loc, truth = _truth(NAME, c)
    e = next(e for e in d.effects if e.kind == kind)
    assert e.location == loc
    (key, v), = truth.items()
    return e.parameters[key] / v - 1, e.std[key] / abs(v)


def test_the_nominal_reaches_the_full_model():
    s, fe, _, freq = member(NAME)
    H = _nominal().frf(freq, "acceleration").H
    assert np.mean(np.abs(np.log(H / _exact(()).H)) ** 2) <= 2e-6          # 1.2e-6


@pytest.mark.parametrize("kind", ["added_damper", "mass_change", "stiffness_change", "delay"])
def test_one_effect_in_the_full_models_data(kind):
    c = case(NAME, kind, 0)
    clean, noisy_ = _diagnosis((c,), 0.0), _diagnosis((c,), 0.01)
    assert clean.effects[0].kind == noisy_.effects[0].kind == kind
    assert len(clean.effects) == len(noisy_.effects) == 1
    e0, _ = _size(clean, c)
    e1, std = _size(noisy_, c)
    print(f"\n{kind}: {e0:+.5f} / {e1:+.5f} (std {std:.5f})")
    assert abs(e0) <= 0.002 and abs(e1) <= 0.005
    assert abs(e1) <= 3 * std + abs(e0)
    assert clean.error_after <= clean.error_before / 1000
    assert noisy_.error_after <= 1.05e-4


def test_two_effects_sharing_a_node_in_the_full_models_data():
    cs = (case(NAME, "mass_change", 1), case(NAME, "added_damper", 0))
    assert cs[0][1] in cs[1][1]                                  # N46
    clean, noisy_ = _diagnosis(cs, 0.0), _diagnosis(cs, 0.01)
    for c in cs:
        e0, _ = _size(clean, c)
        e1, std = _size(noisy_, c)
        print(f"\n{c[0]}: {e0:+.5f} / {e1:+.5f} (std {std:.5f})")
        assert abs(e0) <= 0.003 and abs(e1) <= 0.004             # -0.12%, -0.15% / -0.17%
        assert abs(e1 - e0) <= 3 * std
    assert clean.error_after <= 5e-6                             # 2.3e-6
    assert noisy_.error_after <= 1.05e-4


@pytest.mark.parametrize("seed", range(5))
def test_null_case_in_the_full_models_data(seed):
    data = noisy(_exact(()), 0.01, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = sd.diagnose(_nominal(), data, member(NAME)[1], max_effects=3, progress=False)
    assert len(d.effects) == 0
    why = [r["reason"] for step in d.steps for r in step["rejected"]]
    assert any("not determined" in r for r in why)             # the trend at 60-62 Hz
