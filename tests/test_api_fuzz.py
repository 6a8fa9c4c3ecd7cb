"""Property-based fuzz of the public API (issue 15): every bad input a clear error.

One row of ``ENTRIES`` per public call (``sd.__all__``, the public methods of the models and the
public functions of ``closedloop``, ``placement``, ``testing`` and ``plot``).  Each example takes
the row's valid arguments and replaces none, one or two of them by a drawn class of values
(:mod:`fuzzing`: NaN/inf, huge/tiny scales, wrong shapes and dtypes, complex where real is
expected, object and string arrays, None, empty/reversed bands, duplicate frequencies, label
collisions, read-only arrays, ...).  The call must return a finite, well-formed result or raise
``ValueError``/``TypeError`` (``OSError`` for paths) naming the argument; nothing else escapes,
nothing hangs, no input is modified.  A new entry point is one more row.

Known failures of entry points owned by other work (``fuzz_known.KNOWN``) are excluded from the
property and pinned instead by ``test_known_failure`` as ``xfail(strict=True)``: when the owner
fixes one, its xfail passes, the run fails, and the row is deleted.  ``SDCTRL_FUZZ_SWEEP=1``
runs every class of every argument alone and lists new failures and stale rows.

``SDCTRL_HYPOTHESIS_PROFILE=deep`` draws twenty times more examples, at random.
Run with ``-s`` to print the outcome counts.
"""

from __future__ import annotations

import collections
import dataclasses
import os
import pathlib
import tempfile

import control
import numpy as np
import pytest
import scipy.sparse as sp
from fuzz_known import KNOWN, OWNER
from fuzzing import (
    ANY,
    OK,
    REFUSE,
    Arg,
    Cls,
    Entry,
    Kind,
    _fixed,
    _pick,
    array,
    band_kind,
    choice_kind,
    collocated_kind,
    draw_case,
    expect,
    flag_kind,
    freq_kind,
    integer,
    label_kind,
    labels_kind,
    mask_kind,
    number,
    obj_kind,
    path_kind,
    quantity_kind,
)
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import sdctrl as sd
import sdctrl.closedloop._loops as cl
import sdctrl.plot as splot
import sdctrl.testing as stt
from sdctrl.closedloop import _placement as placement

OUTCOMES: collections.Counter = collections.Counter()
TMP = pathlib.Path(tempfile.mkdtemp(prefix="sdctrl-fuzz-"))

# ----------------------------------------------------------------------------------------
# valid bases (small, so that thousands of calls take seconds)
# ----------------------------------------------------------------------------------------
W = 2 * np.pi * np.array([10.0, 25.0])
FREQ = np.linspace(5.0, 40.0, 60)
LABELS = ("N1.x", "N2.x")
CPHI = np.array([[1.0, 0.5], [0.3, -1.0]])


def nm_args():
    return {"Omega": np.diag(W**2), "Gamma": np.diag(0.04 * W), "cphi": CPHI.copy(),
            "phib": CPHI.T.copy(), "E": np.full((2, 2), 1e-5), "sensors": LABELS,
            "actuators": LABELS}


NM = sd.NormalModeModel(**nm_args())
H = NM.frf(FREQ).H.copy()


def frf_args():
    return {"freq": FREQ.copy(), "H": H.copy(), "quantity": "displacement", "sensors": LABELS,
            "actuators": LABELS, "collocated": [(0, 0), (1, 1)],
            "coherence": np.full(H.shape, 0.9)}


FRF = sd.FRF(**frf_args())


def cm_args():
    lam = NM.poles
    R = np.einsum("sj,ja->jsa", CPHI, CPHI.T) / (2j * lam.imag)[:, None, None]
    return {"poles": lam.copy(), "residues": R, "E": np.full((2, 2), 1e-5),
            "F": np.full((2, 2), -1e-3), "in_band": np.array([True, True]), "sensors": LABELS,
            "actuators": LABELS, "collocated": [(0, 0), (1, 1)], "band": (5.0, 40.0)}


CM = sd.ComplexModeModel(**cm_args())
NODES = [f"N{i}" for i in range(6)]


def fe_args():
    K = 4000.0 * sp.diags([[-1.0] * 5, [2.0] * 6, [-1.0] * 5], [-1, 0, 1]).toarray()
    return {"M": np.eye(6), "K": K, "C": 0.01 * K, "dofs": [f"{n}.x" for n in NODES],
            "nodes": {n: (float(i), 0.0, 0.0) for i, n in enumerate(NODES)},
            "elements": [(NODES[i], NODES[i + 1]) for i in range(5)]}


FE = sd.FEModel(**fe_args())
B_FE = FE.point(["N1.x", "N4.x"])
NM_FE = FE.normal_mode_model(B_FE, B_FE.T, 3)
W1 = 2 * np.pi * 0.5
NM1 = sd.NormalModeModel([[W1**2]], [[0.02 * W1]], [[1.0]], [[1.0]])
UM1 = NM1.uncertain(dGamma=[[0.05 * W1]])          # one block: mu without an LMI (fast)
#: an identified-like model with statistics, and a second test of it
NMS = NM1.replace(std={"Omega": [[0.01 * W1**2]], "Gamma": [[0.002 * W1]], "cphi": [[0.01]],
                       "phib": [[0.01]]})
NMS2 = NMS.replace(Omega=[[1.01 * W1**2]], std=NMS.std)
K1 = control.ss([], [], [], [[0.5]], inputs=["s0"], outputs=["a0_u"])
SS = NM.to_statespace()
SS_NAN = control.ss(SS.A, SS.B, SS.C, np.full(SS.D.shape, np.nan))
SS_UNSTABLE = control.ss([[0.0, 1.0], [-1.0, 0.1]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
SS_DISCRETE = control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
TF = control.tf([1.0], [1.0, 0.2, 1.0])


def _systems(*extra, other=OK):
    """A system argument; ``other``: the fate of an unrelated 2x2 StateSpace."""
    return obj_kind(("statespace", lambda: SS, other), ("nan_matrix", lambda: SS_NAN, REFUSE),
                    ("discrete", lambda: SS_DISCRETE, REFUSE), *extra)


#: FE update rows: the testbed with links 50% too soft, and its nominal test (cached)
TB = sd.testbed(link_stiffness=0.5)
TB_FRF = sd.testbed_frf(n=120).band(10.0, 30.0)
TB_P = TB.stiffness_parameter("links", section=["post_AB", "post_C"])
DK_SPRING = np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 0.0]])


#: diagnose rows: the 2-mode model against its own prediction, 1 ms late
H_LATE = H * np.exp(-2j * np.pi * FREQ * 1e-3)[:, None, None]


def _dg_frf(a):
    return sd.FRF(a.pop("freq"), a.pop("H"), sensors=LABELS, actuators=LABELS)


TB_FRF_NAMES = ("frf", "sensors", "actuators")     # H's shape is checked against the labels


def _tb_frf(a):
    return sd.FRF(a.pop("freq"), a.pop("H"), quantity=TB_FRF.quantity, sensors=TB_FRF.sensors,
                  actuators=TB_FRF.actuators)


