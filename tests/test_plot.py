"""sdctrl.plot: every figure on testbed data or small known models (Agg backend).

The figures are checked for what a reader relies on: layout, labels and units, and that the
plotted numbers are the data (20 log10 |H|, singular values, MAC values, residues, shapes).
"""

import inspect
import re
import subprocess
import sys
import warnings

import matplotlib

matplotlib.use("Agg")

import control
import matplotlib.pyplot as plt
import numpy as np
import pytest

import sdctrl as sd
from sdctrl.plot import _figure
from sdctrl.updating._costs import mac as mac_matrix


@pytest.fixture(autouse=True)
def _no_show_and_close(monkeypatch):
    """No function may call show(); figures are closed after each test."""
    def fail(*args, **kwargs):
        raise AssertionError("a plotting function called show()")

    monkeypatch.setattr(plt, "show", fail)
    monkeypatch.setattr(matplotlib.figure.Figure, "show", fail)
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def testbed_frf():
    return sd.testbed_frf(n=240)


def _two_mode(labels=("A.x", "B.x")):
    """Two modes coupled by damping, sensors A.x, B.x, one shaker on A.x."""
    w = 2 * np.pi * np.array([5.0, 12.0])
    G = np.array([[2 * 0.02 * w[0], 0.4], [0.4, 2 * 0.03 * w[1]]])
    return sd.NormalModeModel(np.diag(w**2), G, [[1.0, 0.6], [0.8, -1.1]], [[1.0], [0.6]],
                              sensors=list(labels), actuators=[labels[0]])


def _db(h):
    return 20 * np.log10(np.abs(h))


def _cell(ax):
    """(row, column) of an axes in the figure's outer channel grid."""
    outer = ax.get_subplotspec().get_topmost_subplotspec()
    return outer.rowspan.start, outer.colspan.start


def _inner_row(ax):
    return ax.get_subplotspec().rowspan.start


def _mag_lines(ax):
    return [ln for ln in ax.get_lines() if ln.get_linestyle() != "None"]


# ------------------------------------------------------------------------------------ bode
def test_bode_grid_layout_units_and_data(testbed_frf):
    frf = testbed_frf
    fig = sd.plot.bode(frf)
    pairs = list(frf.collocated)                          # 6 collocated pairs by default
    assert len(fig.axes) == 2 * len(pairs)
    w, h = fig.get_size_inches()
    assert w <= _figure.MAX_WIDTH and h <= _figure.MAX_HEIGHT
    # 3 columns, 2 rows: channel 3 starts a new row under channel 0; phase under magnitude
    cells = [_cell(ax) for ax in fig.axes]
    assert cells[0::2] == [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]
    assert cells[1::2] == cells[0::2]
    assert [_inner_row(ax) for ax in fig.axes[:2]] == [0, 1]
    for k, (s, a) in enumerate(pairs):
        ax_m, ax_p = fig.axes[2 * k], fig.axes[2 * k + 1]
        assert ax_m.get_ylabel() == "|H| (dB re 1 m/s^2/N)"
        assert ax_p.get_ylabel() == "phase (deg)" and ax_p.get_xlabel() == "frequency (Hz)"
        assert ax_m.get_title() == f"{frf.sensors[s]} / {frf.actuators[a]}"
        line = _mag_lines(ax_m)[0]
        np.testing.assert_allclose(line.get_xdata(), frf.freq)
        np.testing.assert_allclose(line.get_ydata(), _db(frf.H[:, s, a]), rtol=1e-12)


@pytest.mark.parametrize("quantity, unit", [("displacement", "m/N"), ("velocity", "m/s/N")])
def test_bode_unit_follows_quantity_and_converts(testbed_frf, quantity, unit):
    fig = sd.plot.bode(testbed_frf, channels=[(0, 0)], quantity=quantity)
    assert fig.axes[0].get_ylabel() == f"|H| (dB re 1 {unit})"
    conv = testbed_frf.to(quantity).H[:, 0, 0]
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(), _db(conv), rtol=1e-12)


def test_bode_wraps_many_channels_and_caps_size(testbed_frf):
    fig = sd.plot.bode(testbed_frf, actuators=[0], phase=False)
    ns = testbed_frf.H.shape[1]
    assert len(fig.axes) == ns                            # 31 magnitude panels
    cells = [_cell(ax) for ax in fig.axes]
    assert cells == [divmod(k, 3) for k in range(ns)]     # 11 rows of 3, never one long row
    assert tuple(fig.get_size_inches()) <= (_figure.MAX_WIDTH, _figure.MAX_HEIGHT)


