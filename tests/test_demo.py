"""``sdctrl demo`` and ``sdctrl identify`` as a user runs them: a subprocess on the code of
this checkout, its terminal lines, the HTML report (sections, figures, table of contents,
self-contained), the numbers against the truth, and every model file read back."""

import json
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import sdctrl as sd

ROOT = pathlib.Path(__file__).resolve().parents[1]
SECTIONS = ["test", "identification", "normal_modes", "update", "hybrid", "placement",
            "robustness", "diagnosis", "timings"]
FIGURES = {"test": ["true_modes"], "identification": ["stabilisation", "identified_bode",
                                                      "complex_residues"],
           "normal_modes": ["normal_modes_mac"], "update": ["update_bode"],
           "hybrid": ["hybrid_shapes"], "placement": ["placement_bode"], "robustness": ["mu"],
           "diagnosis": ["diagnosis_bode"]}
MODELS = {"identified": "ComplexModeModel", "normal_modes": "NormalModeModel",
          "fe_updated": "FEModel", "updated_model": "NormalModeModel",
          "hybrid": "HybridModel", "uncertain": "UncertainModel"}

def _env():
    env = dict(os.environ, MPLBACKEND="Agg", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def _sdctrl(*args, cwd=None, timeout=600):
    return subprocess.run([sys.executable, "-m", "sdctrl.cli", *args], check=False,
                          capture_output=True, text=True, env=_env(), cwd=cwd or ROOT,
                          timeout=timeout)


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    proc = _sdctrl("demo", "--out", str(out))
    summary = json.loads((out / "summary.json").read_text())
    html = (out / "report.html").read_text(encoding="utf-8")
    return {"proc": proc, "out": out, "summary": summary, "html": html,
            "steps": summary["steps"]}


def _section(html, key):
    m = re.search(rf'<section id="{key}">(.*?)</section>', html, re.DOTALL)
    assert m, f"section {key} missing"
    return m.group(1)


def test_terminal_shows_one_line_per_step_with_its_time(demo):
    lines = demo["proc"].stdout.splitlines()
    steps = [x for x in lines if re.match(r"\[\d/8\] ", x)]
    assert len(steps) == 8, demo["proc"].stdout
    done = [x for x in steps if re.search(r"\(\d+\.\d s\)$", x)]
    assert len(done) >= 7                       # all but a failed step end with their time
    assert lines[-1].startswith("report: ") and "report.html" in lines[-1]
    assert "Traceback" not in demo["proc"].stderr


def test_html_report_is_self_contained_with_contents_and_figures(demo):
    html = demo["html"]
    assert html.startswith("<!DOCTYPE html>") and "<nav>" in html
    for key in SECTIONS:
        assert f'<a href="#{key}">' in html, key
        _section(html, key)
    for key, figs in FIGURES.items():
        sec = _section(html, key)
        for fig in figs:
            m = re.search(rf'<figure id="fig-{fig}"><img alt="{fig}" src="data:image/png;base64,'
                          r'([A-Za-z0-9+/=]+)"', sec)
            assert m and len(m.group(1)) > 20_000, fig           # a real PNG, embedded
    # nothing fetched from elsewhere: every src is an embedded image
    assert not re.search(r'src="(?!data:image/png;base64,)', html)
    assert "<script" not in html
    # every section states its key numbers against the truth
    for key in SECTIONS[1:8]:
        assert '<table class="checks">' in _section(html, key), key
    md = (demo["out"] / "report.md").read_text()
    assert md.startswith("# sdctrl demo") and "## FE model update" in md
    for fig in re.findall(r"!\[[^\]]*\]\((figures/[^)]+\.png)\)", md):
        assert (demo["out"] / fig).stat().st_size > 10_000


def test_every_stated_tolerance_is_met(demo):
    assert demo["proc"].returncode == 0, demo["proc"].stdout[-2000:]
    for key, step in demo["steps"].items():
        assert step["status"] == "ok", (key, step["message"])
        failed = [c["quantity"] for c in step["checks"] if c["passed"] is False]
        assert not failed, (key, failed)


def test_identified_frequencies_within_0p1_percent_of_the_testbed(demo):
    """Checked on the saved model against the testbed's poles computed here independently
    (a 40-mode normal-mode model of the FE with its full projected damping)."""
    cm = sd.load(demo["out"] / "identified.npz")
    fe = sd.testbed()
    truth = fe.normal_mode_model(["N1.x"], ["N1.x"], 40).poles
    f_true = np.abs(truth) / (2 * np.pi)
    truth = truth[(f_true > 8) & (f_true < 60)]
    p = cm.poles[cm.in_band]
    assert p.size == truth.size == 12
    idx = [int(np.argmin(np.abs(np.abs(truth) - abs(x)))) for x in p]
    assert sorted(idx) == list(range(12))                  # each true mode found once
    t = truth[idx]
    assert np.abs(np.abs(p) / np.abs(t) - 1).max() < 1e-3
    # damping ratios too (1% noise): within 5% of each true ratio
    np.testing.assert_allclose(-p.real / np.abs(p), -t.real / np.abs(t), rtol=0.05)
    num = demo["steps"]["identification"]["numbers"]
    assert num["max_frequency_error"] < 1e-3 and num["n_modes"] == num["n_true"] == 12


def test_normal_modes_keep_the_close_pairs_damping_coupling(demo):
    nm = sd.load(demo["out"] / "normal_modes.npz")
    assert nm.n == 12
    i = int(np.argmin(np.abs(nm.frequency - 15.64)))
    rho = abs(nm.Gamma[i, i + 1]) / np.sqrt(nm.Gamma[i, i] * nm.Gamma[i + 1, i + 1])
    assert rho > 0.8                        # strongly coupled by the plate-A damper
    num = demo["steps"]["normal_modes"]["numbers"]
    G, Gt = np.array(num["Gamma"]), np.array(num["Gamma_true"])
    assert abs(G[i, i + 1] / Gt[i, i + 1] - 1) < 0.02


def test_update_recovers_the_true_parameters_within_2_percent(demo):
    num = demo["steps"]["update"]["numbers"]
    # wrong model: links x0.75, plates x1.25; the true corrections make (1 + p) x factor = 1
    assert (1 + num["values"]["links"]) * 0.75 == pytest.approx(1, rel=0.02)
    assert (1 + num["values"]["plates"]) * 1.25 == pytest.approx(1, rel=0.02)
    assert num["cost_after"] < 0.01 * num["cost_before"]
    fe = sd.load(demo["out"] / "fe_updated.npz")
    f_upd, _ = fe.modes(18)
    f_true, _ = sd.testbed().modes(18)
    assert np.abs(f_upd[6:] / f_true[6:] - 1).max() < 3e-3


def test_hybrid_predicts_an_untested_output(demo):
    num = demo["steps"]["hybrid"]["numbers"]
    assert num["untested_logls"]["hybrid"] < 0.05 * num["untested_logls"]["wrong FE"]


def test_hybrid_and_placement_against_the_true_structure(demo):
    num = demo["steps"]["hybrid"]["numbers"]
    assert num["logls"]["hybrid"] < 0.05 * num["logls"]["wrong FE"]
    assert num["untested_logls"]["hybrid"] < 0.5 * num["untested_logls"]["wrong FE"]
    pl = demo["steps"]["placement"]["numbers"]
    assert pl["rms_reduction"] > 0.02 and pl["true_rms_reduction"] > 0.02
    assert abs(pl["rms_reduction"] - pl["true_rms_reduction"]) < 0.02


def test_robust_margin_is_finite_with_upper_and_lower_bounds(demo):
    num = demo["steps"]["robustness"]["numbers"]
    assert num["stable"]
    assert np.isfinite(num["margin"]) and np.isfinite(num["margin_lower"])
    assert 0 < num["margin"] <= num["margin_lower"] <= 1.1 * num["margin"]
    assert num["abscissa_at_delta"]["closed"] > -1e-6 * 2 * np.pi * num["frequency_hz"]
    assert num["samples"][0] == num["samples"][1] > 0
    um = sd.load(demo["out"] / "uncertain.npz")
    assert len(um.blocks) == num["n_blocks"]


def test_every_model_file_loads_back(demo):
    out = demo["out"]
    for stem, kind in MODELS.items():
        obj = sd.load(out / f"{stem}.npz")
        assert type(obj).__name__ == kind, stem
    test = sd.read_uff(out / "test.uff")
    assert test.H.shape == (1000, 31, 6) and len(test.collocated) == 6
    hy = sd.load(out / "hybrid.npz")
    G = hy.to_statespace("acceleration")
    # the documented state count (NormalModeModel.to_statespace, Notes): 2 per mode, the
    # residual dynamics' blocks at the tested I/O, a correction-filter pair per actuator when
    # needed (E, or for acceleration the residual dynamics' s term, 2.19-2.20) and 3 states
    # per actuator for the residual mass F (correction modes a decade below the band); the
    # default hybrid (residual="auto") keeps the test's residual dynamics and F there
    n_res = 0 if hy.residual is None else len(hy.residual.realisation(hy.sensors,
                                                                       hy.actuators)[3])
    n_filter = 2 * hy.na if hy.E is not None or n_res else 0
    n_low = 3 * hy.na if hy.F is not None else 0
    assert G.nstates == 2 * hy.n + n_res + n_filter + n_low and "N32_z" in G.output_labels
    assert sum(x.startswith("zr") for x in G.state_labels) == (hy.na if n_low else 0)
    assert hy.construction.residual.chosen_by == "leave-one-actuator-out"


def test_diagnosis_names_the_planted_effect(demo):
    step = demo["steps"]["diagnosis"]
    assert step["status"] == "ok", step["message"]
    num = step["numbers"]
    # exactly the change: effects within the model's own error on the first test (they
    # remove less than it from the second test, or lower it when applied alone) are prior
    # model errors, not the change
    assert num["changes"] == [{"kind": "mass_change", "location": ["N14"]}], num
    first = num["first_test"]
    alone, removed = first["error_with_each_effect"], first["error_removed_from_second_test"]
    assert len(alone) == len(removed) == len(num["changes"]) + len(num["prior_errors"])
    for k in range(len(alone)):
        prior = alone[k] < first["error"] or removed[k] <= first["error"]
        assert prior == (k in first["prior"])
    assert num["error_after"] <= num["error_after_all_effects"] + first["error"]
    assert num["kind"] == "mass_change"
    assert any(lab.split(".")[0] == "N14" for lab in num["location"])
    assert num["parameters"]["dm"] == pytest.approx(1.0, rel=0.05)
    assert num["error_after"] < num["error_before"] / 10
    sec = _section(demo["html"], "diagnosis")
    assert 'id="fig-diagnosis_bode"' in sec and '<table class="checks">' in sec
    assert sd.read_uff(demo["out"] / "retest.uff").H.shape == (1000, 31, 6)
    assert demo["proc"].returncode == 0


def test_identify_own_data(tmp_path):
    frf = sd.testbed_frf(n=400, band=(8.0, 20.0), noise=0.01, seed=2)
    sd.write_uff(frf, tmp_path / "lab.uff")
    proc = _sdctrl("identify", str(tmp_path / "lab.uff"), "--band", "8", "20", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = [x.split() for x in proc.stdout.splitlines() if re.match(r"\s+\d+\s+\d+\.\d{4}\s", x)]
    f = np.array([float(r[1]) for r in rows if r[5] == "yes"])
    f_true = np.array([9.518, 12.660, 15.786, 15.873, 18.135, 18.630])   # damped, Hz
    assert f.size == 6 and np.abs(f / f_true - 1).max() < 1e-3
    # each frequency and damping with its standard deviation (1% noise: small, positive)
    fs = np.array([float(r[2]) for r in rows if r[5] == "yes"])
    zs = np.array([float(r[4]) for r in rows if r[5] == "yes"])
    assert np.all((fs > 0) & (fs < 1e-3 * f)) and np.all((zs > 0) & (zs < 0.1))
    assert "+- std" in proc.stdout
    out = tmp_path / "lab-sdctrl"
    html = (out / "report.html").read_text()
    for key in ("data", "identification", "normal_modes"):
        _section(html, key)
    assert 'id="fig-stabilisation"' in html
    assert sd.load(out / "identified.npz").in_band.sum() == 6
    assert sd.load(out / "normal_modes.npz").n == 6
    bad = _sdctrl("identify", str(tmp_path / "missing.uff"))
    assert bad.returncode == 2 and "missing.uff" in bad.stderr


def test_identify_own_displacement_data_with_line_weights(tmp_path):
    """``--weighting level`` (``sd.identify``'s): truss_high measured in displacement at 1%
    noise, where the lines at the top of the band weigh ~1/9 of those at its bottom; the
    weighted fit reproduces the exact response to 0.0008 mean logLS against 0.073 (both
    runs' models saved), and the report says which weighting was used."""
    from sdctrl.updating import logls

    st = sd.testbeds.structure("truss_high")
    sd.write_uff(st.frf(quantity="displacement", n=400, noise=0.01, seed=1), tmp_path / "d.uff")
    exact = st.frf(quantity="displacement", n=400)
    err = {}
    for how in ("none", "level"):
        out = tmp_path / how
        proc = _sdctrl("identify", str(tmp_path / "d.uff"), "--weighting", how, "--out",
                       str(out), "--quiet", cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        cm = sd.load(out / "identified.npz")
        assert cm.search.weighting == how
        err[how] = logls(cm.frf(exact.freq, quantity="displacement").H, exact)
        html = (out / "report.html").read_text()
        assert ("weighting=&#x27;level&#x27;" in html or "weighting='level'" in html) == (
            how == "level")
    assert err["level"] <= 0.0015 and err["none"] >= 30 * err["level"]     # 0.0008, 0.073
    bad = _sdctrl("identify", str(tmp_path / "d.uff"), "--weighting", "lines")
    assert bad.returncode == 2 and "--weighting" in bad.stderr


def test_identify_exits_0_when_the_model_exists_and_reports_a_failed_step(tmp_path):
    """Issue 26: normal modes of a test with one sensor and six modes are never all or
    nothing: one normal mode, the other poles kept as complex-mode residual dynamics, each
    named with its reason in the report, never a traceback; the command exits 0."""
    frf = sd.testbed_frf(n=400, band=(8.0, 20.0), noise=0.01, seed=2)
    s, a = frf.collocated[0]
    one = sd.FRF(frf.freq, frf.H[:, [s]][:, :, [a]], quantity=frf.quantity,
                 sensors=[frf.sensors[s]], actuators=[frf.actuators[a]], collocated=[(0, 0)])
    sd.save(one, tmp_path / "one")
    proc = _sdctrl("identify", str(tmp_path / "one.npz"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "normal modes: ok" in proc.stdout
    out = tmp_path / "one-sdctrl"
    html = (out / "report.html").read_text()
    sec = _section(html, "normal_modes")
    assert "fewer sensors (1) than modes" in sec
    assert "Traceback" not in html and 'File "' not in html
    cm = sd.load(out / "identified.npz")
    nm = sd.load(out / "normal_modes.npz")
    # the saved normal modes are those of the band's poles (modes=cm.in_band); the fit
    # weighting="auto" keeps (level) adds a pole below the band, 6.72 Hz (7 poles, 6 in
    # band; logLS against the exact response 2.1e-6, 3.1e-4 unweighted with 6 poles)
    inb = np.flatnonzero(cm.in_band)
    assert cm.search.weighting == "level" and cm.n == 7 and inb.size == 6
    assert nm.n == 1 and nm.residual.m == inb.size - 1
    assert sorted(nm.residual.source.tolist() + nm.properness.poles_used.tolist()) == \
        inb.tolist()                                   # indices of the poles in cm
    assert sum("fewer sensors (1)" in r for r in nm.residual.reasons) >= inb.size - 2


def test_help_and_version_are_plain_text():
    proc = _sdctrl("--version")
    assert proc.returncode == 0 and proc.stdout.strip() == f"sdctrl {sd.__version__}"
    for args in (["--help"], ["demo", "--help"], ["identify", "--help"], ["diagnose", "--help"],
                 ["info", "--help"]):
        text = _sdctrl(*args).stdout
        assert text.startswith("usage: sdctrl")
        for rst in ("``", ":func:", ":mod:", ":class:", ".. "):
            assert rst not in text, (args, rst)
    assert "sdctrl identify test.uff" in _sdctrl("--help").stdout


def test_missing_diagnose_is_reported_as_not_available(monkeypatch):
    """A version without sd.diagnose runs the rest of the demo and says so (not a failure)."""
    import io

    from sdctrl.report import Document
    from sdctrl.demo import _commands as commands
    from sdctrl.demo._runner import StepLog

    monkeypatch.delitem(sd._EXPORTS, "diagnose", raising=False)
    monkeypatch.delattr(sd, "diagnose", raising=False)
    assert not hasattr(sd, "diagnose")
    stream = io.StringIO()
    log = StepLog(1, stream=stream)
    assert commands._diagnosis(log, None, None) is None
    assert stream.getvalue().startswith("[1/1] diagnosis of a second test: not available (")
    assert "sdctrl.diagnose" in stream.getvalue()
    assert [e.status for e in log.entries] == ["unavailable"] and log.failed == []
    doc = Document("t", "intro")
    commands._sections(doc, log, {})
    assert "This step is not available: sdctrl.diagnose is not in this version" in doc.to_html()


def test_diagnose_command_on_the_demo_outputs(demo, tmp_path):
    """A user's next step: `sdctrl diagnose` on the saved updated model, the second test and
    the FE model, as the README says: the planted mass found again, markdown + HTML page."""
    out = demo["out"]
    proc = _sdctrl("diagnose", str(out / "updated_model.npz"), str(out / "retest.uff"), "--fe",
                   str(out / "fe_updated.npz"), "--report", str(tmp_path / "d.md"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    row = re.search(r"\| 1 \| mass_change \| N14 \| dm = (\S+)(?: \+- \S+)? kg", proc.stdout)
    assert row and float(row.group(1)) == pytest.approx(1.0, rel=0.05)
    page = (tmp_path / "d.html").read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and "<script" not in page
    assert "updated_model.npz against retest.uff" in page and "mass_change" in page
    m = re.search(r'<figure id="fig-diagnosis"><img alt="diagnosis" src="data:image/png;base64,'
                  r'([A-Za-z0-9+/=]+)"', page)
    assert m and len(m.group(1)) > 20_000


# --- issue 25: the report never contradicts itself ------------------------------------------
def _md(demo):
    return (demo["out"] / "report.md").read_text(encoding="utf-8")


def _md_section(md, title_start):
    parts = re.split(r"^## ", md, flags=re.M)
    hit = [p for p in parts if p.startswith(title_start)]
    assert len(hit) == 1, title_start
    return hit[0]


def test_report_gives_one_psd_verdict_per_model(demo):
    """Each normal-mode model shown has one damping verdict (3.45), named by its size; a
    warning that a damping matrix is not positive semi-definite sits only in a section whose
    model's verdict is "no"; the hybrid's second model is introduced where it appears."""
    md = _md(demo)
    rows = re.findall(r"\| damping matrix of the (\d+)-mode model: positive semi-definite "
                      r"\(3\.45\) \| (yes|no) \|", md)
    assert rows, "no damping verdict in the report"
    verdicts = {}
    for n, v in rows:
        verdicts.setdefault(int(n), set()).add(v)
    assert all(len(v) == 1 for v in verdicts.values()), verdicts
    assert "damping matrix positive semi-definite" not in md      # no verdict without a model
    nm = sd.load(demo["out"] / "normal_modes.npz")
    assert verdicts[nm.n] == {"yes" if nm.properness.positive_definite["damping"] else "no"}
    for part in re.split(r"^## ", md, flags=re.M):
        if "damping matrix is not positive semi-definite" in part:
            n = re.findall(r"damping matrix of the (\d+)-mode model: positive semi-definite "
                           r"\(3\.45\) \| no \|", part)
            assert n, part[:200]
    hy = _md_section(md, "Hybrid model")
    line = re.search(r"^\[5/8\] hybrid model: (.*)$", demo["proc"].stdout, re.M).group(1)
    total, inside, outside, fe = (int(g or 0) for g in re.match(
        r"(\d+) modes: (\d+) measured in the band(?: \+ (\d+) fitted just outside it)?, (\d+) "
        r"from the FE model", line).groups())
    assert total == inside + outside + fe == sd.load(demo["out"] / "hybrid.npz").n
    assert inside == nm.n == 12
    if outside:                         # the second model is said where it appears
        assert f"second normal-mode model, of {inside + outside} modes" in hy
        assert f"damping matrix of the {inside + outside}-mode model" in hy


def test_report_numbers_modes_one_way(demo):
    """The close pair is "modes 3 and 4" in the normal-modes section and in the hybrid
    figure's caption, at the frequencies of the saved normal-mode model."""
    md = _md(demo)
    nm = sd.load(demo["out"] / "normal_modes.npz")
    sec = _md_section(md, "Normal modes")
    i, j, fi, fj = re.search(r"The closest pair, modes (\d+) and (\d+) of the band \(undamped "
                             r"natural frequencies ([\d.]+) and ([\d.]+) Hz", sec).groups()
    i, j = int(i), int(j)
    assert (i, j) == (3, 4)
    assert float(fi) == pytest.approx(nm.frequency[i - 1], abs=0.006)
    assert float(fj) == pytest.approx(nm.frequency[j - 1], abs=0.006)
    hy = _md_section(md, "Hybrid model")
    assert f"modes {i} and {j} of the normal-modes section" in hy
    test = _md_section(md, "The structure")
    assert re.search(rf"Modes 1, {i} and {j} of the band, numbered as in the table", test)


def test_report_damping_in_percent_and_warnings_in_full(demo):
    md = _md(demo)
    for line in md.splitlines():
        if line.startswith("|") and re.search(r"damping ratio|zeta", line):
            assert "%" in line, line
    # every warning a step raised appears whole: in the report and on the terminal
    flat_out = " ".join(demo["proc"].stdout.split())
    flat_md = " ".join(md.split())
    n = 0
    for step in demo["steps"].values():
        for w in step["warnings"]:
            n += 1
            assert " ".join(w.split()) in flat_md
            assert "warning: " + " ".join(w.split()) in flat_out
    assert n >= 1                        # the demo does raise one (the 13-mode model)
    assert not re.search(r"warning: .*\.\.\.$", demo["proc"].stdout, re.M)
    assert "white-space:pre-wrap" in demo["html"]          # long lines wrap in their box


def test_mu_figure_on_log_axes_centred_on_the_band():
    """The robust-margin figure: log frequency axis around the band (not 0-20 kHz), the
    critical frequency marked, the y axis within three decades of the peak."""
    from types import SimpleNamespace

    from sdctrl.demo._robustness import _mu_figure

    f = np.logspace(-1, np.log10(2e4), 400)
    mu = 1e-14 + 0.85 / (1 + ((f - 15.81) / 0.2) ** 2)
    r = SimpleNamespace(mu_freq=f, mu=mu, frequency=15.81, margin=1.17, margin_lower=1.18)
    ax = _mu_figure(r, (8.0, 60.0)).axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    lo, hi = ax.get_xlim()
    assert lo < 8.0 and hi > 60.0 and hi / lo < 100
    assert 8.0 < np.sqrt(lo * hi) < 60.0                    # centred on the band
    assert any(np.allclose(ln.get_xdata(), 15.81) for ln in ax.get_lines())
    y0, y1 = ax.get_ylim()
    assert y0 >= 0.85e-4 and y1 > 0.85


def test_placement_number_is_the_tables_first_row(demo):
    """The key number, the summary line and the ranking table measure the same thing (the
    mean over the plate sensors of each one's RMS reduction) for the same bar."""
    num = demo["steps"]["placement"]["numbers"]
    sec = _md_section(_md(demo), "Where to put")
    bar, pct = re.search(r"^\| 1 \| (N\d+-N\d+) \| ([\d.]+) % \|", sec, re.M).groups()
    assert bar == "-".join(num["bar"])
    assert float(pct) == pytest.approx(100 * num["rms_reduction"], abs=0.051)
    assert f"plate RMS -{100 * num['rms_reduction']:.1f}% predicted" in demo["proc"].stdout