# ----------------------------------------------------------------------------------------
# checks of results
# ----------------------------------------------------------------------------------------
def is_frf(res, args=None):
    assert isinstance(res, sd.FRF)
    nf, ns, na = res.H.shape
    assert res.freq.shape == (nf,) and len(res.sensors) == ns and len(res.actuators) == na
    assert np.all(np.diff(res.freq) > 0) and not res.H.flags.writeable


def is_ss(res, args=None):
    assert isinstance(res, control.StateSpace)
    ins, outs = list(res.input_labels), list(res.output_labels)
    assert len(set(ins)) == len(ins) and len(set(outs)) == len(outs)
    assert not set(ins) & set(outs), f"input and output names collide: {set(ins) & set(outs)}"


def is_nm(res, args=None):
    assert isinstance(res, sd.NormalModeModel)
    assert res.Omega.shape == res.Gamma.shape == (res.n, res.n)


def is_cm(res, args=None):
    assert isinstance(res, sd.ComplexModeModel)
    assert np.all(res.poles.imag > 0) and np.all(res.poles.real < 0)


def is_identifiability(res, args=None):
    """``separation`` is inf on its diagonal by design; the other figures must be finite."""
    assert np.all(np.isfinite(res.correlation))
    assert all(np.isfinite(v) for v in res.sensitivity.values())
    off = ~np.eye(res.separation.shape[0], dtype=bool)
    assert np.all(np.isfinite(res.separation[off]))


def is_diagnosis(res, args=None):
    assert isinstance(res, sd.Diagnosis)
    assert 0 <= res.error_after <= res.error_before
    assert all(isinstance(e, sd.Effect) for e in res.effects)
    assert res.model.frf(FREQ[:3]).H.shape == (3, 2, 2)


def close_figures(res, args=None):
    import matplotlib.pyplot as plt

    plt.close("all")


# ----------------------------------------------------------------------------------------
# argument kinds shared by rows
# ----------------------------------------------------------------------------------------
REAL, CPLX = array(), array(real=False)
OPT_REAL = array(optional=True)
FREQ_K = freq_kind()
QTY = quantity_kind()
LAB = labels_kind()
COL = collocated_kind(2, 2)


def _call(f):
    """A row's call from a function of keyword arguments."""
    return lambda a: f(**a)


def _frf(a, keys=("freq", "H")):
    return sd.FRF(**{k: a.pop(k) for k in keys})


def _nm(a, keys=("Omega", "Gamma", "cphi", "phib", "E", "sensors", "actuators")):
    return sd.NormalModeModel(**{k: a.pop(k) for k in keys if k in a})


def _cm(a, keys=("poles", "residues", "E", "F", "in_band", "sensors", "actuators", "collocated",
                 "band")):
    return sd.ComplexModeModel(**{k: a.pop(k) for k in keys if k in a})


def _plus(base, **more):
    return lambda: {**base(), **more}


NM_KINDS = {"Omega": REAL, "Gamma": REAL, "cphi": REAL, "phib": REAL, "E": OPT_REAL,
            "sensors": LAB, "actuators": LAB}
CM_KINDS = {"poles": Arg(CPLX.but(negative=REFUSE, real=REFUSE, zero=REFUSE, bool=REFUSE,
                                  int=ANY)),
            "residues": CPLX, "E": OPT_REAL, "F": OPT_REAL, "sensors": LAB, "actuators": LAB,
            "collocated": COL}
MODEL_K = obj_kind(("frf", lambda: FRF, REFUSE))
INFO = obj_kind(optional=True).but(dict=OK, none=REFUSE)
PARAMS_K = obj_kind(("empty", [], REFUSE), ("names", ["links"], REFUSE),
                    ("duplicate", lambda: [TB_P, TB_P], REFUSE), ("one", lambda: TB_P, ANY),
                    ("wrong_size", lambda: [sd.Parameter("s", dK=DK_SPRING)], REFUSE))
#: paths: an error may name the file rather than ``path``; OSError is a clean refusal too
READ_PATH = Arg(path_kind(TMP, True), ("file",))
NPZ_WRITE_PATH = Arg(path_kind(TMP, False, suffix=True), ("file",))
FILE_ERRORS = (ValueError, TypeError, OSError)


def estimate_classes():
    """Input records that the H1 estimate cannot use."""
    def zero_channel(draw, v):
        a = np.array(v, float, copy=True)
        a[:, draw(st.integers(0, a.shape[1] - 1))] = 0.0
        return a

    def identical(draw, v):
        a = np.array(v, float, copy=True)
        a[:, 1] = a[:, 0]
        return a
    return {"zero_channel": Cls(zero_channel, REFUSE), "identical": Cls(identical, REFUSE)}


def estimate_args():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((512, 2))
    y = np.column_stack([u[:, 0] + 0.5 * np.roll(u[:, 1], 1), u[:, 1] - 0.2 * np.roll(u[:, 0], 2),
                         u.sum(axis=1)])
    return {"u": u, "y": y, "fs": 100.0, "nperseg": 64, "sensors": ["y0", "y1", "y2"],
            "actuators": ["u0", "u1"], "quantity": "displacement", "window": "hann"}


def impact_args():
    """Three hammer hits (an 8-sample pulse) on a 2-sensor response, 256 samples each."""
    rng = np.random.default_rng(0)
    t = np.arange(256)
    pulse = np.where(t < 8, np.sin(np.pi * t / 8), 0.0)
    h = np.exp(-t / 40)[:, None] * np.column_stack([np.sin(t / 3), np.cos(t / 5)])
    hits = []
    for k in range(3):
        f = (1 + 0.1 * k) * pulse + 1e-3 * rng.standard_normal(t.size)
        y = np.column_stack([np.convolve(f, h[:, i])[:t.size] for i in range(2)])
        hits.append((f, y + 1e-3 * rng.standard_normal(y.shape)))
    return {"hits": hits, "fs": 1000.0, "force_window": 0.2, "exponential": 0.05,
            "estimator": "H1", "quantity": "accelerance", "sensors": ["y0", "y1"]}


def _bad_hits(kind):
    hits = impact_args()["hits"]
    if kind == "nan":
        hits[1][1][5, 0] = np.nan
    elif kind == "short":
        hits[2] = (hits[2][0][:-1], hits[2][1][:-1])
    elif kind == "triple":
        hits[0] = hits[0] + (hits[0][0],)
    return hits


def is_impact_frf(res, args=None):
    is_frf(res, args)
    assert res.H.shape[2] == 1 and res.coherence is not None
    assert (res.exponential_tau is None) == (args is None or args.get("exponential") is None)


#: issue 25 rows: a hybrid model, a placement study, units strings for the round trips
HY = sd.hybrid(FE, NM_FE, B_FE.T.copy())
STUDY = placement.placement_study(NM_FE, FE, (1.0, 40.0), kv=5.0,
                                  candidates=[("N1", "N2"), ("N3", "N4")])
UNITS = Kind({"none": Cls(_fixed(None), OK), "empty": Cls(_fixed("")),
              "none_word": Cls(_pick("NONE", "none")), "long": Cls(_fixed("m/s^2 per N, " * 4)),
              "newline": Cls(_fixed("m/s^2\n/N")), "unicode": Cls(_fixed("\u00b5m/N")),
              "blank": Cls(_fixed(" m/N ")), "number": Cls(_fixed(3), REFUSE),
              "bytes": Cls(_fixed(b"m/N"), REFUSE)})