def test_statespace_model_and_frf_overlays_coincide():
    nm = _two_mode()
    f = np.linspace(1.0, 20.0, 400)
    frf = nm.frf(f, "velocity")
    ss = nm.to_statespace("velocity")
    fig = sd.plot.bode([frf, nm, ss], labels=["frf", "model", "ss"], channels=[("B.x", "A.x")])
    lines = _mag_lines(fig.axes[0])
    assert [ln.get_label() for ln in lines] == ["frf", "model", "ss"]
    ref = _db(frf.H[:, 1, 0])
    for ln in lines:
        np.testing.assert_allclose(ln.get_ydata(), ref, atol=1e-8)
    ph = [ln.get_ydata() for ln in fig.axes[1].get_lines() if ln.get_linestyle() != "None"]
    assert len(ph) == 3
    for p in ph[1:]:
        np.testing.assert_allclose(p, ph[0], atol=1e-6)
    assert fig.axes[0].get_ylabel() == "|H| (dB re 1 m/s/N)"


def test_statespace_signal_names_match_frf_labels():
    """Sensor "B.x" is output B_x, actuator "A.x" is input A_x_u (API.md)."""
    nm = _two_mode()
    f = np.linspace(1.0, 20.0, 200)
    ss = nm.to_statespace()
    named = control.ss(ss.A, ss.B, ss.C, ss.D, inputs=["A_x_u"], outputs=["A_x", "B_x"])
    frf = nm.frf(f)
    for chan in [("B.x", "A.x"), ("B_x", "A_x_u"), (1, 0)]:
        fig = sd.plot.bode([frf, named], channels=chan)
        a, b = _mag_lines(fig.axes[0])
        np.testing.assert_allclose(b.get_ydata(), a.get_ydata(), atol=1e-8)
        np.testing.assert_allclose(a.get_ydata(), _db(frf.H[:, 1, 0]), rtol=1e-12)
        assert fig.axes[0].get_title() == "B.x / A.x"
    # the StateSpace alone: evaluated on freq=, channels by its own names or FRF labels
    fig = sd.plot.bode(named, freq=f, channels=[("B.x", "A.x")])
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(), _db(frf.H[:, 1, 0]),
                               rtol=1e-9)


def test_channel_selection_by_label_and_errors(testbed_frf):
    frf = testbed_frf
    s_lab, a_lab = frf.sensors[10], frf.actuators[2]
    fig = sd.plot.bode(frf, sensors=[s_lab, 0], actuators=a_lab)
    assert [ax.get_title() for ax in fig.axes[0::2]] == [f"{s_lab} / {a_lab}",
                                                       f"{frf.sensors[0]} / {a_lab}"]
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(), _db(frf.H[:, 10, 2]))
    with pytest.raises(ValueError, match=r"channels: unknown sensor label 'N999\.z'"):
        sd.plot.bode(frf, channels=[("N999.z", a_lab)])
    with pytest.raises(ValueError, match="actuators: unknown actuator label"):
        sd.plot.bode(frf, actuators=["nope"])
    with pytest.raises(ValueError, match="sensors: sensor index 99 out of range"):
        sd.plot.bode(frf, sensors=[99])
    with pytest.raises(ValueError, match="channels cannot be combined"):
        sd.plot.bode(frf, channels=[(0, 0)], sensors=[0])
    with pytest.raises(TypeError, match="systems must be"):
        sd.plot.bode([frf, "not a system"])
    with pytest.raises(ValueError, match="freq must be given"):
        sd.plot.bode(_two_mode())
    with pytest.raises(ValueError, match="labels must have one entry per system"):
        sd.plot.bode(frf, labels=["a", "b"])


def test_default_channels_without_collocation():
    nm = _two_mode()
    f = np.linspace(1.0, 20.0, 50)
    # same label on both sides (A.x / A.x) stands for the collocated pair
    fig = sd.plot.bode(nm, freq=f)
    assert [ax.get_title() for ax in fig.axes[0::2]] == ["A.x / A.x"]
    big = sd.FRF(f, np.ones((f.size, 5, 3)))
    with pytest.warns(UserWarning, match="first 12 of 15 channels"):
        fig = sd.plot.bode(big, phase=False)
    assert len(fig.axes) == 12


