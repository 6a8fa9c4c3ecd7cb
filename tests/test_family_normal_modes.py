"""Normal-mode models on every member of the testbed family (issue 22, normal-mode part; issue
26, "never all or nothing").

The in-band identified poles become normal modes (properness, thesis 3.44); the out-of-band
poles and the modes whose properness cannot be enforced stay complex-mode residual dynamics
(3.7), realised as they are (3.26-3.33), so that the normal-mode model reproduces the
identified model at the tested I/O.  Acceptance: mean logLS of the normal-mode model against
the data <= max(3x the identified model's, 0.01) on every member, noise-free and 1% noise;
each member's figure is also locked at 1.5x its measured value.
"""

import functools
import pickle
import warnings

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.identification._mode_split import IMPROPER, OUT_OF_BAND
from sdctrl.updating import logls

#: measured mean logLS of nm against the data (noise-free, 1% noise; seed 1, 400 lines), with
#: the improper parts of the in-band residues kept at their poles where significant (issue 22;
#: before: truss 0.00719 / 0.01320, truss_high 0.00135 / 0.00281, ladder 0.01078 / 0.01198,
#: plate 0.00503 / 0.00515, cluster unchanged; earlier still, with no out-of-band poles:
#: truss_high 0.264 / 0.262, ladder 0.0475 / 0.0477, plate 1% 0.107).  Noise-free, where the
#: correction is kept, the normal-mode model reproduces the identified model (truss_high 6.8e-8,
#: ladder 3.8e-11: the identified figures); the lock is then 1.5x the identified model's.
#: Since close modes are judged together and the rows of phib of a close pair are refitted to
#: the identified FRF relative to its level (step 6, ``_proper_terms.fitted_to_frf``), at 1%
#: (merged state -> now): truss 0.01827 -> 0.00888, cluster 0.9405 -> 0.0310, the others
#: unchanged (truss_high 0.00228, ladder 0.00253 -> 0.00248 (79.9 Hz kept with 78.4 Hz),
#: plate 0.00075, recorded higher below); noise-free unchanged.  Since identification's own
#: trust-region solver and numpy QR (no scipy on its path, issue 27) the noise-free ladder
#: ends at 15 poles, 7.71e-4 (the identified figure; before 3.8e-11): which of the two an
#: exact fit lands on is decided by round-off (the significance test prunes poles against a
#: noise field of round-off) -- main with scipy's solver gave the 15-pole figure on 11 of 24
#: copies of the data perturbed by 1e-14, this code on 14; both within the 0.01 asked.
#: Since the improper parts are also kept where the normal modes would otherwise miss the
#: identified model by more than it misses the data (the logLS rule,
#: ``identification._part_selection``), at 1%: truss 0.00888 -> 0.00824 (one part, 54 -> 66
#: states), truss_high 0.00228 -> 0.00089 (two, 90 -> 114), plate 0.00075 -> 0.00045 (one, 32
#: -> 36); ladder and cluster unchanged (their normal modes were already that close);
#: noise-free unchanged (every part already kept).  The held-out structure's 3.75x -> 1.98x.
#: At 1% since identify's default is weighting="auto" (the level-weighted fit kept on the
#: truss, truss_high, the ladder and the cluster): truss 0.008237 -> 0.00726, truss_high
#: 0.000886 -> 0.000415, ladder 0.002484 -> 0.00102, cluster 0.03101 -> 0.00037 (nm = the
#: identified model); the plate keeps its unweighted fit; noise-free data are fitted unweighted.
MEASURED = {
    ("truss", 0.0): 0.004274, ("truss", 0.01): 0.00726,
    ("truss_high", 0.0): 6.844e-08, ("truss_high", 0.01): 0.000415,
    ("ladder", 0.0): 7.707e-04, ("ladder", 0.01): 0.00102,
    # the noise-free plate since identify's default zeta_max is 0.25: 6.6e-4 -> 4.5e-12
    # measured, locked at 1e-9 (an exact fit: its last digits are round-off)
    ("plate", 0.0): 1e-09, ("plate", 0.01): 0.000450,
    ("cluster", 0.0): 7.961e-05, ("cluster", 0.01): 0.00037,
}
#: every member but the cluster meets the acceptance bound max(3 x identified, 0.01) since the
#: improper parts are kept (the ladder was short of it, at 0.0108 / 0.0120: the properness
#: enforcement's residue error on its most damped modes, 23.8, 64.2, 78.4 Hz, which its dashpots
#: couple with modes outside the band -- section 3.3's assumption fails there).  Tried before, no
#: gain (noise-free ladder 0.0108): other reduced coordinates c_T (real SVD of c psi: 0.0108; rows
#: equilibrated: 0.0110; whitened by psi psi^H: 0.0107, truss worse), refitting cphi and phib
#: to the residues given the proper modes (0.0106, truss 0.0072 -> 0.0077), relative weights
#: in the phib fit (0.018), the paired out-of-band poles (7.97, 10.0, 98.3 Hz) made modes too
#: (0.0109-0.0113)
#: The cluster at 1%: since the pole search weighs each channel by its noise level its
#: identification finds the 5 modes (0.0299; before 4, 0.30, and 1.028 here).  Two of the four
#: blade modes (10.151, 10.287 Hz, each localised on a blade without a shaker) have collocated
#: residues within their noise (0.2-1.0 standard deviations at both pairs): their scaling
#: (3.24) was noise, and at 10.287 Hz its phase gave a negative identified mass (3.45), so the
#: mode stayed residual dynamics (0.9405).  Now such a mode's scaling takes the phase of a
#: proper mode (3.40; ``_collocated_scaling``) and every blade mode is a normal mode (0.339
#: with the normal modes alone), and the improper parts of the four close modes are judged and
#: kept together (``_close_modes``; 10.287 Hz's is 3.8 sigma, the group's sum 4.0 sigma): kept
#: one by one, the 10.287 Hz part alone upset the cluster's balance (0.997).  0.9405 ->
#: 0.0310 (seeds 2/3: 1.808 -> 0.0306, 0.848 -> 0.0206).  Noise-free the cluster went 1.01
#: -> 0.0103 (close modes identified) -> 8e-5 (improper parts kept).  Since the same change
#: the truss at 1% is 0.0183 against 3x 0.0057 = 0.0171 (before 0.0132 against 0.0170): the
#: in-band poles moved by noise-level amounts (15.787 -> 15.786, 54.730 -> 54.731 Hz) and
#: the properness of its close pair at 15.8/15.9 Hz follows (main's code at these poles gives
#: 0.0183 too; seeds 2/3: 0.0193 -> 0.0238, 0.0115 -> 0.0106).
#: The truss's excess was in the transfers between N33.x and N41.y (and N42.y, N34.y), between
#: 21 and 40 Hz, where its close pair (15.79/15.87 Hz, residues nearly opposite there) nearly
#: cancels: the proper modes change each within its noise (0.5 and 1.0 sigma; their sum 2.1
#: sigma of the summed residue, seeds 2/3: 2.7, 1.6), but phib fitted to the residues, whose
#: largest entries dominate, moved the anti-resonances of those small transfers.  The pair's
#: rows of phib fitted to the identified FRF relative to its level (the logLS cost linearised,
#: step 6): 0.0183 -> 0.0089 against 0.0171 (seeds 2/3: 0.0238 -> 0.0097, 0.0106 -> 0.0079).
#: (phib refitted on every mode gave 0.0076 here but broke the hybrids' predictions, which
#: build on the residue fit's collocation: ladder's default D-strut 807x -> 0.67x.)
GAP = set()
#: in-band modes (their index among the in-band poles) that cannot be a normal mode on their
#: own and stay residual dynamics: none since the cluster's 10.287 Hz blade mode became one
ALONE = {}