def _uff_round_trip(a):
    """An FRF written to UFF and read back: ``(frf, back)``."""
    binary = a.pop("binary")
    frf = sd.FRF(FREQ, H, **a)
    path = TMP / "round.uff"
    sd.write_uff(frf, path, binary=binary, overwrite=True)
    return frf, sd.read_uff(path)


def _npz_round_trip(a):
    """A model and its FRF (with units) saved with ``sd.save`` and loaded back."""
    units = a.pop("units")
    nm = _nm(a)
    frf = sd.FRF(FREQ, nm.frf(FREQ).H, sensors=nm.sensors, actuators=nm.actuators, units=units)
    return [(obj, sd.load(sd.save(obj, TMP / f"round{k}"))) for k, obj in enumerate((nm, frf))]


def same_round_trip(res, args=None):
    """What was written is what is read: labels, units, quantity, pairs, numbers."""
    for obj, back in (res if isinstance(res, list) else [res]):
        _same_object(obj, back)


def _same_object(obj, back):
    assert type(back) is type(obj)
    names = ("freq", "H", "coherence", "quantity", "units", "collocated") if isinstance(
        obj, sd.FRF) else [f.name for f in dataclasses.fields(obj) if f.name != "info"]
    for name in ("sensors", "actuators", *names):
        a, b = getattr(obj, name), getattr(back, name)
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            assert a is not None and b is not None, name
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=0, err_msg=name)
        else:
            assert a == b, f"{name}: wrote {a!r}, read {b!r}"