# ----------------------------------------------------------------------------------- phase
def test_clean_phase_is_unwrapped_without_360_jumps(testbed_frf):
    frf = testbed_frf
    # a transfer whose phase travels over more than a turn: unwrapping is needed
    travel = np.ptp(np.unwrap(np.angle(frf.H), axis=0), axis=0)
    s, a = np.unravel_index(np.argmax(travel), travel.shape)
    assert np.degrees(travel[s, a]) > 360
    fig = sd.plot.bode(frf, channels=[(int(s), int(a))])
    lines = fig.axes[1].get_lines()
    line = lines[0].get_ydata()
    assert np.all(np.isfinite(line))                      # every sample coherent
    assert np.max(np.abs(np.diff(line))) < 180            # no 360-degree jumps
    np.testing.assert_allclose(line, np.degrees(np.unwrap(np.angle(frf.H[:, s, a]))))
    assert len(lines) == 1                                # no noisy points


def test_noisy_phase_drawn_as_points_not_blocks():
    rng = np.random.default_rng(3)
    f = np.linspace(1.0, 20.0, 600)
    clean = _two_mode().frf(f).H[:, 0, 0]
    noise = rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
    line, points = sd.plot.phase_display(noise)
    assert np.mean(np.isfinite(line)) < 0.05              # noise is points ...
    assert np.all(np.isfinite(points) != np.isfinite(line))
    line_c, points_c = sd.plot.phase_display(clean)
    assert np.all(np.isfinite(line_c)) and not np.any(np.isfinite(points_c))
    # a low coherence marks otherwise smooth data as noise; wrapped mode stays in (-180, 180]
    coh = np.where(f < 10, 1.0, 0.1)
    line, points = sd.plot.phase_display(clean, coh, unwrap=False)
    assert np.all(np.isfinite(line[f < 9.9])) and not np.any(np.isfinite(line[f > 10]))
    assert np.all(np.abs(points[f > 10]) <= 180)
    # a channel half noise: the coherent part is a line, the rest points
    h = np.where(f < 10, clean, 1e-3 * noise)
    frf = sd.FRF(f, h)
    fig = sd.plot.bode(frf)
    styles = [ln.get_linestyle() for ln in fig.axes[1].get_lines()]
    assert styles == ["-", "None"]
    pts = fig.axes[1].get_lines()[1].get_ydata()
    assert np.mean(np.isfinite(pts[f > 10.5])) > 0.9


def test_noisy_test_overlays_its_model_on_the_same_phase_turn():
    """Across a noisy gap the turn count is unknowable; the clean overlay fixes it."""
    nm = _two_mode()
    f = np.linspace(1.0, 20.0, 800)
    clean = nm.frf(f).H[:, 1, 0]
    rng = np.random.default_rng(5)
    noise = rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
    gaps = ((f > 4.0) & (f < 6.0)) | ((f > 11.0) & (f < 13.0))   # both poles inside gaps
    h = np.where(gaps, np.abs(clean).max() * noise, clean * (1 + 0.01 * noise))
    test = sd.FRF(f, h, sensors=["B.x"], actuators=["A.x"])
    for order in ([test, nm], [nm, test]):
        fig = sd.plot.bode(order, channels=[("B.x", "A.x")])
        lines = [ln.get_ydata() for ln in fig.axes[1].get_lines() if ln.get_linestyle() != "None"]
        model_line, test_line = (lines[1], lines[0]) if order[0] is test else lines
        ok = np.isfinite(test_line) & np.isfinite(model_line)
        assert ok.sum() > 0.6 * f.size
        # a noise sample survives at a run end only within PHASE_STEP_TOL of its neighbour
        assert np.max(np.abs(test_line[ok] - model_line[ok])) < 30.0


