"""Statistics of identified models (issue 24): calibrated against many noise draws with a
known truth (thesis 3.4, (3.56)-(3.59))."""

import warnings

import numpy as np
import pytest

import sdctrl as sd

LABELS = ("N1.x", "N2.x", "N3.x", "N4.x")


def chain_matrices(n=4):
    """A spring-mass chain fixed at one end, non-proportional damping (a dashpot on mass 1)."""
    M = np.diag(np.linspace(1.0, 1.6, n))
    k = 1e4 * np.linspace(1.0, 1.5, n)
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] += k[i]
        if i + 1 < n:
            K[i, i] += k[i + 1]
            K[i, i + 1] -= k[i + 1]
            K[i + 1, i] -= k[i + 1]
    C = 2e-4 * K + 0.3 * M
    C[0, 0] += 0.5
    return M, K, C


def chain_poles(M, K, C):
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(lam.imag)]


def chain_frf(M, K, C, freq, actuators=(0,)):
    """Exact displacement FRF of every mass to forces on ``actuators``."""
    s = 2j * np.pi * freq
    Z = M[None] * (s**2)[:, None, None] + C[None] * s[:, None, None] + K[None]
    return np.linalg.inv(Z)[:, :, list(actuators)]


def noisy(freq, H0, noise, rng, **labels):
    """FRF with complex Gaussian noise proportional to |H| on every line."""
    e = (rng.standard_normal(H0.shape) + 1j * rng.standard_normal(H0.shape)) / np.sqrt(2)
    return sd.FRF(freq, H0 * (1 + noise * e), **labels)


def draws(freq, H0, poles0, noise, n_draws, seed, **labels):
    """Frequencies, damping and their predicted std over ``n_draws`` noise draws."""
    rng = np.random.default_rng(seed)
    out = {k: [] for k in ("f", "z", "fs", "zs")}
    for _ in range(n_draws):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cm = sd.identify(noisy(freq, H0, noise, rng, **labels), poles=poles0,
                             progress=False)
        out["f"].append(cm.frequency)
        out["z"].append(cm.damping)
        out["fs"].append(cm.frequency_std)
        out["zs"].append(cm.damping_std)
    return {k: np.array(v) for k, v in out.items()}, cm.in_band


def check_calibration(d, f_true, z_true, in_band):
    for key, truth in (("f", f_true), ("z", z_true)):
        pred = np.median(d[key + "s"], axis=0)[in_band]
        emp = np.std(d[key], axis=0, ddof=1)[in_band]
        ratio = emp / pred
        assert np.all((ratio > 0.67) & (ratio < 1.5)), (key, ratio)
        cover = np.mean(np.abs(d[key] - truth) <= 1.96 * d[key + "s"], axis=0)[in_band]
        # 95% intervals over 50 draws: a mode's coverage is below 0.9 with probability 0.04
        # and below 0.84 with 0.001 (binomial), so the mean over the modes is held to 0.9 and
        # each mode to 0.84, as in test_statistics_family (each mode held to 0.9 passed while
        # the noise level around narrow peaks was overstated: conservative intervals; 1e-12:
        # the mean of 43/50 and 47/50 is 0.8999999999999999 in floating point)
        assert np.mean(cover) >= 0.9 - 1e-12 and np.all(cover >= 0.84), (key, cover)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_pole_std_calibrated_on_a_chain(noise):
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    d, in_band = draws(freq, H0, lam, noise, 50, seed=int(noise * 1000),
                       sensors=LABELS, actuators=LABELS[:1])
    assert in_band.all() and d["fs"].shape == (50, 4)
    check_calibration(d, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), in_band)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_pole_std_calibrated_on_the_testbed(noise):
    """Two modes of the built-in truss, four sensors, one shaker; the truth is the fit of
    the exact data (the scatter of the estimate around its noiseless value)."""
    band = (8.0, 14.0)
    exact = sd.testbed_frf(band=band, n=600)
    sub = dict(sensors=exact.sensors[:4], actuators=exact.actuators[:1])
    H0 = exact.H[:, :4, :1]
    ref = sd.identify(sd.FRF(exact.freq, H0, quantity=exact.quantity, **sub), progress=False)
    d, in_band = draws(exact.freq, H0, ref.poles, noise, 50, seed=7 + int(noise * 1000),
                       quantity=exact.quantity, **sub)
    assert in_band.sum() >= 2
    check_calibration(d, ref.frequency, ref.damping, in_band)