ENTRIES = [
    # --- data -------------------------------------------------------------------------
    Entry("FRF", _call(sd.FRF), frf_args, {
        "freq": FREQ_K, "H": Arg(CPLX.but(ndim_down=ANY), ("freq",)), "quantity": QTY,
        "sensors": LAB, "actuators": LAB, "collocated": COL,
        "coherence": Arg(array(optional=True).but(
            negative=REFUSE, huge=REFUSE, int=ANY), ("coherence",))}, is_frf, weight=2),
    Entry("FRF.band", lambda a: _frf(a).band(a["fmin"], a["fmax"]),
          _plus(lambda: {"freq": FREQ.copy(), "H": H.copy()}, fmin=10.0, fmax=30.0),
          {"freq": FREQ_K, "H": CPLX,
           "fmin": Arg(number(zero=ANY), ("band",)), "fmax": Arg(number(), ("band",))}, is_frf),
    Entry("FRF.to", lambda a: _frf(a, ("freq", "H", "quantity")).to(a["to"]),
          _plus(lambda: {"freq": FREQ.copy(), "H": H.copy(), "quantity": "velocity"},
                to="acceleration"),
          {"freq": FREQ_K, "H": CPLX, "quantity": QTY, "to": Arg(QTY, ("quantity",))}, is_frf),
    Entry("FRF.select", lambda a: FRF.select(**a), lambda: {"sensors": [1], "actuators": ["N1.x"]},
          {"sensors": Arg(obj_kind(("index", -3, REFUSE), ("unknown", ["nope"], REFUSE),
                                   ("empty", [], REFUSE), ("bool", [True], REFUSE),
                                   ("float", [0.0], REFUSE), optional=True)),
           "actuators": Arg(obj_kind(("index", 2, REFUSE), ("label", "N2.x", OK),
                                     optional=True))}, is_frf),
    Entry("FRF.from_system", _call(sd.FRF.from_system),
          lambda: {"sys": NM, "freq": FREQ.copy(), "quantity": "velocity"},
          {"sys": _systems(("cm", lambda: CM, OK), ("tf", lambda: TF, OK),
                           ("unstable", lambda: SS_UNSTABLE, ANY)),
           "freq": FREQ_K, "quantity": QTY}, is_frf),
    Entry("estimate_frf", _call(sd.estimate_frf), lambda: estimate_args(),
          {"u": Arg(REAL.but(zero=REFUSE, ndim_up=REFUSE, **estimate_classes())),
           "y": Arg(REAL.but(zero=ANY), ("u",)), "fs": number(),
           "nperseg": integer(8, optional=True), "sensors": LAB, "actuators": LAB,
           "quantity": QTY, "window": choice_kind("hann", "boxcar")}, is_frf),
    Entry("impact_frf", _call(sd.impact_frf), impact_args,
          {"hits": obj_kind(("empty", [], REFUSE), ("nan", lambda: _bad_hits("nan"), REFUSE),
                            ("short", lambda: _bad_hits("short"), REFUSE),
                            ("triple", lambda: _bad_hits("triple"), REFUSE)),
           "fs": number(), "force_window": number(optional=True),
           "exponential": number(optional=True), "estimator": choice_kind("H1", "H2", "Hv"),
           "quantity": QTY, "sensors": LAB}, is_impact_frf),
    Entry("read_uff", _call(sd.read_uff), lambda: {"path": str(UFF_PATH)},
          {"path": READ_PATH}, is_frf, errors=FILE_ERRORS),
    Entry("write_uff", _call(sd.write_uff),
          lambda: {"frf": FRF, "path": str(TMP / "w.uff"), "binary": True, "overwrite": True},
          {"frf": MODEL_K.but(frf=None), "path": Arg(path_kind(TMP, False), ("file",)),
           "binary": flag_kind(),
           "overwrite": flag_kind()}, errors=FILE_ERRORS),
    Entry("save", _call(sd.save), lambda: {"model": NM, "path": str(TMP / "m.npz")},
          {"model": obj_kind(("cm", lambda: CM, OK), ("fe", lambda: FE, OK),
                             ("um", lambda: UM1, OK)), "path": NPZ_WRITE_PATH},
          errors=FILE_ERRORS),
    Entry("load", _call(sd.load), lambda: {"path": str(MODEL_PATH)},
          {"path": READ_PATH}, errors=FILE_ERRORS),
    # --- complex modes ------------------------------------------------------------------
    Entry("ComplexModeModel", _call(sd.ComplexModeModel), _plus(cm_args, cost=0.1, info={}),
          {**CM_KINDS, "in_band": mask_kind(), "info": INFO,
           "cost": number(zero=OK, negative=ANY).but(nan=OK, inf=ANY), "band": Arg(
              band_kind().but(none=OK), ("band",))}, is_cm, weight=2),
    Entry("ComplexModeModel.frf", lambda a: _cm(a).frf(**a),
          _plus(cm_args, freq=FREQ.copy(), quantity="acceleration"),
          {**CM_KINDS, "freq": FREQ_K, "quantity": QTY}, is_frf, weight=2),
    Entry("ComplexModeModel.to_statespace", lambda a: _cm(a).to_statespace(**a),
          _plus(cm_args, quantity="velocity", omega_c=2000.0),
          {**CM_KINDS, "quantity": QTY, "omega_c": number(optional=True)}, is_ss, weight=2),
    Entry("ComplexModeModel.minimal", lambda a: _cm(a).minimal(**a),
          _plus(cm_args, multiplicity=1),
          {"residues": CPLX, "multiplicity": integer(1).but(array=ANY)}, is_cm),
    Entry("ComplexModeModel.scaled", lambda a: _cm(a).scaled(**a),
          _plus(cm_args, collocated=[(0, 0), (1, 1)], spread_tol=0.1),
          {"residues": CPLX.but(real=ANY), "collocated": COL,
           "spread_tol": number(zero=ANY).but(inf=ANY)}),
    Entry("ComplexModeModel.singular_value_ratios", lambda a: _cm(a).singular_value_ratios(),
          cm_args, {"residues": CPLX}),
    Entry("ComplexModeModel.residue_std", lambda a: _cm(a).residue_std(sd.FRF(
        FREQ, H, coherence=a.pop("coherence")), **a),
          _plus(cm_args, coherence=np.full(H.shape, 0.9), n_averages=10),
          {"residues": CPLX, "coherence": array().but(negative=REFUSE, huge=REFUSE,
                                                      none=OK),   # no coherence: residual
           "n_averages": integer(1, optional=True)}),   # None: from frf.averages
    # --- identification (chapter III) -------------------------------------------------
    Entry("initial_poles", lambda a: sd.initial_poles(_frf(a), **a),
          lambda: {"freq": FREQ.copy(), "H": H.copy(), "band": (6.0, 35.0), "n": 2,
                   "damping": 0.01, "n_sv": 2, "prominence": 2.0},
          {"freq": FREQ_K, "H": CPLX, "band": band_kind().but(none=OK, outside=REFUSE),
           "n": integer(1, optional=True), "damping": number(), "n_sv": integer(1),
           "prominence": number(zero=ANY)}),
    Entry("identify", lambda a: sd.identify(_frf(a), **a),
          lambda: {"freq": FREQ.copy(), "H": H.copy(), "poles": None, "band": (6.0, 35.0)},
          {"freq": FREQ_K, "H": Arg(CPLX.but(real=ANY), ("frf",)),
           "poles": Arg(CPLX.but(none=OK, negative=REFUSE, real=REFUSE, ndim_down=ANY), (),
                        NM.poles),
           "band": band_kind().but(none=OK, outside=REFUSE)}, is_cm, weight=0.5),
    Entry("normal_modes", lambda a: sd.normal_modes(_cm(a), **a),
          _plus(cm_args, collocated=[(0, 0), (1, 1)]),
          {"poles": Arg(CM_KINDS["poles"].kind, ("cm",)),
           "residues": Arg(CPLX.but(real=ANY), ("cm",)),
           "collocated": COL.but(empty=REFUSE)},
          is_nm),
    # --- normal modes -----------------------------------------------------------------
    Entry("NormalModeModel", _call(sd.NormalModeModel),
          _plus(nm_args, F=None, omega_c=None, shapes=np.ones((3, 2)), dofs=("a", "b", "c"),
                info={"x": 1}),
          {**NM_KINDS, "F": Arg(OPT_REAL, (), np.full((2, 2), -1e-3)),
           "omega_c": number(optional=True), "shapes": OPT_REAL.but(none=ANY),
           "dofs": Arg(LAB, ("shapes",)), "info": INFO},
          is_nm, weight=2),
    Entry("NormalModeModel.frf", lambda a: _nm(a).frf(**a),
          _plus(nm_args, freq=FREQ.copy(), quantity="acceleration"),
          {**NM_KINDS, "freq": FREQ_K, "quantity": QTY}, is_frf, weight=2),
    Entry("NormalModeModel.to_statespace", lambda a: _nm(a).to_statespace(**a),
          _plus(nm_args, quantity="acceleration", omega_c=2000.0),
          {**NM_KINDS, "quantity": QTY, "omega_c": number(optional=True)}, is_ss, weight=2),
    Entry("NormalModeModel.poles", lambda a: _nm(a).poles, nm_args, NM_KINDS),
    Entry("NormalModeModel.modified", lambda a: NM.modified(**a),
          lambda: {"dmu": 0.1 * np.eye(2), "dGamma": np.diag([1.0, 2.0]),
                   "dOmega": 100.0 * np.ones((2, 2))},
          {"dmu": OPT_REAL, "dGamma": OPT_REAL, "dOmega": OPT_REAL}, is_nm),
    Entry("NormalModeModel.with_feedback", lambda a: NM_FE.with_feedback(**a),
          lambda: {"b": FE.strut("N1", "N2"), "c": FE.strut("N1", "N2").T, "kp": 10.0,
                   "kv": 1.0, "modal": False},
          {"b": REAL, "c": REAL.but(ndim_down=ANY), "kp": array(ndim_free=True),
           "kv": array(ndim_free=True),
           "modal": flag_kind()}, is_nm),
    Entry("NormalModeModel.uncertain", lambda a: NM.uncertain(**a),
          lambda: {"dGamma": np.diag([0.1, 0.1]), "dOmega": np.diag([10.0, 10.0]),
                   "db": None, "dc": np.full((2, 2), 0.01)},
          {"dGamma": OPT_REAL.but(negative=REFUSE), "dOmega": OPT_REAL.but(negative=REFUSE),
           "db": Arg(OPT_REAL.but(negative=REFUSE), (), np.ones((2, 2))),
           "dc": OPT_REAL.but(negative=REFUSE)}),
    # --- finite elements -----------------------------------------------------------------
    Entry("FEModel", _call(sd.FEModel), fe_args,
          {"M": REAL.but(negative=REFUSE, zero=REFUSE), "K": REAL, "C": OPT_REAL,
           "dofs": LAB, "nodes": obj_kind(optional=True), "elements": obj_kind(
               ("unknown_node", [("N0", "X9")], REFUSE), ("triple", [("N0", "N1", "N2")],
                                                          REFUSE), optional=True)}),
    Entry("FEModel.modes", lambda a: FE.modes(**a),
          lambda: {"n": 3, "method": "auto", "sigma": None},
          {"n": integer(1), "method": choice_kind("dense", "auto"),
           "sigma": number(optional=True, zero=ANY, negative=ANY)}),
    Entry("FEModel.frf", lambda a: FE.frf(**a),
          lambda: {"freq": FREQ.copy(), "b": B_FE.copy(), "c": B_FE.T.copy(),
                   "quantity": "velocity"},
          {"freq": FREQ_K, "b": REAL, "c": OPT_REAL.but(ndim_down=ANY), "quantity": QTY}, is_frf),
    Entry("FEModel.normal_mode_model", lambda a: FE.normal_mode_model(**a),
          lambda: {"b": B_FE.copy(), "c": B_FE.T.copy(), "n": 3, "damping": 0.01,
                   "static": False},
          {"b": REAL, "c": REAL.but(ndim_down=ANY, none=ANY), "n": integer(1),
           "damping": number(zero=ANY),
           "static": flag_kind()}, is_nm),
    Entry("FEModel.static_correction", lambda a: FE.static_correction(**a),
          lambda: {"b": B_FE.copy(), "phi": FE.modes(2)[1].copy()},
          {"b": REAL, "phi": REAL}),
    Entry("FEModel.strut", lambda a: FE.strut(**a), lambda: {"node_a": "N1", "node_b": "N2"},
          {"node_a": obj_kind(("unknown", "N99", REFUSE), ("same", "N2", REFUSE)),
           "node_b": obj_kind(("unknown", "N99", REFUSE))}),
    Entry("FEModel.point", lambda a: FE.point(**a),
          lambda: {"dofs": ["N1"], "direction": [1, 0, 0]},
          {"dofs": obj_kind(("unknown", ["N99"], REFUSE), ("empty", [], REFUSE)),
           "direction": array(optional=True).but(zero=REFUSE, none=ANY)}),
    Entry("FEModel.dof_index", lambda a: FE.dof_index(**a), lambda: {"labels": ["N1.x"]},
          {"labels": obj_kind(("unknown", ["N1.q"], REFUSE), ("one", "N2.x", OK))}),
    Entry("FEModel.static_response", lambda a: FE.static_response(**a),
          lambda: {"b": B_FE.copy()}, {"b": REAL}),
    Entry("FEModel.principal_static_modes", lambda a: FE.principal_static_modes(**a),
          lambda: {"phi_s": FE.static_response(B_FE), "rtol": 1e-8},
          {"phi_s": REAL, "rtol": number()}),
    # --- FE update (chapter IV) ---------------------------------------------------------
    Entry("Parameter", _call(sd.Parameter),
          lambda: {"name": "k", "dM": None, "dK": DK_SPRING.copy(), "dC": None,
                   "bounds": (-0.5, 2.0), "scale": None, "description": ""},
          {"name": label_kind(), "dM": Arg(OPT_REAL, (), DK_SPRING), "dK": OPT_REAL.but(none=ANY),
           "dC": Arg(OPT_REAL, (), DK_SPRING),
           "bounds": band_kind().but(negative=ANY, outside=REFUSE, huge=REFUSE, tiny=ANY,
                                     inf_high=ANY),
           "scale": number(optional=True), "description": obj_kind().but(string=OK, none=ANY)},
          nan_ok=True),                                 # infinite bounds are allowed
    Entry("update", lambda a: sd.update(a.pop("fe"), _tb_frf(a), progress=False, **a),
          lambda: {"fe": TB, "freq": TB_FRF.freq.copy(), "H": TB_FRF.H.copy(),
                   "parameters": [TB_P], "band": None, "damping": 0.003,
                   "strategy": "two-stage", "fmax": None, "max_nfev": None},
          {"fe": obj_kind(("nm", lambda: NM, REFUSE)), "freq": Arg(FREQ_K, ("frf",)),
           "H": Arg(CPLX.but(real=ANY), TB_FRF_NAMES), "parameters": PARAMS_K,
           "band": Arg(band_kind().but(none=OK), (), (10.0, 30.0)),
           "damping": number(optional=True, zero=ANY).but(data=Cls(lambda d, v: "data", OK)),
           "strategy": choice_kind("two-stage", "logls").but(none=REFUSE),
           "fmax": number(optional=True), "max_nfev": integer(1, optional=True)},
          weight=0.2, seconds=120),
    Entry("identifiability", lambda a: sd.identifiability(a.pop("fe"), _tb_frf(a), **a),
          lambda: {"fe": TB, "freq": TB_FRF.freq.copy(), "H": TB_FRF.H.copy(),
                   "parameters": [TB_P], "band": None, "damping": 0.003, "noise": None,
                   "n_averages": 1, "corr_max": 0.95, "fmax": None},
          {"fe": obj_kind(("nm", lambda: NM, REFUSE)), "freq": Arg(FREQ_K, ("frf",)),
           "H": Arg(CPLX.but(real=ANY), TB_FRF_NAMES), "parameters": PARAMS_K,
           "band": Arg(band_kind().but(none=OK), (), (10.0, 30.0)),
           "damping": number(optional=True, zero=ANY).but(data=Cls(lambda d, v: "data", OK)),
           "noise": number(optional=True, zero=OK), "n_averages": integer(1),
           "corr_max": number().but(huge=REFUSE), "fmax": number(optional=True)},
          is_identifiability, weight=0.3, seconds=120, nan_ok=True),
    # --- closing the loop with measured data -------------------------------------------------
    Entry("diagnose", lambda a: sd.diagnose(a.pop("model"), _dg_frf(a), **a),
          lambda: {"model": NM, "freq": FREQ.copy(), "H": H_LATE.copy(), "fe": None,
                   "executor": None, "band": None, "reach": None, "max_effects": 2,
                   "noise": None, "progress": False},
          {"model": obj_kind(("frf", lambda: FRF, REFUSE), ("fe", lambda: FE, REFUSE)),
           "freq": Arg(FREQ_K, ("frf",)), "H": Arg(CPLX.but(real=ANY), ("frf",)),
           "fe": obj_kind(("nm", lambda: NM, REFUSE), optional=True),
           "executor": obj_kind(optional=True),
           "band": Arg(band_kind().but(none=OK), (), (10.0, 30.0)),
           "reach": number(optional=True), "max_effects": integer(0),
           "noise": number(optional=True, zero=ANY)},
          is_diagnosis, weight=0.3, seconds=60),
    # --- testbed and hybrid ----------------------------------------------------------------
    Entry("testbed_frf", _call(sd.testbed_frf),
          lambda: {"quantity": "acceleration", "band": (8.0, 60.0), "n": 20, "noise": 0.0,
                   "seed": 0},
          {"quantity": QTY, "band": band_kind(), "n": integer(2), "noise": number(zero=OK),
           "seed": integer(0, optional=True)}, is_frf, weight=0.1, seconds=60),
    Entry("hybrid", lambda a: sd.hybrid(FE, **a),
          lambda: {"nm": NM_FE, "sensor_c": B_FE.T.copy(), "actuator_b": None,
                   "fmax": None, "mac_min": 0.8},
          {"nm": obj_kind(("cm", lambda: CM, REFUSE)), "sensor_c": REAL,
           "actuator_b": Arg(OPT_REAL, (), B_FE), "fmax": number(optional=True),
           "mac_min": number(zero=ANY)}, is_nm),
    # --- uncertainty, robustness, closed loop --------------------------------------------
    Entry("UncertainModel.perturbed", lambda a: UM1.perturbed(**a),
          lambda: {"deltas": np.array([0.5])},
          {"deltas": REAL.but(huge=REFUSE)}, is_ss),
    Entry("UncertainModel.sample_deltas", lambda a: UM1.sample_deltas(**a),
          lambda: {"n": 3, "seed": 0},
          {"n": integer(1), "seed": integer(0, optional=True)}),
    Entry("UncertainModel.sample", lambda a: UM1.sample(**a), lambda: {"n": 3, "seed": 0},
          {"n": integer(1), "seed": integer(0, optional=True)}),
    Entry("UncertainModel.frf_envelope", lambda a: UM1.frf_envelope(**a),
          lambda: {"freq": np.linspace(0.1, 1.0, 8), "n_samples": 5, "seed": 0,
                   "max_vertices": 4, "executor": None},
          {"freq": FREQ_K, "n_samples": integer(0), "seed": integer(0, optional=True),
           "max_vertices": integer(0), "executor": obj_kind(optional=True)}),
    Entry("uncertain_from_data", _call(sd.uncertain_from_data),
          lambda: {"models": NMS, "level": 0.95},
          {"models": obj_kind(("no statistics", lambda: NM1, REFUSE),
                              ("two tests", lambda: [NMS, NMS2], OK),
                              ("one test in a list", lambda: [NMS], OK)),
           "level": number()}),
    Entry("robust_stability", _call(sd.robust_stability),
          lambda: {"um": UM1, "controller": K1, "freq": np.linspace(0.2, 1.0, 4), "eps": 0.01,
                   "n_directions": 2, "seed": 0, "rtol": 0.005, "executor": None},
          {"um": obj_kind(("nm", lambda: NM1, REFUSE)), "controller": _systems(other=REFUSE),
           "freq": FREQ_K.but(none=OK), "eps": number(), "n_directions": integer(0),
           "seed": integer(0).but(none=ANY), "rtol": number(),
           "executor": obj_kind(optional=True)},
          weight=0.3),
    Entry("worst_case_gain", _call(sd.worst_case_gain),
          lambda: {"um": UM1, "controller": K1, "output": 0, "input": 0,
                   "freq": np.linspace(0.2, 1.0, 4), "n_samples": 4, "seed": 0,
                   "executor": None},
          {"um": obj_kind(("nm", lambda: NM1, REFUSE)), "controller": _systems(other=REFUSE),
           "output": integer(0), "input": integer(0), "freq": FREQ_K.but(none=OK),
           "n_samples": integer(0), "seed": integer(0).but(none=ANY),
           "executor": obj_kind(optional=True)}),
    Entry("rms", _call(sd.rms), lambda: {"sys": NM, "band": (5.0, 40.0), "psd": 1.0},
          {"sys": _systems(("unstable", lambda: SS_UNSTABLE, REFUSE), ("tf", lambda: TF, OK),
                           ("cm", lambda: CM, ANY)),
           "band": band_kind(infinite_ok=True).but(outside=OK, tiny=OK, huge=OK),
           "psd": array().but(negative=REFUSE, ndim_down=OK, ndim_up=REFUSE)}),
    Entry("feedback", _call(sd.feedback),
          lambda: {"plant": NM1, "controller": K1, "sign": -1.0},
          {"plant": _systems(other=ANY), "controller": _systems(other=ANY),
           "sign": number(positive=False).but(zero=REFUSE, huge=REFUSE, tiny=REFUSE)}, is_ss),
    Entry("closedloop.modal_damping", _call(cl.modal_damping),
          lambda: {"sys": NM, "band": (1.0, 50.0)},
          {"sys": _systems(("tf", lambda: TF, OK)),
           "band": band_kind(infinite_ok=True).but(none=OK, outside=OK, huge=OK, tiny=OK)}),
    Entry("placement_study", _call(placement.placement_study),
          lambda: {"model": NM_FE, "fe": FE, "band": (1.0, 40.0), "kv": 5.0, "kp": 0.0,
                   "candidates": [("N1", "N2"), ("N3", "N4")], "outputs": None, "psd": 1.0,
                   "criterion": "rms", "executor": None},
          {"model": obj_kind(("nm", lambda: NM, REFUSE)), "fe": obj_kind(),
           "band": band_kind().but(outside=REFUSE), "kv": number(zero=ANY),
           "kp": number(positive=False), "candidates": obj_kind(
               ("unknown", [("N1", "N99")], REFUSE), optional=True),
           "outputs": obj_kind(("unknown", ["nope"], REFUSE), optional=True),
           "psd": array().but(negative=REFUSE, ndim_down=OK),
           "criterion": choice_kind("rms", "damping").but(none=REFUSE),
           "executor": obj_kind(optional=True)}, weight=0.3),
    Entry("testing.record_rms", _call(stt.record_rms),
          lambda: {"system": NM1, "band": (0.1, 2.0), "psd": 1.0, "controller": None},
          {"system": _systems(), "band": band_kind(infinite_ok=True).but(
              outside=OK, huge=OK, tiny=OK),
           "psd": array().but(negative=REFUSE, ndim_down=OK, ndim_up=ANY),
           "controller": _systems(("k", lambda: K1, OK), other=ANY).but(none=OK)}),
    Entry("testing.assert_rms_matches", _call(stt.assert_rms_matches),
          lambda: {"system": NM1, "snapshot": stt.record_rms(NM1, (0.1, 2.0)), "rtol": 1e-6},
          {"system": Arg(_systems(other=ANY), ("snapshot",)),
           "snapshot": obj_kind(("missing", str(TMP / "none.json"),
                                                       REFUSE)),
           "rtol": number(zero=OK)}, errors=(ValueError, TypeError, AssertionError)),
    # --- plots (validation only) ---------------------------------------------------------
    Entry("plot.bode", lambda a: splot.bode(**a),
          lambda: {"systems": FRF, "freq": None, "quantity": None, "max_cols": 2},
          {"systems": Arg(_systems(other=ANY), ("freq",)),
           "freq": Arg(FREQ_K.but(none=OK), (), FREQ),
           "quantity": quantity_kind(True),
           "max_cols": integer(1)}, close_figures, weight=0.3),
    Entry("plot.cmif", lambda a: splot.cmif(**a),
          lambda: {"data": FRF, "freq": None, "n_sv": None, "poles": None},
          {"data": Arg(_systems(other=ANY), ("freq",)),
           "freq": Arg(FREQ_K.but(none=OK), (), FREQ), "n_sv": integer(1, optional=True),
           "poles": Arg(OPT_REAL.but(complex=OK, ndim_down=ANY), (), NM.poles)},
          close_figures, weight=0.3),
    Entry("plot.mac", lambda a: splot.mac(**a), lambda: {"a": CPHI.copy(), "b": None},
          {"a": REAL.but(complex=OK, zero=ANY, ndim_down=ANY),
           "b": Arg(OPT_REAL.but(complex=OK, ndim_down=ANY), (), CPHI)},
          close_figures, weight=0.3),
    Entry("plot.cost_map", lambda a: splot.cost_map(**a),
          lambda: {"x": np.linspace(0, 1, 4), "y": np.linspace(0, 2, 3),
                   "cost": np.arange(12.0).reshape(4, 3) + 1.0, "levels": 5},
          {"x": REAL, "y": REAL, "cost": REAL.but(nan=ANY), "levels": integer(2)},
          close_figures, weight=0.3),
    Entry("plot.phase_display", lambda a: splot.phase_display(**a),
          lambda: {"h": H[:, 0, 0].copy(), "coherence": np.full(FREQ.size, 0.9),
                   "reference": None},
          {"h": CPLX, "coherence": OPT_REAL.but(negative=REFUSE, huge=REFUSE),
           "reference": Arg(OPT_REAL.but(nan=OK), (), FREQ)}, nan_ok=True),
    Entry("plot.phase_dispersion", lambda a: splot.phase_dispersion(**a),
          lambda: {"r": CM.residues[0, :, 0].copy(), "rel": 0.1},
          {"r": CPLX, "rel": number(zero=OK).but(huge=REFUSE)}),
    Entry("plot.stabilisation_flags", lambda a: splot.stabilisation_flags(**a),
          lambda: {"poles": [NM.poles[:1], NM.poles], "freq_tol": 0.01, "damping_tol": 0.05,
                   "mac_min": 0.95},
          {"poles": obj_kind(("nan", [np.array([np.nan + 1j])], REFUSE)).but(array=ANY, list=ANY),
           "freq_tol": number(), "damping_tol": number(), "mac_min": number().but(huge=REFUSE)}),
    Entry("plot.complex_residues", lambda a: splot.complex_residues(**a),
          lambda: {"data": CM, "mode": 0, "actuator": None, "scaled": False, "rel": 0.1},
          {"data": obj_kind(("nm", lambda: NM, ANY)).but(array=ANY),
           "mode": integer(0).but(below=ANY),
           "actuator": Arg(obj_kind(("label", "N2.x", OK), ("index", 1, OK),
                                    ("unknown", "nope", REFUSE), optional=True)),
           "scaled": flag_kind(), "rel": number(zero=OK).but(huge=REFUSE)},
          close_figures, weight=0.2),
    Entry("plot.mode_shapes", lambda a: splot.mode_shapes(**a),
          lambda: {"fe": FE, "shapes": FE.modes(3)[1].copy(), "modes": 0, "scale": None},
          {"fe": obj_kind(), "shapes": Arg(OPT_REAL.but(complex=OK), (), FE.modes(3)[1]),
           "modes": obj_kind(("index", 1, OK), ("several", [0, 2], OK), ("range", 7, REFUSE),
                             ("negative", -1, REFUSE), ("empty", [], REFUSE)),
           "scale": number(optional=True)}, close_figures, weight=0.2),
    Entry("plot.envelope", lambda a: splot.envelope(**a),
          lambda: {"samples": UM1, "freq": np.linspace(0.1, 1.0, 8), "n_samples": 4, "seed": 0},
          {"samples": obj_kind(("frf", lambda: FRF, OK)), "freq": FREQ_K.but(none=ANY),
           "n_samples": integer(1), "seed": integer(0, optional=True)},
          close_figures, weight=0.2),
    Entry("plot.stabilisation", lambda a: splot.stabilisation(**a),
          lambda: {"poles": [NM.poles[:1], NM.poles], "frf": FRF, "orders": None,
                   "band": None},
          {"poles": obj_kind(("nan", [np.array([np.nan + 1j])], REFUSE)).but(array=ANY, list=ANY),
           "frf": obj_kind(optional=True),
           "orders": obj_kind(("short", [1], REFUSE), optional=True).but(list=ANY),
           "band": Arg(band_kind().but(none=OK, outside=ANY, huge=ANY, tiny=ANY), (),
                       (5.0, 40.0))},
          close_figures, weight=0.2),
    # --- issue 25: the rest of the public surface, and round trips through the files ------
    Entry("write_uff+read_uff", _uff_round_trip,
          lambda: {"quantity": "velocity", "sensors": LABELS, "actuators": LABELS,
                   "collocated": [(0, 0), (1, 1)], "coherence": np.full(H.shape, 0.9),
                   "units": "m/s/N", "binary": True},
          {"quantity": QTY, "sensors": Arg(LAB, ("labels", "frf")),
           "actuators": Arg(LAB, ("labels", "frf")), "collocated": COL,
           "coherence": Arg(array(optional=True).but(negative=REFUSE, huge=REFUSE, int=ANY)),
           "units": Arg(UNITS, ("frf.units",)), "binary": flag_kind()},
          same_round_trip, errors=FILE_ERRORS),
    Entry("save+load", _npz_round_trip,
          lambda: {**nm_args(), "units": "m/N"}, {**NM_KINDS, "units": UNITS},
          same_round_trip, errors=FILE_ERRORS),
    Entry("FRF.transpose", lambda a: _frf(a, ("freq", "H", "sensors", "actuators",
                                               "collocated")).transpose(),
          lambda: {"freq": FREQ.copy(), "H": H[:, :, :1].copy(), "sensors": LABELS,
                   "actuators": LABELS[:1], "collocated": [(0, 0)]},
          {"freq": FREQ_K, "H": CPLX, "sensors": LAB, "collocated": COL}, is_frf),
    Entry("NormalModeModel.proportional", lambda a: _nm(a).proportional(), nm_args, NM_KINDS,
          is_nm),
    Entry("NormalModeModel.replace", lambda a: NM.replace(**a),
          lambda: {"Gamma": np.diag(0.05 * W), "E": None, "sensors": ("s1", "s2")},
          {"Gamma": REAL, "E": Arg(OPT_REAL, (), np.full((2, 2), 1e-5)), "sensors": LAB}, is_nm),
    Entry("ComplexModeModel.replace", lambda a: CM.replace(**a),
          lambda: {"residues": cm_args()["residues"], "in_band": np.array([True, False])},
          {"residues": CPLX, "in_band": mask_kind()}, is_cm),
    Entry("FEModel.rigid_modes", lambda a: sd.FEModel(**a).rigid_modes(), fe_args,
          {"M": REAL.but(negative=REFUSE, zero=REFUSE), "K": REAL}),
    Entry("FEModel.members", lambda a: TB.members(**a),
          lambda: {"kind": None, "section": "post_AB", "material": None},
          {"kind": obj_kind(("unknown", "nope", REFUSE), optional=True),
           "section": obj_kind(("unknown", "nope", REFUSE), ("two", ["post_AB", "post_C"],
                                                             OK), optional=True).but(list=REFUSE),
           "material": obj_kind(("unknown", "nope", REFUSE), optional=True)}),
    Entry("FEModel.member_matrices", lambda a: TB.member_matrices(**a),
          lambda: {"elements": [("N29", "N30")], "section": None},
          {"elements": obj_kind(("unknown", [("N29", "N999")], REFUSE),
                                ("empty", [], REFUSE), optional=True).but(list=REFUSE),
           "section": obj_kind(("unknown", "nope", REFUSE), optional=True)}, weight=0.3),
    Entry("FEModel.stiffness_parameter", lambda a: TB.stiffness_parameter(**a),
          lambda: {"name": "links", "section": ["post_AB", "post_C"], "bounds": (-0.5, 2.0)},
          {"name": label_kind(), "section": obj_kind(("unknown", ["nope"], REFUSE),
                                                      optional=True).but(list=REFUSE),
           "bounds": band_kind().but(negative=ANY, outside=REFUSE, huge=REFUSE, tiny=ANY,
                                     inf_high=ANY)}, nan_ok=True, weight=0.3),
    Entry("FEModel.mass_parameter", lambda a: TB.mass_parameter(**a),
          lambda: {"name": "plates", "nodes": ["N31", "N32"], "mass": None},
          {"name": label_kind(), "nodes": obj_kind(("unknown", ["N999"], REFUSE),
                                                    ("empty", [], REFUSE)).but(list=REFUSE),
           "mass": number(optional=True)}, nan_ok=True, weight=0.3),
    Entry("UncertainModel.lft", lambda a: NM.uncertain(**a).lft(),
          lambda: {"dGamma": np.diag([0.1, 0.1]), "dOmega": None},
          {"dGamma": OPT_REAL.but(negative=REFUSE), "dOmega": Arg(OPT_REAL.but(
              negative=REFUSE), (), np.diag([10.0, 10.0]))}),
    Entry("UncertainModel.compact_lft", lambda a: NM.uncertain(**a).compact_lft(),
          lambda: {"dGamma": np.diag([0.1, 0.1]), "dOmega": None},
          {"dGamma": OPT_REAL.but(negative=REFUSE), "dOmega": Arg(OPT_REAL.but(
              negative=REFUSE), (), np.diag([10.0, 10.0]))}),
    Entry("HybridModel.with_io", lambda a: HY.with_io(**a),
          lambda: {"b": B_FE.copy(), "c": B_FE.T.copy()},
          {"b": Arg(OPT_REAL, (), B_FE), "c": Arg(OPT_REAL.but(ndim_down=ANY), (), B_FE.T)},
          is_nm),
    Entry("testbed", _call(sd.testbed), lambda: {"link_stiffness": 1.0, "plate_mass": 1.0},
          {"link_stiffness": number(), "plate_mass": number()}, weight=0.1, seconds=60),
    Entry("PlacementStudy.table", lambda a: STUDY.table(**a), lambda: {"k": 2},
          {"k": integer(1)}),
]