# ------------------------------------------------------------------------------- envelope
def test_envelope_over_samples_and_uncertain_model():
    nm = _two_mode()
    f = np.linspace(2.0, 16.0, 120)
    um = nm.uncertain(dGamma=np.diag([0.3, 0.5]))
    fig = sd.plot.envelope(um, f, n_samples=8, seed=1)
    env = um.frf_envelope(f, n_samples=8, seed=1)
    ax = fig.axes[0]
    assert ax.get_title() == "A.x / A.x" and ax.get_ylabel() == "|H| (dB re 1 m/N)"
    verts = ax.collections[0].get_paths()[0].vertices
    lo_db, hi_db = _db(env["mag_min"][:, 0, 0]), _db(env["mag_max"][:, 0, 0])
    # the band polygon runs along the lower bound then back along the upper one
    assert np.isclose(verts[:, 1].min(), lo_db.min()) and np.isclose(verts[:, 1].max(),
                                                                     hi_db.max())
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), _db(env["nominal"][:, 0, 0]))
    # acceleration: |(j w)^2| times the displacement band
    fig = sd.plot.envelope(um, f, quantity="acceleration", n_samples=8, seed=1)
    verts = fig.axes[0].collections[0].get_paths()[0].vertices
    gain = _db((2 * np.pi * f) ** 2)
    assert np.isclose(verts[:, 1].max(), np.max(hi_db + gain))
    # a list of sampled systems, with a nominal
    samples = um.sample(6, seed=2)
    fig = sd.plot.envelope(samples, f, nominal=nm, channels=[("B.x", "A.x")])
    H = np.array([sd.FRF.from_system(s, f).H[:, 1, 0] for s in samples])
    verts = fig.axes[0].collections[0].get_paths()[0].vertices
    assert np.isclose(verts[:, 1].min(), _db(np.abs(H).min(axis=0)).min())
    assert np.isclose(verts[:, 1].max(), _db(np.abs(H).max(axis=0)).max())
    # the grid of an FRF nominal serves the sampled StateSpace objects
    fig = sd.plot.envelope(samples, nominal=nm.frf(f), channels=[("B.x", "A.x")])
    verts2 = fig.axes[0].collections[0].get_paths()[0].vertices
    np.testing.assert_allclose(verts2, verts)
    with pytest.raises(ValueError, match="freq must be given"):
        sd.plot.envelope(um)


# ------------------------------------------------------------------- identification figures
def test_cmif_lines_are_singular_values(testbed_frf):
    frf = testbed_frf
    fig = sd.plot.cmif(frf, poles=[2j * np.pi * 20 - 0.1])
    ax = fig.axes[0]
    sv = np.linalg.svd(frf.H, compute_uv=False)
    lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("sigma")]
    assert len(lines) == min(frf.H.shape[1:]) == 6
    for k, ln in enumerate(lines):
        np.testing.assert_allclose(ln.get_ydata(), _db(sv[:, k]), rtol=1e-10)
    assert any(np.allclose(ln.get_xdata(), 20.0) for ln in ax.get_lines())   # pole marker
    assert ax.get_xlabel() == "frequency (Hz)" and "m/s^2/N" in ax.get_ylabel()
    with pytest.raises(ValueError, match="n_sv"):
        sd.plot.cmif(frf, n_sv=7)


def test_stabilisation_flags_frequency_damping_shape():
    p = 2 * np.pi * 10 * (-0.01 + 1j)
    q = 2 * np.pi * 30 * (-0.02 + 1j)
    orders = [np.array([p]),
              np.array([p * (1 + 1e-4), q]),                  # p stable in f and damping
              np.array([p.real * 1.3 + 1j * p.imag, q, np.conj(q)]),   # p: damping moved
              np.array([p.real * 1.3 + 1j * p.imag * 1.05])]  # p: frequency moved 5%
    flags = sd.plot.stabilisation_flags(orders)
    assert [f.tolist() for f in flags] == [[0], [2, 0], [1, 2, -1], [0]]
    shapes = [np.array([[1.0], [0.5]]), np.array([[1.0, 0], [0.5, 1]]),
              np.array([[1.0, 0.0, 0.0], [0.5, 1.0, 1.0]]), np.array([[0.0], [1.0]])]
    flags = sd.plot.stabilisation_flags(orders, shapes=shapes)
    assert [f.tolist() for f in flags] == [[0], [3, 0], [1, 3, -1], [0]]
    shapes[1] = np.array([[0.0, 0], [1.0, 1]])                # p's shape changes at order 1
    assert sd.plot.stabilisation_flags(orders, shapes=shapes)[1].tolist() == [2, 0]
    with pytest.raises(ValueError, match=r"shapes\[0\] must have shape"):
        sd.plot.stabilisation_flags(orders, shapes=[np.ones((2, 2))] * 4)
    with pytest.raises(ValueError, match="freq_tol"):
        sd.plot.stabilisation_flags(orders, freq_tol=0)