def test_pole_std_calibrated_from_the_coherence():
    """With a coherence the point variance is ``|H|^2 (1 - coherence)`` (3.59)."""
    noise = 0.05
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    coh = np.full(H0.shape, 1 - noise**2)
    d, in_band = draws(freq, H0, lam, noise, 50, seed=3, sensors=LABELS,
                       actuators=LABELS[:1], coherence=coh)
    check_calibration(d, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), in_band)


def test_statistics_absent_saved_and_residue_parts(tmp_path):
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq)
    frf = noisy(freq, H0, 0.02, np.random.default_rng(1), sensors=LABELS,
                actuators=LABELS[:1])
    cm = sd.identify(frf, poles=lam, progress=False)
    assert np.all(np.isfinite(cm.frequency_std)) and np.all(cm.frequency_std > 0)
    # a model built by hand has no statistics: NaN, and residue_std NaN too
    bare = sd.ComplexModeModel(cm.poles, cm.residues)
    assert np.all(np.isnan(bare.frequency_std)) and np.all(np.isnan(bare.damping_std))
    assert np.all(np.isnan(bare.residue_std()))
    # both parts of (3.58): the part through the poles matters, and the total matches the
    # scatter of the residues over noise draws
    total, direct = cm.residue_std(), cm.residue_std(direct_only=True)
    assert np.any(np.abs(total - direct) > 0.05 * direct)
    rng = np.random.default_rng(5)
    est = []
    for _ in range(40):
        est.append(sd.identify(noisy(freq, H0, 0.02, rng, sensors=LABELS,
                                     actuators=LABELS[:1]), poles=lam, progress=False).residues)
    est = np.array(est)
    emp = np.sqrt(np.var(est.real, axis=0) + np.var(est.imag, axis=0))
    assert 0.75 < np.median(emp / total) < 1.33
    # the residue error is of the order of the noise (2%) relative to the residue
    assert 0.002 < np.median(total / np.abs(cm.residues)) < 0.05
    path = tmp_path / "cm.npz"
    sd.save(cm, path)
    back = sd.load(path)
    assert np.array_equal(back.frequency_std, cm.frequency_std)
    assert np.array_equal(back.residue_std(), total)


# --------------------------------------------------------------------------------------
# normal-mode statistics and uncertain models from the data (3.4, 5.2.3)
# --------------------------------------------------------------------------------------
def chain_normal_modes(M, K, C, sensors, actuators):
    """The full (untruncated) normal-mode model of the chain: Omega, Gamma, cphi, phib."""
    import scipy.linalg as sla

    w2, phi = sla.eigh(K, M)
    return np.diag(w2), phi.T @ C @ phi, phi[list(sensors)], phi[list(actuators)].T


def aligned(nm, cphi_true):
    """Omega, Gamma, cphi, phib of ``nm`` with mode signs of the truth."""
    d = np.sign(np.sum(nm.cphi * cphi_true, axis=0))
    return (np.asarray(nm.Omega), d[:, None] * nm.Gamma * d, nm.cphi * d,
            d[:, None] * nm.phib)


@pytest.fixture(scope="module")
def chain_tests():
    """30 noisy tests (2%) of the chain, 4 sensors x 2 collocated shakers, identified and
    transformed to normal modes, with the exact normal-mode model."""
    M, K, C = chain_matrices()
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, C, freq, actuators=(0, 3))
    truth = chain_normal_modes(M, K, C, range(4), (0, 3))
    rng = np.random.default_rng(11)
    labels = dict(sensors=LABELS, actuators=(LABELS[0], LABELS[3]),
                  collocated=[(0, 0), (3, 1)])
    models = []
    for _ in range(30):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cm = sd.identify(noisy(freq, H0, 0.02, rng, **labels), poles=lam, progress=False)
            models.append(sd.normal_modes(cm))
    return models, truth