UFF_PATH = TMP / "base.uff"
MODEL_PATH = TMP / "model"
sd.write_uff(FRF, UFF_PATH)
MODEL_PATH = pathlib.Path(sd.save(NM, MODEL_PATH))

BY_NAME = {e.name: e for e in ENTRIES}
assert len(BY_NAME) == len(ENTRIES), "two rows share a name"


def _excluded(name):
    return frozenset((a, c) for (e, a, c) in KNOWN if e == name)


def _run(entry, deadline, excluded, max_examples, **kw):
    """Draw ``max_examples`` cases of ``entry`` (except ``excluded``) and check each."""
    kw = {"max_examples": max(1, int(max_examples)),
          "suppress_health_check": [HealthCheck.too_slow, HealthCheck.filter_too_much,
                                    HealthCheck.data_too_large], **kw}

    @settings(**kw)
    @given(data=st.data())
    def run(data):
        args, mutated = draw_case(entry, data.draw, excluded)
        if not COUNT_ONLY:
            OUTCOMES[(entry.name, expect(entry, args, mutated, deadline))] += 1
            return
        try:                                 # the full run: count failures by kind, go on
            OUTCOMES[(entry.name, expect(entry, args, mutated, deadline))] += 1
        except AssertionError as exc:
            msg = str(exc).split("\n")[0]
            kind = next((k for k, words in FAILURE_KINDS if any(w in msg for w in words)),
                        "other")
            OUTCOMES[(entry.name, kind)] += 1
            FAILURES.setdefault(kind, []).append(msg)

    run()