def test_stabilisation_diagram_points_and_background(testbed_frf):
    frf = testbed_frf
    nm = sd.testbeds._truss._modal()
    true = nm.poles[(nm.frequency > 8) & (nm.frequency < 60)]
    rng = np.random.default_rng(0)
    orders = [np.concatenate([true[:3 + k], 2 * np.pi * rng.uniform(8, 60, 2) * (-0.05 + 1j)])
              for k in range(6)]
    fig = sd.plot.stabilisation(orders, frf, orders=np.arange(4, 16, 2), ylabel="iteration")
    ax_bg, ax = fig.axes
    sv = np.linalg.svd(frf.H, compute_uv=False)
    np.testing.assert_allclose(ax_bg.get_lines()[0].get_ydata(), _db(sv[:, 0]))
    assert ax.get_ylabel() == "iteration" and ax_bg.get_xlabel() == "frequency (Hz)"
    cmif = ax_bg.get_ylabel()                 # "CMIF (dB re 1 m/s^2/N)": unit, balanced
    assert cmif.startswith("CMIF (dB re 1 ") and cmif.endswith("/N)") and cmif.count(")") == 1
    flags = sd.plot.stabilisation_flags(orders)
    labels = [c.get_label() for c in ax.collections]
    assert labels[0] == "new pole" and "stable in frequency and damping" in labels
    pts = np.vstack([c.get_offsets() for c in ax.collections])
    assert len(pts) == sum(int(np.sum(f >= 0)) for f in flags)
    stable = ax.collections[labels.index("stable in frequency and damping")].get_offsets()
    # every true pole repeated from the previous order is stable in frequency and damping
    assert len(stable) == sum(3 + k for k in range(5))
    np.testing.assert_allclose(np.sort(stable[stable[:, 1] == 6, 0]),
                               np.sort(np.abs(true[:3]) / (2 * np.pi)))
    assert not hasattr(sd.plot, "stabilization")            # one name, no alias


# -------------------------------------------------------------------------- shapes, maps
def test_mac_heat_map_values_and_labels():
    nm = sd.testbeds._truss._modal()
    fig = sd.plot.mac(nm.cphi[:, 6:12], nm.cphi[:, 6:10], names=("test", "FE"))
    ax = fig.axes[0]
    M = mac_matrix(nm.cphi[:, 6:12], nm.cphi[:, 6:10])
    np.testing.assert_allclose(ax.images[0].get_array(), M)
    assert len(ax.texts) == M.size and ax.texts[0].get_text() == f"{M[0, 0]:.2f}"
    assert ax.get_ylabel() == "test" and ax.get_xlabel() == "FE"
    fig = sd.plot.mac(nm)                                       # a model: auto-MAC of cphi
    ax = fig.axes[0]
    assert np.allclose(np.diag(ax.images[0].get_array()), 1.0)
    f = nm.frequency
    assert ax.get_yticklabels()[6].get_text() == f"7: {f[6]:.4g} Hz"
    with pytest.raises(ValueError, match="same number of rows"):
        sd.plot.mac(np.ones((3, 2)), np.ones((4, 2)))


