"""Closing the loop with measured data: an undeclared effect in a second test, step 8.

The structure is tested again after a change nobody declared (:data:`PLANTED`); the
updated model of step 4 no longer matches, and :func:`sdctrl.diagnose` must name the
effect, fit its size and report the error before and after.  Written against the
contract of ``sd.diagnose`` in API.md: ``Diagnosis.effects[0].kind / .location /
.parameters``, ``.error_before``, ``.error_after``, ``.model``, ``.report()``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.report import Check

__all__ = ["PLANTED", "Diagnosed", "Planted", "diagnose_retest", "diagnosis_page",
           "planted_structure"]

#: tolerance on the fitted size of the planted effect (1% noise)
SIZE_TOL = 0.05
#: the error after the diagnosis must be below this fraction of the error before
ERROR_RATIO = 0.1


@dataclass(frozen=True, eq=False)
class Planted:
    """An effect added to the true structure before the second test.

    Parameters
    ----------
    kind : str
        Effect kind as :func:`sdctrl.diagnose` names it.
    location : str
        Node (or element) it applies to, FE labels.
    parameters : dict
        Its size in SI units (``dm`` kg for a mass change).
    story : str
        What happened, in words.
    """

    kind: str
    location: str
    parameters: dict
    story: str


#: the undeclared effect of the demo's second test
PLANTED = Planted("mass_change", "N14", {"dm": 1.0},
                  "a 1 kg instrument box bolted to truss node N14 between the two tests")


def planted_structure(fe, planted: Planted = PLANTED):
    """The true structure with the planted effect (a lumped mass on a node's translations).

    Parameters
    ----------
    fe : FEModel
        True structure.
    planted : Planted
        The effect (``mass_change`` only).

    Returns
    -------
    FEModel
    """
    import scipy.sparse as sp

    from sdctrl.fe import FEModel

    if planted.kind != "mass_change":
        raise ValueError(f"planted: only a mass_change is simulated, got {planted.kind!r}")
    d = np.zeros(fe.N)
    d[fe.dof_index([f"{planted.location}.{a}" for a in "xyz"])] = planted.parameters["dm"]
    return FEModel(fe.M + sp.diags(d), fe.K, fe.C, dofs=fe.dofs, nodes=dict(fe.nodes),
                   elements=fe.elements)


def _labels(location) -> list[str]:
    if location is None:
        return []
    if isinstance(location, str):
        return [location]
    if isinstance(location, dict):
        return [str(v) for v in location.values()]
    try:
        return [x for item in location for x in _labels(item)]
    except TypeError:
        return [str(location)]


def names_node(location, node: str) -> bool:
    """Whether an effect's ``location`` names ``node`` (a node name or its DOF labels)."""
    return any(lab.split(".")[0] == node for lab in _labels(location))


@dataclass(frozen=True, eq=False)
class Diagnosed:
    """Diagnosis of the second test.

    Parameters
    ----------
    frf : FRF
        The second test.
    model : NormalModeModel
        The model diagnosed (the updated FE model on the test's sensors and shakers).
    diagnosis : Diagnosis
        Output of :func:`sdctrl.diagnose`.
    planted : Planted
        The truth.
    """

    frf: object
    model: object
    diagnosis: object
    planted: Planted

    @property
    def top(self):
        """The first effect found (None when none)."""
        eff = self.diagnosis.effects
        return eff[0] if len(eff) else None

    def size_error(self) -> float:
        """Relative error of the fitted size of the planted effect's parameter."""
        key, true = next(iter(self.planted.parameters.items()))
        got = (self.top.parameters or {}).get(key, np.nan) if self.top is not None else np.nan
        return float(got / true - 1)

    @property
    def summary(self) -> str:
        """One line."""
        d, t = self.diagnosis, self.top
        if t is None:
            return f"no effect found; error {d.error_before:.3g}"
        sizes = ", ".join(f"{k} = {v:.4g}" for k, v in (t.parameters or {}).items())
        return (f"{t.kind} at {t.location} ({sizes}); error {d.error_before:.3g} -> "
                f"{d.error_after:.3g}")

    def checks(self) -> list[Check]:
        """Key numbers against the planted truth."""
        d, t, p = self.diagnosis, self.top, self.planted
        key, true = next(iter(p.parameters.items()))
        got = (t.parameters or {}).get(key, np.nan) if t is not None else np.nan
        ratio = d.error_after / d.error_before if d.error_before > 0 else np.nan
        return [Check("kind of the first effect", None if t is None else t.kind, p.kind),
                Check("it names the planted location", t is not None and names_node(
                    t.location, p.location), True),
                Check(f"fitted size {key}", float(got), float(true), self.size_error(),
                      SIZE_TOL),
                Check("error after / error before", float(ratio), 0.0, float(ratio),
                      ERROR_RATIO)]

    def numbers(self) -> dict:
        """Key numbers for ``summary.json``."""
        d, t = self.diagnosis, self.top
        return {"kind": None if t is None else t.kind,
                "location": None if t is None else _labels(t.location),
                "parameters": None if t is None else dict(t.parameters or {}),
                "error_before": d.error_before, "error_after": d.error_after,
                "planted": {"kind": self.planted.kind, "location": self.planted.location,
                            "parameters": dict(self.planted.parameters)}}

    def section(self, doc) -> None:
        """Write the diagnosis section.

        Parameters
        ----------
        doc : sdctrl.report.Document
            The report the section is appended to.
        """
        from sdctrl import plot

        d, frf = self.diagnosis, self.frf
        s = doc.section("diagnosis", "Diagnosis of an undeclared effect in a second test")
        s.paragraph(
            f"The structure is tested again after a change nobody declared ({self.planted.story})"
            ". The updated model of the FE-update section no longer matches the new test; "
            "`sd.diagnose(model, frf, fe=fe)` traces the residual to the effects the model "
            "lacks (candidate masses, dampers, stiffness changes on the FE model's nodes and "
            "elements, missing modes, delays...), fits their size and applies the best, with "
            "the error (logLS) before and after.")
        s.key_numbers(self.checks())
        s.markdown(d.report())
        H = self.model.frf(frf.freq, frf.quantity).H
        err = np.mean(np.abs(np.log(H / frf.H)) ** 2, axis=0)
        worst = np.argsort(err.ravel())[::-1][:2]
        chans = [(frf.sensors[k // err.shape[1]], frf.actuators[k % err.shape[1]])
                 for k in worst]
        s.figure(plot.bode([frf, self.model, d.model], labels=[
            "second test", "model before", "model after diagnosis"], channels=chans,
            max_cols=2), "The two channels the undeclared effect changes most: test, model "
            "before and after the diagnosis.", "diagnosis_bode")


def diagnose_retest(test, update, noise: float | None = None, seed: int | None = None,
                    planted: Planted = PLANTED, executor=None,
                    progress: bool | None = None) -> Diagnosed:
    """Step 8: simulate the second test with the planted effect and diagnose it.

    Parameters
    ----------
    test : SimulatedTest
        The first test (frequency lines, noise level) and the true structure.
    update : Update
        Its ``result.model`` (updated FE model on the test I/O) is diagnosed against the
        second test, with ``result.fe`` for the candidate locations.
    noise : float, optional
        Noise of the second test (default: that of the first).
    seed : int, optional
        Its seed (default: the first test's plus one).
    planted : Planted
        The undeclared effect.
    executor : concurrent.futures.Executor, optional
        For the candidate scan of :func:`sdctrl.diagnose`.
    progress : bool, optional
        Progress bar policy.

    Returns
    -------
    Diagnosed
    """
    import sdctrl
    from sdctrl.demo._simulated import simulate_test
    from sdctrl.testbeds._truss import SENSORS, SHAKERS, TESTBED_BAND

    noise = test.noise if noise is None else float(noise)
    seed = test.seed + 1 if seed is None else int(seed)
    frf2 = simulate_test(planted_structure(test.fe, planted), test.frf.freq, noise, seed,
                         SENSORS, SHAKERS, 5 * TESTBED_BAND[1])
    model = update.result.model
    diagnosis = sdctrl.diagnose(model, frf2, fe=update.result.fe, executor=executor,
                                progress=progress)
    return Diagnosed(frf2, model, diagnosis, planted)


def diagnosis_page(diagnosis, model_path: str, data_path: str):
    """The HTML report of ``sdctrl diagnose``: the markdown report and its figure embedded.

    Parameters
    ----------
    diagnosis : Diagnosis
        Output of :func:`sdctrl.diagnose`.
    model_path, data_path : str
        The files diagnosed (named in the title).

    Returns
    -------
    sdctrl.report.Document
        One section; ``.to_html()`` is a self-contained page.
    """
    import os

    from sdctrl.plot import diagnosis as figure
    from sdctrl.report import Document
    from sdctrl.demo._runner import agg_backend

    agg_backend()
    d = diagnosis
    doc = Document(f"sdctrl diagnose: {os.path.basename(model_path)} against "
                   f"{os.path.basename(data_path)}",
                   "The residual between the model and the measured FRFs traced to the effects "
                   "the model lacks, their fitted sizes (SI units) and the error (complex logLS, "
                   "3.12) before and after.")
    s = doc.section("diagnosis", "Diagnosis")
    s.markdown(d.report())
    if d.frf is not None and d.initial is not None:
        s.figure(figure(d), "Data, model before and after the corrections at the worst "
                 "channel, residual per line, and residual maps before/after.", "diagnosis")
    return doc