@functools.cache
def _chain(name, noise, weighting="auto"):
    """(test FRF, identified model, normal-mode model without statistics) of one member;
    ``weighting`` is identify's (the default; tests of a mechanism shown on the unweighted
    fit pass ``"none"``)."""
    frf = sd.testbeds.structure(name).frf(n=400, noise=noise, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, weighting=weighting)
        nm = sd.normal_modes(cm, std=False)
    return frf, cm, nm


def _error(model, frf):
    return logls(model.frf(frf.freq, quantity=frf.quantity).H, frf.H)


def test_the_family_is_covered():
    assert {name for name, _ in MEASURED} == set(sd.testbeds.family())


@pytest.mark.parametrize("name,noise", sorted(MEASURED))
def test_normal_modes_reproduce_the_test_on_every_member(name, noise):
    frf, cm, nm = _chain(name, noise)
    e_nm, e_id = _error(nm, frf), _error(cm, frf)
    if (name, noise) not in GAP:
        assert e_nm <= max(3 * e_id, 0.01)                   # acceptance (issue 22)
    assert e_nm <= 1.5 * MEASURED[name, noise]               # locked
    # the record: in-band poles became modes (but those that cannot be one on their own,
    # kept as residual dynamics first, with the reason), out-of-band poles stayed residual,
    # nothing lost
    in_band = np.asarray(cm.in_band, bool)
    alone = np.flatnonzero(in_band)[list(ALONE.get((name, noise), ()))]
    modes = np.setdiff1d(np.flatnonzero(in_band), alone)
    assert nm.properness.poles_used.tolist() == modes.tolist()
    assert nm.properness.poles_left_out.size == 0
    assert nm.n == modes.size and nm.std is None
    if in_band.all() and not alone.size:
        assert nm.residual is None
    else:
        r = nm.residual
        assert r.source[:alone.size].tolist() == alone.tolist()
        assert all(x.startswith("cannot be a normal mode") for x in r.reasons[:alone.size])
        a = alone.size
        k = a + int((~in_band).sum())
        assert r.source[a:k].tolist() == np.flatnonzero(~in_band).tolist()
        assert r.reasons[a:k] == (OUT_OF_BAND,) * (k - a)
        # kept as they are: the identified poles and residues, bit for bit
        assert np.array_equal(r.poles[:k], cm.poles[r.source[:k]])
        assert np.array_equal(r.residues[:k], cm.residues[r.source[:k]])
        assert r.sensors == cm.sensors and r.actuators == cm.actuators
        # then the improper parts of in-band residues, at the identified poles of modes
        assert r.reasons[k:] == (IMPROPER,) * (r.m - k)
        assert set(r.source[k:].tolist()) <= set(modes.tolist())
        assert np.array_equal(r.poles[k:], cm.poles[r.source[k:]])