def test_complex_residues_plane_and_phase_dispersion():
    rng = np.random.default_rng(1)
    mag = 1 + rng.random(8)
    real = mag * np.sign(rng.standard_normal(8)) * np.exp(1j * 0.7)   # collinear, rotated
    assert sd.plot.phase_dispersion(real) == pytest.approx(0.0, abs=1e-9)
    dev = np.radians([-20, 0, 0, 20, 0, 0, 0, 0])
    spread = real * np.exp(1j * dev)
    assert sd.plot.phase_dispersion(spread) == pytest.approx(40.0, abs=1.0)
    # from a complex-mode model: the collocated actuator's residue column
    R = np.stack([np.outer(spread, [1.0, 2.0]), np.outer(real, [1.0, 0.5])])
    cm = sd.ComplexModeModel(2 * np.pi * np.array([10.0, 20.0]) * (-0.01 + 1j), R,
                             sensors=[f"S{i}" for i in range(8)], actuators=["U0", "U1"],
                             collocated=[(0, 1)])
    fig = sd.plot.complex_residues(cm, mode=0)
    ax = fig.axes[0]
    pts = next(ln for ln in ax.get_lines() if ln.get_gid() == "set0")
    np.testing.assert_allclose(pts.get_xdata() + 1j * pts.get_ydata(), 2 * spread)
    assert re.search(r"mode 1 \(10 Hz\): phase dispersion 4\d\.\d deg", fig.texts[0].get_text())
    assert {t.get_text() for t in ax.texts} == {f"S{i}" for i in range(8)}
    # two sets overlaid, linked sensor by sensor
    fig = sd.plot.complex_residues([cm, real], mode=1, actuator="U0", labels=["id", "real"])
    ax = fig.axes[0]
    assert [ln.get_gid() for ln in ax.get_lines()].count("set1") == 1
    assert sum(ln.get_linestyle() == ":" for ln in ax.get_lines()) == 8
    with pytest.raises(ValueError, match="actuator: unknown label"):
        sd.plot.complex_residues(cm, actuator="U7")


def test_complex_residue_labels_never_overlap():
    """Issue 25: residues in clusters (most sensors near the origin or near each other) get
    labels that overlap no other label; the largest residue is always labelled."""
    rng = np.random.default_rng(3)
    big = np.array([1.0 + 0.1j, -0.9 - 0.2j])
    cluster = 0.3 + 0.01 * (rng.standard_normal(20) + 1j * rng.standard_normal(20))
    r = np.concatenate([big, cluster])
    labels = [f"N{i}.y" for i in range(r.size)]
    fig = sd.plot.complex_residues(r, sensors=labels)
    ax = fig.axes[0]
    fig.canvas.draw()
    rend = fig.canvas.get_renderer()
    texts = [t for t in ax.texts if t.get_gid() == "sensor label"]
    boxes = [t.get_window_extent(rend) for t in texts]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    written = {t.get_text() for t in texts}
    assert {"N0.y", "N1.y"} <= written               # the two large ones
    assert 2 < len(written) < r.size                 # the pile is thinned, not all dropped
    # each label sits next to its own point (within 25 points) and covers no other point
    pts = {lab: z for lab, z in zip(labels, r)}
    for t in texts:
        z = pts[t.get_text()]
        x, y = ax.transData.transform((z.real, z.imag))
        b = t.get_window_extent(rend)
        gap = np.hypot(max(b.x0 - x, 0, x - b.x1), max(b.y0 - y, 0, y - b.y1))
        assert gap < 25 * fig.dpi / 72
        for other in written - {t.get_text()}:
            w = pts[other]
            assert not b.contains(*ax.transData.transform((w.real, w.imag))), (t, other)


def test_mode_shapes_panel_names_give_the_report_numbering():
    nodes = {"A": (0.0, 0, 0), "B": (1.0, 0, 0), "C": (2.0, 0, 0)}
    fe = sd.FEModel(np.eye(3), np.diag([1.0, 2, 3]), dofs=["A.y", "B.y", "C.y"], nodes=nodes,
                    elements=[("A", "B"), ("B", "C")])
    fig = sd.plot.mode_shapes(fe, modes=[1, 2], names=["band mode 1", "band mode 2"])
    assert [ax.get_title() for ax in fig.axes] == ["band mode 1", "band mode 2"]
    fig = sd.plot.mode_shapes(fe, modes=[1, 2])
    assert fig.axes[0].get_title().startswith("mode 2: ")
    with pytest.raises(ValueError, match="names must hold one title per mode"):
        sd.plot.mode_shapes(fe, modes=[1, 2], names=["one"])