def test_normal_mode_std_calibrated(chain_tests):
    models, truth = chain_tests
    est = np.array([np.concatenate([a.ravel() for a in aligned(m, truth[2])]) for m in models])
    std = np.array([np.concatenate([m.std[k].ravel() for k in ("Omega", "Gamma", "cphi",
                                                                 "phib")]) for m in models])
    assert np.all(np.isfinite(std))
    # Omega is diagonal by construction: its off-diagonal entries are certain
    off = ~np.eye(4, dtype=bool).ravel()
    assert np.all(std[:, :16][:, off] == 0)
    det = np.median(std, axis=0) > 0
    ratio = np.std(est, axis=0, ddof=1)[det] / np.median(std, axis=0)[det]
    assert 0.75 < np.median(ratio) < 1.33 and np.all((ratio > 0.5) & (ratio < 2.0)), ratio


def test_uncertain_from_one_identified_model_covers_the_truth(chain_tests):
    models, truth = chain_tests
    inside = {k: [] for k in ("Omega", "Gamma", "cphi", "phib")}
    for m in models:
        um = sd.uncertain_from_data(m, level=0.95)
        assert "identification statistics" in um.source and um.source in repr(um)
        Om, Ga, cp, pb = aligned(um.model, truth[2])
        for k, est, true, bound in (("Omega", Om, truth[0], um.dOmega),
                                    ("Gamma", Ga, truth[1], um.dGamma),
                                    ("cphi", cp, truth[2], um.dc), ("phib", pb, truth[3], um.db)):
            sel = bound > 0
            inside[k].append(np.abs(est - true)[sel] <= bound[sel])
    rates = {k: np.mean(np.concatenate(v)) for k, v in inside.items()}
    assert all(0.85 <= r <= 1.0 for r in rates.values()), rates
    # a lower level gives tighter bounds that cover less often (level is honoured)
    um50 = sd.uncertain_from_data(models[0], level=0.5)
    um95 = sd.uncertain_from_data(models[0], level=0.95)
    assert np.allclose(um95.dGamma, um50.dGamma * 1.959964 / 0.674490, rtol=1e-5)


def test_uncertain_from_several_tests(chain_tests, tmp_path):
    models, truth = chain_tests
    hits, n = 0, 0
    for g in range(6):
        group = models[5 * g:5 * g + 5]
        um = sd.uncertain_from_data(group, level=0.95)
        assert "5 tests" in um.source
        # the larger of the spread and the statistics: never below the statistical bound
        single = sd.uncertain_from_data(group[0], level=0.95)
        assert np.all(um.dGamma >= 0.5 * single.dGamma)
        Om, Ga, cp, pb = aligned(um.model, truth[2])
        for est, true, bound in ((Ga, truth[1], um.dGamma), (cp, truth[2], um.dc),
                                 (pb, truth[3], um.db)):
            sel = bound > 0
            hits += int(np.sum(np.abs(est - true)[sel] <= bound[sel]))
            n += int(np.sum(sel))
    assert hits / n >= 0.85
    path = tmp_path / "um.npz"
    sd.save(um, path)
    back = sd.load(path)
    assert back.source == um.source and np.array_equal(back.dGamma, um.dGamma)
    path = tmp_path / "nm.npz"
    sd.save(models[0], path)
    assert all(np.array_equal(sd.load(path).std[k], models[0].std[k]) for k in models[0].std)