def only(entry, argname, cls) -> frozenset:
    """Every (argument, class) pair of ``entry`` but one: draws of that class alone."""
    return frozenset((a, c) for a in entry.kinds for c in _kind(entry, a).classes
                     if (a, c) != (argname, cls))


def _kind(entry, a):
    k = entry.kinds[a]
    return k.kind if isinstance(k, Arg) else k


#: examples per known failure (derandomised in every profile, so the xfails are stable)
KNOWN_EXAMPLES = 15


def run_only(entry, argname, cls, deadline):
    """The check of ``test_known_failure``: a few draws of one class, no shrinking."""
    _run(entry, deadline, only(entry, argname, cls), KNOWN_EXAMPLES, derandomize=True,
         database=None, phases=[Phase.generate])


#: ``SDCTRL_FUZZ_EXAMPLES``: examples per unit weight (default: the hypothesis profile's);
#: ``SDCTRL_FUZZ_COUNT=1``: count failures by kind instead of failing (the full run of
#: ``benchmarks/fuzz_api.py``, which reports the counts)
EXAMPLES = int(os.environ.get("SDCTRL_FUZZ_EXAMPLES", "0")) or settings.default.max_examples
COUNT_ONLY = os.environ.get("SDCTRL_FUZZ_COUNT") == "1"
FAILURE_KINDS = (("hang", ("Hang escaped",)), ("crash", ("escaped",)),
                 ("unnamed", ("names none of",)),
                 ("wrong result", ("ill-formed", "NaN/inf", "accepted", "modified")),
                 ("valid refused", ("refused",)))