def test_mode_shapes_on_fe_geometry():
    nodes = {"A": (0.0, 0, 0), "B": (1.0, 0, 0), "C": (2.0, 0, 0)}
    dofs = ["A.y", "B.y", "C.y", "B.x"]
    fe = sd.FEModel(np.eye(4), np.diag([1.0, 2, 3, 4]), dofs=dofs, nodes=nodes,
                    elements=[("A", "B"), ("B", "C")])
    v = np.array([0.0, 1.0, -2.0, 0.5])
    fig = sd.plot.mode_shapes(fe, v, scale=0.1)
    ax = fig.axes[0]
    assert ax.name == "3d"
    und, dfm = (next(c for c in ax.collections if c.get_gid() == g)
                for g in ("undeformed", "deformed"))
    seg0 = np.array(und._segments3d)
    seg1 = np.array(dfm._segments3d)
    np.testing.assert_allclose(seg0[:, :, 0], [[0, 1], [1, 2]])
    # B moves (0.05, 0.1, 0), C moves (0, -0.2, 0)
    np.testing.assert_allclose(seg1[1], [[1.05, 0.1, 0], [2.0, -0.2, 0]])
    # the FE model's own modes, several panels, frequencies in the titles
    fe_t = sd.testbed()
    f, _ = fe_t.modes(8)
    fig = sd.plot.mode_shapes(fe_t, modes=[6, 7])
    assert len(fig.axes) == 2 and fig.axes[1].get_title() == f"mode 8: {f[7]:.4g} Hz"
    # a model carrying shapes on FE DOFs (FE-derived or hybrid) brings labels and frequencies
    nm = sd.testbeds._truss._modal()
    fig = sd.plot.mode_shapes(fe_t, nm, modes=8)
    assert fig.axes[0].get_title() == f"mode 9: {nm.frequency[8]:.4g} Hz"
    seg = np.array(next(c for c in fig.axes[0].collections if c.get_gid() == "deformed")
                   ._segments3d)
    assert np.ptp(seg) > 0 and len(seg) == len(fe_t.elements)
    with pytest.raises(ValueError, match="node coordinates"):
        sd.plot.mode_shapes(sd.FEModel(np.eye(2), np.eye(2)), np.ones(2))
    with pytest.raises(ValueError, match="modes: index 3 out of range"):
        sd.plot.mode_shapes(fe, v, modes=3)


def test_cost_map_contours_and_optimum():
    x = np.linspace(-1, 1, 21)
    y = np.linspace(-0.5, 1.5, 17)
    X, Y = np.meshgrid(x, y, indexing="ij")
    cost = (X + Y - 0.5) ** 2 + 0.05 * (X - 0.2) ** 2 + 1e-3   # valley of constant x + y
    fig = sd.plot.cost_map(x, y, cost, xlabel="dm mirror (kg)", ylabel="dm plate (kg)",
                           markers={"truth": (0.2, 0.3)})
    ax = fig.axes[0]
    assert ax.get_xlabel() == "dm mirror (kg)" and ax.get_ylabel() == "dm plate (kg)"
    i, j = np.unravel_index(np.argmin(cost), cost.shape)
    star = next(ln for ln in ax.get_lines() if ln.get_label().startswith("optimum"))
    assert (star.get_xdata()[0], star.get_ydata()[0]) == (x[i], y[j])
    assert fig.axes[1].get_ylabel() == "log10 cost"            # spans > 2 decades: log
    levels = ax.collections[0].levels                          # the filled contour set
    assert np.min(levels) <= np.log10(cost.min()) and np.max(levels) >= np.log10(cost.max())
    fig = sd.plot.cost_map(x, y, cost, log=False, optimum=(0.25, 0.25))
    star = next(ln for ln in fig.axes[0].get_lines() if ln.get_label().startswith("optimum"))
    assert star.get_xdata()[0] == 0.25
    with pytest.raises(ValueError, match=r"cost must have shape \(len\(x\), len\(y\)\)"):
        sd.plot.cost_map(x, y, cost.T)


# ------------------------------------------------------------------------------ contracts
def test_path_saves_and_closes(tmp_path, testbed_frf):
    out = tmp_path / "b.png"
    fig = sd.plot.bode(testbed_frf, channels=[(0, 0)], path=out, title="t")
    assert out.stat().st_size > 5000
    assert not plt.fignum_exists(fig.number)
    assert fig._suptitle.get_text() == "t"


def test_every_figure_function_is_documented():
    for name in sd.plot.__all__:
        func = getattr(sd.plot, name)
        doc = inspect.getdoc(func)
        assert doc and "Returns" in doc, name
        params = [p for p in inspect.signature(func).parameters]
        block = doc.split("Parameters")[1].split("Returns")[0]
        documented = set()
        for line in block.splitlines():
            if line and not line.startswith(" ") and not line.startswith("-"):
                documented.update(n.strip() for n in line.split(" : ")[0].split(","))
        missing = [p for p in params if p not in documented]
        assert not missing, f"sd.plot.{name}: undocumented parameters {missing}"