def test_models_without_statistics():
    nm = sd.NormalModeModel(np.diag([100.0, 400.0]), np.diag([0.2, 0.4]), np.eye(2), np.eye(2))
    assert nm.std is None
    with pytest.raises(ValueError, match="statistics"):
        sd.uncertain_from_data(nm)
    with pytest.raises(ValueError, match="level"):
        sd.uncertain_from_data([nm, nm], level=1.5)
    with pytest.raises(TypeError, match="NormalModeModel"):
        sd.uncertain_from_data("nm")
    with pytest.raises(ValueError, match="std"):
        nm.replace(std={"Omega": np.ones((2, 2))})
    # new parameters drop statistics that no longer describe them
    std = {k: np.ones_like(getattr(nm, k)) for k in ("Omega", "Gamma", "cphi", "phib")}
    with_std = nm.replace(std=std)
    assert with_std.replace(E=np.zeros((2, 2))).std is not None
    assert with_std.replace(Omega=np.diag([101.0, 400.0])).std is None
    # normal modes of a complex-mode model built by hand have no statistics either
    lam = np.array([-0.5 + 60j, -0.8 + 90j])
    phi = np.array([[1.0, 0.5], [0.4, -1.0]])
    R = np.einsum("ij,kj->jik", phi, phi) / (2j * lam.imag)[:, None, None]
    assert sd.normal_modes(sd.ComplexModeModel(lam, R, collocated=[(0, 0), (1, 1)])).std is None


# --------------------------------------------------------------------------------------
# FE update: Cramer-Rao standard deviations (UpdateResult.std, Identifiability.std)
# --------------------------------------------------------------------------------------
def test_update_std_matches_the_scatter_of_updates():
    """A 5-DOF chain FE model, two parameters (a ground spring, a tip mass), the test made
    on the truth with 2% noise proportional to |H|: over 20 draws the scatter of the fitted
    values is within [0.5, 2] of the predicted std, and identifiability predicts it too."""
    noise = 0.02
    M, K, C = chain_matrices(5)
    dofs = [f"N{i + 1}.x" for i in range(5)]
    dK = np.zeros((5, 5))
    dK[0, 0] = 1e4
    dM = np.zeros((5, 5))
    dM[4, 4] = 1.0
    pars = [sd.Parameter("k1", dK=dK, bounds=(-0.5, 2.0)),
            sd.Parameter("m5", dM=dM, bounds=(-0.5, 2.0))]
    truth = np.array([0.1, -0.1])
    fe = sd.FEModel(M, K, C=C, dofs=dofs)
    freq = np.linspace(2.0, 40.0, 200)
    H0 = chain_frf(M - 0.1 * dM, K + 0.1 * dK, C, freq)
    rng = np.random.default_rng(2)
    vals, stds = [], []
    for _ in range(20):
        frf = noisy(freq, H0, noise, rng, sensors=dofs, actuators=dofs[:1])
        res = sd.update(fe, frf, pars, damping="fe", progress=False)
        vals.append([res.values[p.name] for p in pars])
        stds.append([res.std[p.name] for p in pars])
    vals, stds = np.array(vals), np.array(stds)
    scatter = np.std(vals, axis=0, ddof=1)
    assert np.all(np.abs(vals.mean(axis=0) - truth) < 3 * scatter)
    ratio = scatter / np.median(stds, axis=0)
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio
    assert "| k1 | 0 |" in res.report() and f"{res.std['k1']:.2g}" in res.report()
    # before any update, from the nominal model and the noise level (NOISE^2 / 2 on log|H|)
    ident = sd.identifiability(fe, frf, pars, damping="fe", noise=noise**2 / 2)
    pred = np.array([ident.std[p.name] for p in pars])
    assert np.all((scatter / pred > 0.5) & (scatter / pred < 2.0)), scatter / pred
    assert ident.weak == [] and ident.confounded == []
    assert abs(ident.estimate_correlation[0, 1]) < 0.95


# --------------------------------------------------------------------------------------
# diagnosis: Effect.std against the scatter of the fitted sizes
# --------------------------------------------------------------------------------------
def _chain_model(keep, C):
    """Normal-mode model of the chain restricted to the modes ``keep``."""
    import scipy.linalg as sla

    M, K, _ = chain_matrices()
    w2, phi = sla.eigh(K, M)
    G = phi.T @ C @ phi
    return sd.NormalModeModel(np.diag(w2[keep]), G[np.ix_(keep, keep)], phi[:, keep],
                              phi[[0, 3]][:, keep].T, sensors=LABELS,
                              actuators=(LABELS[0], LABELS[3])), w2, G


