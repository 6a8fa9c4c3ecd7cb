"""The model side of the story: FE update, hybrid model, D-strut placement.

Steps of ``sdctrl demo`` (see :mod:`sdctrl.demo._test_side` for the record conventions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.data._coherence import measured_coherence
from sdctrl.report import Check, psd_check

__all__ = ["WRONG", "Hybrid", "Placement", "Update", "build_hybrid", "place_strut", "update_fe"]

#: the deliberately wrong FE model of the demo: post links 25% soft, plates 25% heavy
WRONG = {"link_stiffness": 0.75, "plate_mass": 1.25}
#: the lumped plate masses (centre and corners of plates A, B, C)
PLATE_NODES = tuple(f"N{k}" for k in (*range(31, 36), *range(38, 43), *range(45, 50)))
#: relative tolerance on the updated physical properties
UPDATE_TOL = 0.02
#: modes kept in the FE reference models (up to ~5x the band top)
N_FE_MODES = 40


def _fe_model(fe, n: int = N_FE_MODES):
    from sdctrl.testbeds._truss import SENSORS, SHAKERS

    return fe.normal_mode_model(list(SHAKERS), list(SENSORS), n, static=True)


def _logls(model, frf) -> float:
    from sdctrl.updating._costs import logls

    return float(logls(model.frf(frf.freq, frf.quantity), frf))


def _band_hz(fe, n: int = 20) -> np.ndarray:
    from sdctrl.testbeds._truss import TESTBED_BAND

    f, _ = fe.modes(n)
    return f[(f > TESTBED_BAND[0]) & (f < TESTBED_BAND[1])]


# --- step 4: FE update ---------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Update:
    """A deliberately wrong FE model updated against the test (chapter IV).

    Parameters
    ----------
    wrong : FEModel
        The analyst's model (post links 25% soft, plates 25% heavy).
    result : UpdateResult
        Output of :func:`sdctrl.update`.
    identifiability : Identifiability
        Output of :func:`sdctrl.identifiability` before the update.
    truth : dict
        True parameter values (those that make the wrong model right).
    hz : dict
        In-band undamped frequencies (Hz) of the true, wrong and updated models.
    """

    wrong: object
    result: object
    identifiability: object
    truth: dict
    hz: dict

    def property_errors(self) -> dict:
        """Relative error of each recovered physical property ``(1 + p) factor - 1``."""
        factor = {"links": WRONG["link_stiffness"], "plates": WRONG["plate_mass"]}
        return {k: (1 + v) * factor[k] - 1 for k, v in self.result.values.items()}

    def freq_errors(self) -> tuple[float, float]:
        """Max relative in-band frequency error of the FE model before and after."""
        t = self.hz["true"]
        n = min(t.size, self.hz["before"].size, self.hz["after"].size)
        return (float(np.abs(self.hz["before"][:n] / t[:n] - 1).max()),
                float(np.abs(self.hz["after"][:n] / t[:n] - 1).max()))

    @property
    def summary(self) -> str:
        """One line."""
        e = self.property_errors()
        return ("links " + f"{self.result.values['links']:+.4f} (true {self.truth['links']:+.4f})"
                f", plates {self.result.values['plates']:+.4f} (true "
                f"{self.truth['plates']:+.4f}); properties within "
                f"{max(abs(v) for v in e.values()):.1e}; logLS {self.result.cost_before:.3g} -> "
                f"{self.result.cost_after:.3g}")

    def checks(self) -> list[Check]:
        """Key numbers against the truth."""
        r, e = self.result, self.property_errors()
        out = [Check(f"parameter {k}", float(r.values[k]), float(self.truth[k]), float(e[k]),
                     UPDATE_TOL) for k in self.truth]
        before, after = self.freq_errors()
        out += [Check("max FE frequency error in the band, before", before, 0.0, before),
                Check("max FE frequency error in the band, after", after, 0.0, after, 3e-3),
                Check("logLS cost before", float(r.cost_before)),
                Check("logLS cost after", float(r.cost_after))]
        return out

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        b, a = self.freq_errors()
        return {"values": dict(self.result.values), "truth": dict(self.truth),
                "property_errors": self.property_errors(), "cost_before": self.result.cost_before,
                "cost_after": self.result.cost_after, "max_freq_error_before": b,
                "max_freq_error_after": a}

    def section(self, doc, frf) -> None:
        """Write the FE-update section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        frf : FRF
            The test (for the before/after overlay).
        """
        from sdctrl import plot

        r = self.result
        s = doc.section("update", "FE model update of a deliberately wrong model")
        s.paragraph(
            f"The analyst's FE model `sd.testbed(link_stiffness={WRONG['link_stiffness']}, "
            f"plate_mass={WRONG['plate_mass']})` has post links 25% too soft and plates 25% "
            "too heavy: its modes in the band are 5-20% low. Two parameters (4.15) built "
            "from its own element groups and nodes, `fe.stiffness_parameter('links', "
            "section=['post_AB', 'post_C'])` and `fe.mass_parameter('plates', ...)`, are "
            "first checked for identifiability (Table 4.1), then `sd.update` minimises the "
            "logLS cost (3.12) on a reanalysed reduced model (modes plus static correction "
            "modes, 4.23), after a first stage on MAC-paired frequencies that keeps it out of "
            "logLS's local minima. The damping comes from the identified normal modes.")
        s.key_numbers(self.checks())
        s.markdown(self.identifiability.report())
        s.markdown(r.report())
        chans = [(frf.sensors[i], frf.actuators[a]) for i, a in frf.collocated[:3]]
        s.figure(plot.bode([frf, _fe_model(self.wrong), r.model], labels=[
            "test", "wrong FE model", "updated FE model"], channels=chans, max_cols=3),
            "Test, wrong and updated FE models at three collocated pairs.", "update_bode")


def update_fe(test, normal_modes, progress: bool | None = None, ident=None) -> Update:
    """Step 4: update the deliberately wrong FE model against the test.

    The identifiability check (Table 4.1) and the update use the identified normal modes'
    damping; the check's error level is the misfit of the identification of step 2 when
    given (the test has no coherence measuring its noise), so the test is not identified a
    second time.

    Parameters
    ----------
    test : SimulatedTest
        The test (labels are FE DOF labels) and the true structure.
    normal_modes : NormalModes
        Identified normal modes (their damping is used).
    progress : bool, optional
        Progress bar policy.
    ident : Identification, optional
        The identified complex modes of step 2 (their misfit gives the error level).

    Returns
    -------
    Update
    """
    from sdctrl.testbeds._truss import testbed
    from sdctrl.updating import identifiability, update

    wrong = testbed(**WRONG)
    params = [wrong.stiffness_parameter("links", section=["post_AB", "post_C"]),
              wrong.mass_parameter("plates", list(PLATE_NODES))]
    noise = None
    if ident is not None and measured_coherence(test.frf) is None:
        from sdctrl.updating._placed_test import error_level, place_test

        noise = error_level(place_test(wrong, test.frf, None), ident.cm)[0]
    check = identifiability(wrong, test.frf, params, damping=normal_modes.nm, noise=noise)
    res = update(wrong, test.frf, params, damping=normal_modes.nm, progress=progress)
    truth = {"links": 1 / WRONG["link_stiffness"] - 1, "plates": 1 / WRONG["plate_mass"] - 1}
    hz = {"true": _band_hz(test.fe), "before": _band_hz(wrong), "after": _band_hz(res.fe)}
    return Update(wrong, res, check, truth, hz)


# --- step 5: hybrid ------------------------------------------------------------------------
#: an untested point where the hybrid model is asked to predict (plate C centre, vertical)
UNTESTED = "N45.z"


@dataclass(frozen=True, eq=False)
class Hybrid:
    """Hybrid test/FE model (5.1) and its accuracy.

    Parameters
    ----------
    model : HybridModel
        The hybrid model.
    costs : dict
        logLS against the test of the identified normal modes, hybrid, wrong and updated FE
        models and of the truth itself (the noise floor).
    untested : dict
        logLS at the untested output :data:`UNTESTED` against the true structure: the
        hybrid's and the wrong FE model's predictions.
    source : NormalModeModel, optional
        The normal-mode model the hybrid was built from when it is not the one of the
        normal-modes section (every identified pole, :func:`sdctrl.normal_modes` default).
    """

    model: object
    costs: dict
    untested: dict
    source: object = None

    def counts(self) -> tuple[int, int, int]:
        """Modes of the hybrid: measured in the band, measured outside it, from the FE."""
        h = self.model
        meas = h.n if getattr(h, "measured", None) is None else int(np.sum(h.measured))
        rec = getattr(self.source, "properness", None)
        inside = meas if rec is None or rec.in_band is None else int(np.sum(rec.in_band))
        return inside, meas - inside, h.n - meas

    @property
    def summary(self) -> str:
        """One line."""
        inside, outside, fe = self.counts()
        extra = f" + {outside} fitted just outside it" if outside else ""
        return (f"{inside + outside + fe} modes: {inside} measured in the band{extra}, {fe} "
                f"from the FE model outside the band; logLS vs test {self.costs['hybrid']:.3g} "
                f"(wrong FE {self.costs['wrong FE']:.3g})")

    def checks(self) -> list[Check]:
        """Key numbers against the truth."""
        c, u = self.costs, self.untested
        built = getattr(self.model, "construction", None)
        pairing = None if built is None else built.pairing
        out = [] if self.source is None else psd_check(self.source)
        out += [Check(f"logLS vs test: {k}", float(v)) for k, v in c.items()]
        if pairing is not None and pairing.mac is not None:
            out.append(Check("smallest MAC of the FE/test mode pairing",
                             float(np.min(pairing.mac))))
        out += [Check(f"logLS at untested {UNTESTED} vs truth: hybrid", float(u["hybrid"])),
                Check(f"logLS at untested {UNTESTED} vs truth: wrong FE", float(u["wrong FE"]))]
        return out

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        return {"n_modes": int(self.model.n), "logls": dict(self.costs),
                "untested_logls": dict(self.untested)}

    def section(self, doc, fe) -> None:
        """Write the hybrid section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        fe : FEModel
            The updated FE model (geometry of the mode shapes).
        """
        from sdctrl import plot

        h = self.model
        inside, outside, n_fe = self.counts()
        s = doc.section("hybrid", "Hybrid model: measured modes on the FE model")
        s.paragraph(
            "`sd.hybrid(fe, nm, sensors)` (5.1): the identified frequencies and full damping "
            "matrix are kept, the measured shapes are expanded onto every FE DOF (4.7) and "
            "the FE modes outside the band are appended. Its outputs at untested DOFs and "
            "inputs at untested points come from the expanded shapes (`.with_io`). The "
            f"prediction at the untested DOF `{UNTESTED}` is compared with the true structure.")
        s.paragraph(self._models_paragraph(inside, outside, n_fe))
        s.key_numbers(self.checks())
        meas = np.flatnonzero(np.ones(h.n, bool) if getattr(h, "measured", None) is None
                              else h.measured)
        f = h.frequency[meas]
        close = int(np.argmin(np.diff(f) / f[1:])) if f.size > 1 else 0
        pair = [close, min(close + 1, meas.size - 1)]
        names = [f"mode {k + 1}: {f[k]:.2f} Hz undamped" for k in pair]
        s.figure(plot.mode_shapes(fe, h, modes=[int(meas[k]) for k in pair], names=names),
                 f"The close pair of the hybrid model, modes {pair[0] + 1} and {pair[1] + 1} "
                 "of the normal-modes section (undamped frequencies; the table of the "
                 "identification section lists the damped poles): measured frequencies and "
                 "damping, shapes expanded on the FE model.", "hybrid_shapes")

    def _models_paragraph(self, inside: int, outside: int, n_fe: int) -> str:
        txt = (f"The hybrid has {inside + outside + n_fe} modes: the {inside + outside} "
               f"measured normal modes ({inside} in the band")
        txt += (f" and {outside} fitted just outside it, which carries the response of the "
                "modes beyond the band)" if outside else ")")
        txt += f" and {n_fe} modes of the updated FE model outside the band."
        if self.source is not None:
            n = self.source.n
            txt += (f" It is built from a second normal-mode model, of {n} modes: "
                    f"`sd.normal_modes(cm)` on every identified pole, as `sd.hybrid` "
                    f"recommends, where the normal-modes section transforms the {inside} "
                    "poles of the band alone (`modes=cm.in_band`) for its comparison with "
                    "the true modes of the band. Its damping matrix is checked below "
                    f"(3.45), and any warning of its construction is listed at the end of "
                    "this section.")
        return txt


def build_hybrid(test, normal_modes, update, ident=None) -> Hybrid:
    """Step 5: hybrid model of the identified modes on the updated FE model.

    Parameters
    ----------
    test : SimulatedTest
        The test and the truth.
    normal_modes : NormalModes
        Identified normal modes (of the band).
    update : Update
        The updated FE model.
    ident : Identification, optional
        The identified complex modes: when given, the hybrid is built from the normal
        modes of every identified pole (the pole fitted just above the band carries the
        modes beyond it; the hybrid pairs it with an FE mode or absorbs it), as
        :func:`sdctrl.hybrid` recommends.

    Returns
    -------
    Hybrid
    """
    from sdctrl.hybrids._build import hybrid
    from sdctrl.identification import normal_modes as to_normal_modes
    from sdctrl.testbeds._truss import SENSORS, SHAKERS

    frf = test.frf
    # every pole's normal modes: their statistics (3.4) are read nowhere (the hybrid keeps
    # the measured Omega, Gamma and shapes; step 3 reports the band's statistics)
    nm = normal_modes.nm if ident is None else to_normal_modes(ident.cm, std=False)
    source = None if nm is normal_modes.nm else nm
    h = hybrid(update.result.fe, nm, list(SENSORS))
    truth = _fe_model(test.fe)
    costs = {"identified normal modes": _logls(nm, frf), "hybrid": _logls(h, frf),
             "wrong FE": _logls(_fe_model(update.wrong), frf),
             "updated FE": float(update.result.cost_after),
             "true structure (noise floor)": _logls(truth, frf)}
    ref = test.fe.normal_mode_model(list(SHAKERS), [UNTESTED], N_FE_MODES, static=True)
    exact = ref.frf(frf.freq, frf.quantity)
    untested = {"hybrid": _logls(h.with_io(c=[UNTESTED]), exact),
                "wrong FE": _logls(update.wrong.normal_mode_model(
                    list(SHAKERS), [UNTESTED], N_FE_MODES, static=True), exact)}
    return Hybrid(h, costs, untested, source)


# --- step 6: D-strut placement -------------------------------------------------------------
#: D-strut dashpot (N s/m)
KV = 3e4


@dataclass(frozen=True, eq=False)
class Placement:
    """D-strut placement study on the hybrid model and its closed-loop RMS (5.3-5.4).

    Parameters
    ----------
    study : PlacementStudy
        Ranked candidate bars.
    bar : (str, str)
        The best bar.
    rms : dict
        Band-limited RMS of the plate sensors: hybrid ``open``/``closed`` and the true
        structure's ``true open``/``true closed`` (dashpot added to its damping).
    closed : NormalModeModel
        The hybrid model with the strut closed.
    outputs : tuple of str
        The sensors whose RMS is reduced.
    """

    study: object
    bar: tuple
    rms: dict
    closed: object
    outputs: tuple

    def reductions(self) -> tuple[float, float]:
        """Mean over the plate sensors of each one's RMS reduction (the measure of
        ``study.table``), predicted by the hybrid and on the true structure."""
        r = self.rms
        pred = np.mean(1 - np.asarray(r["closed"]) / np.asarray(r["open"]))
        true = np.mean(1 - np.asarray(r["true closed"]) / np.asarray(r["true open"]))
        return float(pred), float(true)

    @property
    def summary(self) -> str:
        """One line."""
        p, t = self.reductions()
        return (f"best of {len(self.study.candidates)} bars: {self.bar[0]}-{self.bar[1]}; "
                f"plate RMS -{100 * p:.1f}% predicted (mean over the plate sensors), "
                f"-{100 * t:.1f}% on the true structure")

    def checks(self) -> list[Check]:
        """Key numbers against the truth."""
        p, t = self.reductions()
        return [Check("mean RMS reduction of the plate sensors (hybrid vs true structure)",
                      100 * p, 100 * t, 100 * (p - t), 2.0, "%", "points")]

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        p, t = self.reductions()
        return {"bar": list(self.bar), "kv": KV, "rms_reduction": p, "true_rms_reduction": t}

    def section(self, doc, hybrid) -> None:
        """Write the placement section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        hybrid : NormalModeModel
            The hybrid model the strut is closed on.
        """
        from sdctrl import plot

        s = doc.section("placement", "Where to put a D-strut: placement and closed-loop RMS")
        s.paragraph(
            f"A D-strut (a dashpot of {KV:g} N s/m replacing a bar, `F = -kv y'`, 5.3-5.4) is "
            f"closed on the hybrid model in each of the {len(self.study.candidates)} truss "
            "bars (`placement_study`); the bars are ranked by the band-limited RMS reduction "
            f"of the {len(self.outputs)} plate sensors for white-noise forces on the six "
            "shakers. The best strut is checked on the true structure (its dashpot added to "
            "the FE damping matrix).")
        s.key_numbers(self.checks())
        s.markdown(self.study.table(5))
        chans = [(self.outputs[0], hybrid.actuators[0]), (self.outputs[-1], hybrid.actuators[2])]
        strut = f"D-strut on {self.bar[0]}-{self.bar[1]}"
        s.figure(plot.bode([hybrid, self.closed], labels=["open loop", strut], channels=chans,
                           freq=np.linspace(8, 60, 1500), quantity="displacement", max_cols=2),
                 "Hybrid model, open loop and with the best D-strut (displacement/force).",
                 "placement_bode")


def place_strut(test, hybrid, update, progress: bool | None = None) -> Placement:
    """Step 6: rank the truss bars for a D-strut and check the best on the true structure.

    Parameters
    ----------
    test : SimulatedTest
        The true structure.
    hybrid : Hybrid
        The hybrid model.
    update : Update
        The updated FE model (geometry of the bars).
    progress : bool, optional
        Progress bar policy.

    Returns
    -------
    Placement
    """
    from sdctrl.closedloop._loops import rms
    from sdctrl.fe import FEModel
    from sdctrl.closedloop._placement import placement_study
    from sdctrl.testbeds._truss import SENSORS, SHAKERS, TESTBED_BAND

    fe, h = update.result.fe, hybrid.model
    plates = ("N32", "N33", "N34", "N35", "N39", "N40", "N41", "N42", "N46", "N47", "N48",
              "N49")
    outputs = tuple(s for s in SENSORS if s.split(".")[0] in plates)
    truss = [e for e in fe.elements if max(int(e[0][1:]), int(e[1][1:])) <= 28]
    study = placement_study(h, fe, TESTBED_BAND, kv=KV, candidates=truss, outputs=outputs,
                            progress=progress)
    bar = tuple(study.best.bar)
    s = fe.strut(*bar)
    closed = h.with_feedback(s, s.T, kv=KV)
    out_idx = [h.sensors.index(o) for o in outputs]

    def band_rms(model):
        return rms(model.to_statespace()[out_idx, :], TESTBED_BAND)

    lab = test.fe
    st = lab.strut(*bar)
    lab_closed = FEModel(lab.M, lab.K, lab.C + KV * st @ st.T, dofs=lab.dofs)
    true_models = [m.normal_mode_model(list(SHAKERS), list(outputs), N_FE_MODES, static=True)
                   for m in (lab, lab_closed)]
    values = {"open": band_rms(h), "closed": band_rms(closed),
              "true open": rms(true_models[0].to_statespace(), TESTBED_BAND),
              "true closed": rms(true_models[1].to_statespace(), TESTBED_BAND)}
    return Placement(study, bar, values, closed, outputs)