def test_the_cluster_blade_mode_at_10_287_hz_is_a_normal_mode_at_1_percent():
    """The blade mode that its collocated residues do not scale (within their noise at both
    pairs) is a normal mode: its scaling's phase is a proper mode's (3.40), with a warning."""
    frf, cm, nm = _chain("cluster", 0.01)
    j = int(np.argmin(np.abs(cm.frequency - 10.287)))
    assert abs(cm.frequency[j] - 10.287) < 0.005 and cm.in_band[j]
    assert j in nm.properness.poles_used.tolist()
    # at its pole the residual dynamics hold its improper part only, not the whole mode
    assert all(why == IMPROPER for why, i in zip(nm.residual.reasons, nm.residual.source)
               if i == j)
    assert np.min(np.abs(nm.poles - cm.poles[j])) < 1e-6 * abs(cm.poles[j])   # its pole
    assert np.all(np.linalg.eigvalsh(nm.properness.M_T) > 0)          # positive mass (3.45)
    assert nm.properness.pole_error < 1e-6
    with pytest.warns(RuntimeWarning, match=r"10\.29 Hz.* collocated residues within 3 standard"):
        sd.normal_modes(cm, std=False)


@pytest.mark.parametrize("name,noise", [("plate", 0.0), ("truss", 0.01)])
def test_the_residual_block_matters(name, noise):
    """Without its residual dynamics the model loses the out-of-band poles' contribution."""
    frf, cm, nm = _chain(name, noise)
    assert nm.residual is not None
    assert _error(nm.replace(residual=None), frf) > 2 * _error(nm, frf)