@pytest.mark.parametrize("kind", ["delay", "missing_mode"])
def test_effect_std_matches_the_scatter_of_diagnoses(kind):
    """A 2 ms measurement delay, or a mode missing from the model, on the chain with 2% noise:
    over 30 draws the scatter of the fitted sizes is within [0.5, 2] of the predicted std and
    the 95% intervals cover the truth in at least 85% of the draws."""
    M, K, _ = chain_matrices()
    Cp = 2e-4 * K + 0.3 * M                       # proportional: the missing mode is a mode
    freq = np.linspace(2.0, 40.0, 300)
    H0 = chain_frf(M, K, Cp, freq, actuators=(0, 3))
    labels = dict(sensors=LABELS, actuators=(LABELS[0], LABELS[3]))
    if kind == "delay":
        nm, _, _ = _chain_model([0, 1, 2, 3], Cp)
        H0 = H0 * np.exp(-2j * np.pi * freq * 2e-3)[:, None, None]
        truth = {"tau": 2e-3}
    else:
        nm, w2, G = _chain_model([0, 1, 3], Cp)
        truth = {"frequency": np.sqrt(w2[2]) / (2 * np.pi),
                 "damping": G[2, 2] / (2 * np.sqrt(w2[2]))}
    rng = np.random.default_rng(4)
    got = {k: [] for k in truth}
    std = {k: [] for k in truth}
    for _ in range(30):
        d = sd.diagnose(nm, noisy(freq, H0, 0.02, rng, **labels), max_effects=1,
                        progress=False)
        e = d.effects[0]
        assert e.kind == kind
        for k in truth:
            got[k].append(e.parameters[k])
            std[k].append(e.std[k])
    for k, true in truth.items():
        g, s = np.array(got[k]), np.array(std[k])
        ratio = np.std(g, ddof=1) / np.median(s)
        assert 0.5 < ratio < 2.0, (k, ratio)
        assert np.mean(np.abs(g - true) <= 1.96 * s) >= 0.85, k
    assert "+-" in d.report() and "+-" in repr(e)


def test_certified_controller_stabilises_the_true_structure():
    """A 2-DOF chain (its full normal-mode model known, no truncation), 2% noise: a
    non-collocated rate feedback (sensor 2 -> shaker 1) near its stability limit.  In every
    draw where ``robust_stability`` on ``uncertain_from_data(nm, 0.95)`` certifies it
    (margin >= 1), the true structure is stable under it; the certificate is not vacuous
    (2.5 times the gain destabilises the true structure)."""
    import control

    M, K, C = chain_matrices(2)
    lam = chain_poles(M, K, C)
    freq = np.linspace(2.0, 30.0, 200)
    H0 = chain_frf(M, K, C, freq, actuators=(0, 1))
    Om, Ga, cp, pb = chain_normal_modes(M, K, C, range(2), (0, 1))
    labels = dict(sensors=LABELS[:2], actuators=LABELS[:2], collocated=[(0, 0), (1, 1)])
    true = sd.NormalModeModel(Om, Ga, cp, pb, sensors=LABELS[:2],
                              actuators=LABELS[:2]).to_statespace()

    def rate(g):
        wc = 2 * np.pi * 200
        r = control.ss(control.tf([g * wc, 0.0], [1.0, wc]))
        pick = np.zeros((2, 2))
        pick[0, 1] = 1.0                               # shaker 1 <- sensor 2
        return control.append(r, r) * control.ss([], [], [], pick)

    def true_abscissa(g):
        return np.linalg.eigvals(sd.feedback(true, rate(g)).A).real.max()

    gain = 18.0
    assert true_abscissa(gain) < 0 < true_abscissa(2.5 * gain)
    rng = np.random.default_rng(8)
    margins = []
    for _ in range(6):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cm = sd.identify(noisy(freq, H0, 0.02, rng, **labels), poles=lam, progress=False)
        um = sd.uncertain_from_data(sd.normal_modes(cm), 0.95)
        r = sd.robust_stability(um, rate(gain))
        margins.append(r.margin)
        if r.margin >= 1:
            assert r.stable and true_abscissa(gain) < 0
    # the margin is finite (the uncertainty matters) and certifies most draws
    assert np.all(np.isfinite(margins)) and np.mean(np.array(margins) >= 1) >= 0.5, margins