def test_matplotlib_is_imported_lazily():
    code = ("import sys, sdctrl as sd; sd.plot.bode; "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_figures_do_not_warn(testbed_frf):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd.plot.bode(testbed_frf, channels=[(0, 0), (1, 1)])
        sd.plot.cmif(testbed_frf)


# ------------------------------------------------------------------- statistics (issue 24)
def test_mode_table_intervals_are_the_statistics(chain_identified):
    frf, cm, _ = chain_identified
    assert np.all(np.isfinite(cm.frequency_std))
    fig = sd.plot.mode_table(cm, frf, level=0.95)
    bars = fig.axes[1].containers[0]
    np.testing.assert_allclose(bars.lines[0].get_xdata(), cm.frequency)
    np.testing.assert_allclose(bars.lines[0].get_ydata(), 100 * cm.damping)
    # horizontal bar segments span f +- 1.96 std
    seg = bars.lines[2][0].get_segments()
    half = np.array([abs(s[1][0] - s[0][0]) / 2 for s in seg])
    np.testing.assert_allclose(half, 1.959964 * cm.frequency_std, rtol=1e-5)
    cells = fig.axes[2].tables[0].get_celld()
    text = cells[(1, 1)].get_text().get_text()
    assert (text.startswith(f"{cm.frequency[0]:.6g} +- ")
            and "95%" in cells[(0, 1)].get_text().get_text())
    # the CMIF is the data's singular values
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(),
                               np.linalg.svd(frf.H, compute_uv=False)[:, 0])
    # half the level, narrower bars; a model without statistics shows n/a
    seg50 = sd.plot.mode_table(cm, level=0.5).axes[1].containers[0].lines[2][0].get_segments()
    assert abs(seg50[0][1][0] - seg50[0][0][0]) < 0.5 * abs(seg[0][1][0] - seg[0][0][0])
    bare = sd.plot.mode_table(sd.ComplexModeModel(cm.poles, cm.residues))
    assert "n/a" in bare.axes[2].tables[0].get_celld()[(1, 1)].get_text().get_text()
    with pytest.raises(ValueError, match="level"):
        sd.plot.mode_table(cm, level=95)
    with pytest.raises(TypeError, match="ComplexModeModel"):
        sd.plot.mode_table(frf)


def test_envelope_of_the_uncertain_model_from_the_data(chain_identified):
    frf, cm, _ = chain_identified
    nm = sd.normal_modes(cm)
    wide, narrow = sd.uncertain_from_data(nm, 0.95), sd.uncertain_from_data(nm, 0.5)
    spans = []
    for um in (wide, narrow):
        fig = sd.plot.envelope(um, frf.freq, channels=[("N1.x", "N1.x")], n_samples=10, seed=0)
        env = um.frf_envelope(frf.freq, n_samples=10, seed=0)
        v = fig.axes[0].collections[0].get_paths()[0].vertices
        assert np.isclose(v[:, 1].max(), _db(env["mag_max"][:, 0, 0]).max())
        spans.append(np.median(env["mag_max"][:, 0, 0] / env["mag_min"][:, 0, 0]))
    assert spans[0] > spans[1] > 1


def test_correlation_matrix_of_the_estimates(chain_identified):
    frf, _, (M, K, C, labels) = chain_identified
    fe = sd.FEModel(M, K, C=C, dofs=list(labels))
    dK = np.zeros((3, 3))
    dK[0, 0] = 1e4
    dM1, dM2 = np.diag([0.0, 1.0, 0.0]), np.diag([0.0, 0.0, 1.0])
    pars = [sd.Parameter("k1", dK=dK), sd.Parameter("m2", dM=dM1), sd.Parameter("m3", dM=dM2)]
    ident = sd.identifiability(fe, frf, pars, damping="fe", noise=0.02**2 / 2)
    fig = sd.plot.correlation(ident)
    np.testing.assert_allclose(fig.axes[0].images[0].get_array(), ident.estimate_correlation)
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == ["k1", "m2", "m3"]
    assert len(fig.axes[0].patches) == 2 * len(ident.confounded)
    with pytest.raises(TypeError, match="Identifiability"):
        sd.plot.correlation(frf)