def test_a_mode_that_cannot_be_made_proper_stays_residual_with_the_reason():
    """A phase-rotated in-band mode (far from proper: no small real root of 3.52) is kept as
    a complex mode; the other in-band poles still become normal modes."""
    frf, cm, _ = _chain("truss", 0.0)
    # the 18.13 Hz mode (index 4 of the unweighted fit's 13 poles; the default, level-weighted
    # fit has two more out of band, at 3.5 and 79.5 Hz, and its index 4 is the close pair's
    # 15.87 Hz, judged with its pair: 3.45 instead)
    b = int(np.argmin(np.abs(cm.frequency - 18.13)))
    R = np.array(cm.residues)
    R[b] = R[b] * 1j
    bad = cm.replace(residues=R)
    with pytest.warns(RuntimeWarning, match=rf"pole\(s\) {b} .*Riccati equation \(3.52\)"):
        nm = sd.normal_modes(bad, std=False)
    out = np.flatnonzero(~np.asarray(cm.in_band, bool)).tolist()
    assert nm.properness.poles_used.tolist() == [j for j in range(cm.n) if j != b and j not in out]
    k = len(out) + 1                                 # then the improper parts (IMPROPER)
    assert nm.residual.source[:k].tolist() == sorted([b] + out)
    assert nm.residual.reasons[k:] == (IMPROPER,) * (nm.residual.m - k)
    reason = dict(zip(nm.residual.source.tolist(), nm.residual.reasons))
    assert "Riccati equation (3.52) has no small real root" in reason[b]
    assert all(reason[j] == OUT_OF_BAND for j in out)
    H = bad.frf(frf.freq, quantity=frf.quantity).H
    # measured 0.0129 before the improper parts were kept, 3e-26 with them (issue 22)
    assert logls(nm.frf(frf.freq, quantity=frf.quantity).H, H) < 1e-12


def test_roving_hammer_orientation_keeps_the_residual_block():
    """The transposed test (few sensors, many actuators) is transformed by reciprocity and
    turned back; its residual block is turned back with it."""
    frf, cm, _ = _chain("truss", 0.0)
    # the transposed copy has no statistics, so no improper parts (IMPROPER): compare alike
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nm = sd.normal_modes(cm.replace(statistics=None), std=False)
    cm_t = cm.replace(residues=np.swapaxes(cm.residues, 1, 2), E=np.asarray(cm.E).T,
                      F=np.asarray(cm.F).T, sensors=cm.actuators, actuators=cm.sensors,
                      collocated=tuple((a, s) for s, a in cm.collocated))
    with pytest.warns(RuntimeWarning, match="transposed test"):
        nm_t = sd.normal_modes(cm_t, std=False)
    assert (nm_t.ns, nm_t.na) == (cm.na, cm.ns)
    assert nm_t.residual.sensors == cm.actuators
    H, Ht = nm.frf(frf.freq).H, nm_t.frf(frf.freq).H
    assert np.abs(np.swapaxes(Ht, 1, 2) - H).max() < 1e-12 * np.abs(H).max()