def test_confounded_verdict_agrees_with_the_scatter_of_updates():
    """Two mass parameters of a 5-DOF chain with almost the same effect (their estimates
    correlated -0.99): at 2% noise each is determined to 0.2% of its standard change, and 20
    updates agree -- not confounded (a correlation rule alone would say they are).  Raising
    the noise until the pair's 95% joint region spans the standard changes makes them
    confounded, each still below its standard change (not weak)."""
    noise = 0.02
    M, K, C = chain_matrices(5)
    dofs = [f"N{i + 1}.x" for i in range(5)]
    pars = [sd.Parameter("a", dM=np.diag([0, 0, 0, 0.3, 1.0]), bounds=(-0.5, 2.0)),
            sd.Parameter("b", dM=np.diag([0, 0, 0, 0.5, 1.0]), bounds=(-0.5, 2.0))]
    fe = sd.FEModel(M, K, C=C, dofs=dofs)
    freq = np.linspace(2.0, 40.0, 200)
    H0 = chain_frf(M, K, C, freq)
    rng = np.random.default_rng(3)
    ident = sd.identifiability(fe, noisy(freq, H0, noise, rng, sensors=dofs,
                                         actuators=dofs[:1]), pars, damping="fe",
                               noise=noise**2 / 2)
    assert ident.estimate_correlation[0, 1] < -0.95
    assert ident.confounded == [] and ident.weak == []
    vals, stds = [], []
    for _ in range(20):
        res = sd.update(fe, noisy(freq, H0, noise, rng, sensors=dofs, actuators=dofs[:1]),
                        pars, damping="fe", progress=False)
        vals.append([res.values["a"], res.values["b"]])
        stds.append([res.std["a"], res.std["b"]])
    vals = np.array(vals)
    scatter = np.std(vals, axis=0, ddof=1)
    pred = np.array([ident.std["a"], ident.std["b"]])
    for s in (pred, np.median(stds, axis=0)):
        assert np.all((scatter / s > 0.5) & (scatter / s < 2.0)), scatter / s
    # the updates tell them apart: their spread along the worst combination is far below
    # the standard changes (1), though the two estimates move together
    major = np.sqrt(np.linalg.eigvalsh(np.cov(vals.T)).max())
    assert major < 0.05 and np.corrcoef(vals.T)[0, 1] < -0.9
    # a noise level giving each estimate half its standard change: confounded, not weak
    level = noise**2 / 2 * (0.5 / ident.std["a"]) ** 2
    loud = sd.identifiability(fe, noisy(freq, H0, noise, rng, sensors=dofs,
                                        actuators=dofs[:1]), pars, damping="fe", noise=level)
    assert loud.std["a"] == pytest.approx(0.5, rel=1e-6) and loud.weak == []
    assert loud.confounded == [("a", "b")]


def test_normal_mode_std_steps_the_other_way_where_properness_is_lost():
    """A nominal near the properness limit (3.52) may lose it on one side of a finite-
    difference step: the difference is then taken the other way, not every std made NaN (a
    held-out aircraft test with two of three shakers at 1%: ``nm.std`` was all NaN)."""
    from sdctrl.identification._normal_statistics import _difference

    def f(h):                                   # no transform for positive steps
        if h > 0:
            raise ValueError("cm: the Riccati equation (3.52) has no small real root")
        return np.array([3.0 + 2.0 * h, -h])

    y0 = np.array([3.0, 0.0])
    assert np.allclose(_difference(f, y0, 1e-3), [2.0, -1.0])
    assert np.allclose(_difference(lambda h: y0 + 5 * h, y0, 1e-3), [5.0, 5.0])
    with pytest.raises(ValueError):
        _difference(lambda h: (_ for _ in ()).throw(ValueError("both sides")), y0, 1e-3)