FAILURES: dict = {}


@pytest.mark.parametrize("entry", ENTRIES, ids=lambda e: e.name)
def test_entry_point(entry, deadline):
    _run(entry, deadline, _excluded(entry.name), entry.weight * EXAMPLES)


def _known_failure(key, deadline):
    """Each known failure still fails (strict xfail): when it passes, delete its KNOWN row."""
    __tracebackhide__ = True
    name, argname, cls = key
    try:
        run_only(BY_NAME[name], argname, cls, deadline)
        still = False
    except AssertionError:
        still = True
    if still:
        # imperative xfail (outside the except: no chained traceback): the outcome of a
        # failing xfail(strict=True) without pytest formatting a hypothesis traceback for
        # each of hundreds of rows, which takes ten times longer than the calls
        pytest.xfail(f"issue {OWNER.get(name, '?')}: {KNOWN[key]}")
    pytest.fail(f"{name}({argname}={cls}) no longer fails ({KNOWN[key]!r}): delete its row "
                "of tests/fuzz_known.py (strict xfail)")


if KNOWN:        # no parameter set (and no skipped test) once every known failure is fixed
    test_known_failure = pytest.mark.parametrize(
        "key", sorted(KNOWN), ids=lambda k: "-".join(k))(_known_failure)


def _sweep_every_class(entry, deadline):
    """Every class of every argument alone (slow): lists new failures and stale KNOWN rows."""
    new, fixed = [], []
    for a in entry.kinds:
        for c in _kind(entry, a).classes:
            try:
                run_only(entry, a, c, deadline)
                if (entry.name, a, c) in KNOWN:
                    fixed.append((a, c))
            except AssertionError as exc:
                if (entry.name, a, c) not in KNOWN:
                    new.append(str(exc).split("\n")[0])
    assert not new and not fixed, f"new failures: {new}; KNOWN rows now passing: {fixed}"