@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_statespace_carries_the_residual_block(quantity):
    frf, cm, nm = _chain("plate", 0.0)
    f = frf.freq
    H = nm.frf(f, quantity=quantity).H
    G = nm.to_statespace(quantity, omega_c=1e3 * 2 * np.pi * f.max(), rigid_body=True)
    Hs = np.moveaxis(G(2j * np.pi * f), -1, 0)
    # exact but for the correction filter of the improper terms (2 w / w_c = 2e-3)
    tol = 1e-9 if quantity == "displacement" else 3e-3
    assert np.abs(Hs - H).max() <= tol * np.abs(H).max()
    names = [s for s in G.state_labels if s.startswith("r") or s.startswith("dr")]
    assert len(names) >= 2 * nm.residual.m


def test_residual_mass_is_stable_by_default_and_rigid_on_request():
    frf, cm, nm = _chain("truss", 0.01)
    assert nm.F is not None and nm.residual is not None
    rigid, stable = nm.to_statespace(rigid_body=True), nm.to_statespace()
    lam_r, lam_s = np.linalg.eigvals(rigid.A), np.linalg.eigvals(stable.A)
    assert np.sum(np.abs(lam_r) < 1e-9) == 2 * nm.na                 # double integrators (2.24)
    assert lam_s.real.max() < 0                                       # asymptotically stable
    assert stable.nstates == rigid.nstates + nm.na                    # 3 states per input
    wf = 0.1 * 2 * np.pi * cm.band[0]                                 # a decade below the band
    assert np.sum(np.abs(lam_s + wf) < 1e-3 * wf) == 3 * nm.na      # triple poles at -w_f
    f = frf.freq
    H = nm.frf(f).H
    Hr = np.moveaxis(rigid(2j * np.pi * f), -1, 0)
    Hs = np.moveaxis(stable(2j * np.pi * f), -1, 0)
    assert np.abs(Hr - H).max() < 1e-9 * np.abs(H).max()
    # F (s + 3 w_f)/(s + w_f)^3 against F/s^2: relative error 3 (w_f/w)^2 (1 + 3 w_f/w) of F
    s = 2j * np.pi * f[:, None, None]
    x = wf / (2 * np.pi * f[:, None, None])
    bound = 3 * x**2 * (1 + 3 * x) * np.abs(nm.F[None] / s**2)
    assert np.all(np.abs(Hs - H) <= bound + 1e-9 * np.abs(H).max())


def test_operations_keep_the_residual_block_at_the_tested_io():
    frf, cm, nm = _chain("plate", 0.0)
    n = nm.n
    for m2 in (nm.modified(dOmega=0.01 * nm.Omega), nm.proportional(),
               nm.with_feedback(nm.phib[:, :1], nm.phib[:, :1].T, kv=1.0, modal=True)):
        assert m2.residual is nm.residual and m2.n == n
    # the uncertain model (5.5) bounds the normal modes; given no bounds for the residual
    # dynamics it keeps them certain, and says so
    with pytest.warns(RuntimeWarning, match="residual dynamics .* certain in the uncertain"):
        um = nm.replace(F=None).uncertain(dOmega=0.01 * np.abs(nm.Omega))
    assert um.model.n == n
    # placed by label: a model on a subset of the sensors gets the residual at those only
    sub = nm.replace(cphi=nm.cphi[[2, 0]], E=None if nm.E is None else nm.E[[2, 0]],
                     F=None if nm.F is None else nm.F[[2, 0]], sensors=nm.sensors[2::-2])
    f = frf.freq
    assert np.allclose(sub.frf(f).H, nm.frf(f).H[:, [2, 0]], rtol=1e-12, atol=0)


def test_round_trips_keep_the_residual_block(tmp_path):
    frf, cm, nm = _chain("plate", 0.0)
    path = tmp_path / "nm.npz"
    sd.save(nm, path)
    for back in (sd.load(path), pickle.loads(pickle.dumps(nm))):
        r, b = nm.residual, back.residual
        assert np.array_equal(b.poles, r.poles) and np.array_equal(b.residues, r.residues)
        assert b.reasons == r.reasons and np.array_equal(b.source, r.source)
        assert b.sensors == r.sensors and b.actuators == r.actuators
        assert not b.residues.flags.writeable
        assert np.array_equal(back.frf(frf.freq).H, nm.frf(frf.freq).H)
        assert back.properness.poles_used.tolist() == nm.properness.poles_used.tolist()


def test_statistics_cover_the_normal_modes_only_and_can_be_skipped():
    frf, cm, nm = _chain("plate", 0.01)
    assert cm.statistics is not None and nm.std is None and nm.residual is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full = sd.normal_modes(cm)
    n, ns, na = full.n, full.ns, full.na
    assert {k: v.shape for k, v in full.std.items()} == {
        "Omega": (n, n), "Gamma": (n, n), "cphi": (ns, n), "phib": (n, na)}
    assert np.all(np.isfinite(np.diag(full.std["Omega"])))
    assert np.all(np.diag(full.std["Omega"]) > 0)
    # the same model otherwise
    assert np.array_equal(full.Omega, nm.Omega) and np.array_equal(full.cphi, nm.cphi)
    assert full.residual.source.tolist() == nm.residual.source.tolist()


#: where the logLS rule runs out of significant parts before its end point (measured logLS of
#: nm against cm): the ladder at 1% since identify's default keeps its level-weighted fit
#: (a434751): the target, the identified model's logLS against the data, fell 0.00191 ->
#: 0.00047, and nm reaches 0.00069 (1.46x it) with every part above three sigma kept (seven
#: poles: 23.8, 36.5, 37.7, 64.2, 78.4, 79.9, 86.0 Hz) -- while nm against the exact response
#: went 0.00244 -> 0.00098 and against the data 0.00248 -> 0.00102 (unweighted -> default)
SHORT = {("ladder", 0.01): 0.0006884}
#: where the rule stops with parts above three sigma left (an open gap, locked at the measured
#: figure and held to the issue's max(3x, 0.01)): truss_high at 1% since the level-weighted fit
#: is kept there -- the identified model 0.00012 against the data, nm 0.00027 against it, two
#: in-band parts at z = 6.0 and 9.8 not kept (nm against the data 0.00084 -> 0.00041,
#: unweighted -> default)
LEFT = {("truss_high", 0.01): 0.0002705}


@pytest.mark.parametrize("name,noise", sorted(MEASURED))
def test_normal_modes_as_close_to_the_identified_model_as_it_is_to_the_data(name, noise):
    """The logLS rule's end point on every member: the normal-mode model (with its residual
    dynamics) against the identified model, on the identification's lines, within the
    identified model's own logLS against the data (``cm.search.logls``), noise-free and at
    1% -- what the state count is spent on."""
    frf, cm, nm = _chain(name, noise)
    lines = np.linspace(*cm.band, cm.search.lines)
    err = logls(nm.frf(lines).H, cm.frf(lines).H)
    if (name, noise) in LEFT:
        assert err <= LEFT[name, noise] * 1.01 and err <= max(3 * cm.search.logls, 0.01)
        return
    if (name, noise) in SHORT:
        # the rule ran out of candidates: every in-band part left is within three standard
        # deviations (z = 2.3-2.9), so it is not kept; locked at the measured figure
        from sdctrl.identification._mode_split import IMPROPER_SIGMAS, residues_at

        kept = nm.residual.source[[why == IMPROPER for why in nm.residual.reasons]]
        free = np.setdiff1d(nm.properness.poles_used, kept)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            std = np.asarray(cm.residue_std())[free]
        D = cm.residues[free] - residues_at(nm, cm.poles[free])
        assert np.all(np.sqrt(np.mean(np.abs(D) ** 2 / std**2, axis=(1, 2))) <= IMPROPER_SIGMAS)
        assert err <= SHORT[name, noise] * 1.01
        return
    assert err <= cm.search.logls * (1 + 1e-9) + 1e-20