# the slow sweep is collected only on request (a local tool, not a CI test):
# SDCTRL_FUZZ_SWEEP=1 python -m pytest tests/test_api_fuzz.py -k sweep
if os.environ.get("SDCTRL_FUZZ_SWEEP"):
    test_sweep_every_class = pytest.mark.parametrize(
        "entry", ENTRIES, ids=lambda e: e.name)(_sweep_every_class)


#: public names without arguments to fuzz (result classes, a fixed testbed)
NO_ROW = {"testbed", "ImpactWarning", "RobustResult", "UpdateResult", "Identifiability",
          "Diagnosis", "Effect", "HybridModel", "PlacementStudy"}
#: names API.md announces (other work): merging them keeps CI green, but test_every_public_
#: name_has_a_row xfails, naming them, until their rows are added to ENTRIES
PENDING: set = set()


def test_every_public_name_has_a_row():
    """A new public name needs a row (the entry points of sd.__all__ and of the models)."""
    covered = {e.name.split(".")[0] for e in ENTRIES}
    missing = set(sd.__all__) - covered - NO_ROW
    assert not missing - PENDING, f"public names without a fuzz row: {sorted(missing - PENDING)}"
    if missing:
        pytest.xfail(f"no fuzz row yet for sd.{', sd.'.join(sorted(missing))}: add them")


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    if OUTCOMES:
        print("\nfuzzed calls:", sum(OUTCOMES.values()))
        for (name, outcome), n in sorted(OUTCOMES.items()):
            print(f"  {name:42s} {outcome:8s} {n}")
        for kind, msgs in sorted(FAILURES.items()):
            print(f"failures: {kind}: {len(msgs)}")
            for m in sorted(set(msgs))[:20]:
                print(f"    {m[:300]}")
