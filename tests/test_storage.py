"""sd.save / sd.load: exact round trips of every model and result type, hostile archives refused
before any large allocation, paths."""

import io
import json
import pathlib
import shutil
import os
import tracemalloc
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from exact import assert_same

import sdctrl as sd
from sdctrl import storage
from sdctrl.hybrids._predictions import HybridModel
from sdctrl.robust._stability import RobustResult


def round_trip(obj, tmp_path, name="m"):
    path = sd.save(obj, tmp_path / name)
    assert path == str(tmp_path / f"{name}.npz") and os.path.isfile(path)
    back = sd.load(tmp_path / name)                       # '.npz' found without being given
    assert_same(obj, back)
    return back


# ------------------------------------------------------------------------------------------
# models of the testbed (identified, normal modes, hybrid, FE, uncertain)
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def testbed_models():
    frf = sd.testbed_frf()
    fe = sd.testbed()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm = sd.identify(frf, progress=False)
        nm = sd.normal_modes(cm, frf.collocated)
        hy = sd.hybrid(fe, nm, list(frf.sensors))
    return {"frf": frf, "fe": fe, "cm": cm, "nm": nm, "hybrid": hy}


@pytest.mark.parametrize("key", ["frf", "fe", "cm", "nm", "hybrid"])
def test_testbed_models_round_trip_exactly(testbed_models, tmp_path, key):
    obj = testbed_models[key]
    back = round_trip(obj, tmp_path)
    if key == "hybrid":
        assert isinstance(back, HybridModel)
        assert back.construction.pairing.mac.min() > 0.9          # construction kept, usable
    if key == "fe":
        assert back.sparse and back.M.nnz == obj.M.nnz and back.C is not None
        assert np.array_equal(obj.modes(6)[0], back.modes(6)[0])    # same matrices, same modes
    if key in ("cm", "nm", "hybrid"):
        w = np.linspace(10, 50, 7)
        assert np.array_equal(obj.frf(w).H, back.frf(w).H)
        assert back.info == back.info and set(back.info) == set(obj.info)
    for name in ("H", "residues", "Omega", "M"):
        arr = getattr(back, name, None)
        if isinstance(arr, np.ndarray):
            assert not arr.flags.writeable                        # loaded models are immutable


def test_uncertain_model_of_testbed_round_trip(testbed_models, tmp_path):
    nm = testbed_models["nm"].replace(F=None)
    um = nm.uncertain(dGamma=0.1 * np.abs(nm.Gamma) + 1e-3 * np.eye(nm.n),
                      db=0.05 * np.abs(nm.phib), dc=0.02 * np.abs(nm.cphi))
    back = round_trip(um, tmp_path)
    assert back.blocks == um.blocks and len(back.params) > 10
    d = np.linspace(-1, 1, len(um.params))
    assert np.array_equal(um.perturbed(d).A, back.perturbed(d).A)
    hy = testbed_models["hybrid"]
    uh = hy.uncertain(dOmega=1e-2 * np.abs(hy.Omega))
    back = round_trip(uh, tmp_path, "hybrid")
    assert isinstance(back.model, HybridModel)


def test_dense_fe_frf_and_small_models_round_trip(tmp_path):
    fe = sd.FEModel(np.diag([2.0, 1.0, 1.5]), [[2, -1, 0], [-1, 2, -1], [0, -1, 1.0]],
                    C=0.01 * np.eye(3), dofs=["A.x", "B.x", "C.x"],
                    nodes={"A": (0, 0, 0), "B": (1, 0, 0.5), "C": (2, 0, 0)},
                    elements=[("A", "B"), ("B", "C")])
    round_trip(fe, tmp_path, "fe")
    round_trip(sd.FEModel(np.eye(2), np.eye(2)), tmp_path, "bare")      # no C, nodes, elements
    frf = sd.FRF([1.0], [[[1 + 2j]]], quantity="velocity", sensors=["s|1\n"],
                 actuators=[" a\u00e9 "], collocated=[(0, 0)], units="m/s/N", averages=4)
    assert round_trip(frf, tmp_path, "frf").averages == 4
    nm = sd.NormalModeModel(np.diag([4.0, 9.0]), np.diag([0.04, 0.06]), np.eye(2),
                            [[1.0], [0.5]], E=[[1e-3], [0.0]], F=[[0.0], [-1e-300]],
                            omega_c=123.0, sensors=["x", "y"], actuators=["u"],
                            shapes=np.eye(2), dofs=["N1.x", "N2.x"],
                            info={"a": [1, (2, 3.5), None], "nan": float("nan"),
                                  "inf": -float("inf"), "c": 1 - 2j, "i64": np.int64(-7),
                                  "f32": np.float32(0.1), "u": np.array(["ab", "c"]),
                                  "nested": {"deep": {"x": np.arange(3)}}, "t": ()})
    back = round_trip(nm, tmp_path, "nm")
    diagnostics = back.info                         # the info codec itself: dtypes and tuples kept
    assert diagnostics["i64"].dtype == np.int64 and isinstance(diagnostics["a"][1], tuple)
    cm = sd.ComplexModeModel(poles=[-0.1 + 10j], residues=[[[0.5j]]], cost=float("nan"),
                             band=(1.0, 2.0), collocated=[(0, 0)], in_band=[False])
    round_trip(cm, tmp_path, "cm")


def test_robust_result_round_trip(tmp_path):
    r = RobustResult(margin=2.5, margin_lower=float("inf"), stable=True, frequency=12.0,
                     worst_delta=np.array([0.5, -1.0]), mu_freq=np.linspace(1, 2, 4),
                     mu=np.array([0.1, 0.4, 0.3, 0.2]), info={"n_freq": 4})
    round_trip(r, tmp_path)


def test_saved_files_are_deterministic(tmp_path):
    nm = sd.NormalModeModel(np.diag([4.0]), np.diag([0.04]), [[1.0]], [[1.0]])
    a, b = sd.save(nm, tmp_path / "a"), sd.save(nm, tmp_path / "b.npz")
    assert b.endswith("b.npz") and not b.endswith(".npz.npz")
    assert Path(a).read_bytes() == Path(b).read_bytes()


def test_unstorable_info_dropped_with_warning_and_bad_types_refused(tmp_path):
    nm = sd.NormalModeModel(np.diag([4.0]), np.diag([0.04]), [[1.0]], [[1.0]],
                            info={"ok": 1, "fn": len, "items": [1, {2, 3}], "keys": {1: "a"}})
    with pytest.warns(storage.StorageWarning, match=r"info\['fn'\].*info\['items'\]\[1\]"):
        path = sd.save(nm, tmp_path / "m")
    back = sd.load(path)
    assert back.info == {"ok": 1, "items": [1, None]}          # dropped / replaced by None
    with pytest.raises(TypeError, match="model must be one of the storable types"):
        sd.save(object(), tmp_path / "x")
    with pytest.raises(TypeError, match="path must be a file path"):
        sd.save(nm, 3)
    assert not os.path.exists(tmp_path / "x.npz")
    assert "FEModel" in storage.registered() and "UncertainModel" in storage.registered()


LEGACY = pathlib.Path(__file__).resolve().parent / "data" / "legacy"


def test_load_reads_save_npz_files_and_finds_suffix(tmp_path):
    """An FRF written by ``save_npz`` (sdctrl 0.1, checked-in file) loads through sd.load."""
    ref = np.load(LEGACY / "reference.npz")
    old = sd.load(LEGACY / "frf_save_npz.npz")
    assert np.array_equal(old.H[::7, ::5, :], ref["frf_H"])
    assert_same(old, sd.load(LEGACY / "frf.npz"))
    shutil.copy(LEGACY / "frf_save_npz.npz", tmp_path / "legacy.npz")
    assert_same(old, sd.load(tmp_path / "legacy"))
    assert not hasattr(sd, "save_npz") and not hasattr(sd, "load_npz")


def test_missing_directory_fifo_paths(tmp_path):
    missing = tmp_path / "nothing"
    for reader in (sd.load,):
        with pytest.raises(FileNotFoundError, match="nothing"):
            reader(missing)
        with pytest.raises(ValueError, match="does not exist"):   # also a ValueError
            reader(missing)
        with pytest.raises(IsADirectoryError, match=str(tmp_path.name)):
            reader(tmp_path)
    fe = sd.FEModel(np.eye(1), np.eye(1))
    with pytest.raises(OSError, match="nowhere"):
        sd.save(fe, tmp_path / "nowhere" / "m")
    with pytest.raises(ValueError, match="must name a file"):
        sd.save(fe, str(tmp_path) + os.sep)
    with pytest.raises(IsADirectoryError, match="is a directory"):
        sd.save(fe, tmp_path / "d.npz") if os.mkdir(tmp_path / "d.npz") is None else None


# ------------------------------------------------------------------------------------------
# hostile archives
# ------------------------------------------------------------------------------------------
def _npy(arr=None, header=None, body=b""):
    buf = io.BytesIO()
    if header is None:
        np.lib.format.write_array(buf, arr, allow_pickle=True)
        return buf.getvalue()
    np.lib.format.write_array_header_1_0(buf, header)
    return buf.getvalue() + body


def _zip(path, members, compress=zipfile.ZIP_STORED):
    with zipfile.ZipFile(path, "w", compress) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return str(path)


def _model_members(tmp_path):
    nm = sd.NormalModeModel(np.diag([4.0, 9.0]), np.diag([0.04, 0.06]), np.eye(2), np.ones((2, 1)))
    with zipfile.ZipFile(sd.save(nm, tmp_path / "good")) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    return members, json.loads(np.load(io.BytesIO(members["__sdctrl__.npy"])).tobytes())


def _with_meta(members, meta):
    raw = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    return {**members, "__sdctrl__.npy": _npy(raw)}


def _refused(path, match):
    for reader in (sd.load,):
        with pytest.raises(ValueError, match=match):
            reader(path)


def test_huge_header_refused_before_allocation(tmp_path):
    hdr = {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
    path = _zip(tmp_path / "huge.npz", {"freq.npy": _npy(header=hdr, body=b"\0" * 64)})
    tracemalloc.start()
    try:
        _refused(path, r"huge\.npz.*claims shape")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20 * os.path.getsize(path) + (1 << 20)
    hdr = {"descr": "<f8", "fortran_order": False, "shape": (0, 10**15)}   # empty but absurd
    _refused(_zip(tmp_path / "wide.npz", {"freq.npy": _npy(header=hdr)}), "claims shape")


def test_zip_bomb_refused_unread(tmp_path):
    path = _zip(tmp_path / "bomb.npz", {"H.npy": _npy(np.zeros(4_000_000))},
                compress=zipfile.ZIP_DEFLATED)
    assert os.path.getsize(path) < 100_000
    tracemalloc.start()
    try:
        _refused(path, "more than 16 times its size")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20 * os.path.getsize(path) + (1 << 20)


class _Boom:
    triggered = False

    def __reduce__(self):
        return (_Boom._trigger, ())

    @staticmethod
    def _trigger():
        _Boom.triggered = True


def test_pickles_never_loaded(tmp_path):
    members, _ = _model_members(tmp_path)
    obj = np.array([_Boom()], dtype=object)
    path = _zip(tmp_path / "pickle.npz", {**members, "a0.npy": _npy(obj)})
    with pytest.raises(ValueError, match="holds Python objects"):
        sd.load(path)
    path = _zip(tmp_path / "pickle2.npz", {"freq.npy": _npy(obj), "H.npy": _npy(obj)})
    _refused(path, "holds Python objects")
    assert not _Boom.triggered


@pytest.mark.parametrize("fault, match", [
    ("not zip", "not a valid .npz archive"),
    ("empty", "not a valid .npz archive"),
    ("missing member", "missing array member 'a1'"),
    ("wrong dtype", "Omega has dtype complex128"),
    ("string dtype", "Omega has dtype <U3"),
    ("structured", "expected a plain"),
    ("not npy", "is not a .npy array"),
    ("duplicate", "duplicated member"),
    ("bad header", "bad .npy header"),
    ("short data", "holds 8 bytes"),
    ("no meta", "not an sdctrl archive"),
    ("meta not json", "not valid JSON"),
    ("meta wrong dtype", "must be 1-D uint8"),
    ("newer version", "format version 99"),
    ("unknown type", "unknown type 'Evil'"),
    ("unknown field", r"unknown field\(s\) \['evil'\]"),
    ("unknown tag", "unknown value kind 'eval'"),
    ("deep nesting", "nested too deeply|not valid JSON"),
    ("bad values", "stored NormalModeModel is invalid"),
])
def test_hostile_model_archives_refused(tmp_path, fault, match):
    members, meta = _model_members(tmp_path)
    fields = meta["root"]["object"][1]
    if fault == "not zip":
        members = None
        (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 this is not a zip" * 10)
    elif fault == "empty":
        members = None
        (tmp_path / "bad.npz").write_bytes(b"")
    elif fault == "missing member":
        del members["a1.npy"]
    elif fault == "wrong dtype":
        members["a0.npy"] = _npy(np.eye(2) + 0j)
    elif fault == "string dtype":
        members["a0.npy"] = _npy(np.array([["1.0", "0"], ["0", "1.0"]]))
    elif fault == "structured":
        members["a0.npy"] = _npy(np.zeros(2, dtype=[("a", "<f8"), ("b", "<i4")]))
    elif fault == "not npy":
        members["evil.py"] = b"import os"
    elif fault == "duplicate":
        members = list(members.items()) + [("a0.npy", _npy(np.eye(2)))]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")          # zipfile warns about the duplicate name
            with zipfile.ZipFile(tmp_path / "bad.npz", "w") as zf:
                for name, data in members:
                    zf.writestr(name, data)
        members = None
    elif fault == "bad header":
        members["a0.npy"] = b"\x93NUMPY\x01\x00\x10\x00{'descr': __import__('os')}\n"
    elif fault == "short data":
        members["a0.npy"] = _npy(header={"descr": "<f8", "fortran_order": False,
                                         "shape": (2, 2)}, body=b"\0" * 8)
    elif fault == "no meta":
        del members["__sdctrl__.npy"]
    elif fault == "meta not json":
        members["__sdctrl__.npy"] = _npy(np.frombuffer(b"{not json", np.uint8))
    elif fault == "meta wrong dtype":
        members["__sdctrl__.npy"] = _npy(np.array(["{}"]))
    elif fault == "newer version":
        members = _with_meta(members, {**meta, "version": 99})
    elif fault == "unknown type":
        members = _with_meta(members, {**meta, "root": {"object": ["Evil", fields]}})
    elif fault == "unknown field":
        bad = {**fields, "evil": 1}
        members = _with_meta(members, {**meta, "root": {"object": ["NormalModeModel", bad]}})
    elif fault == "unknown tag":
        bad = {**fields, "info": {"eval": "__import__('os').system('false')"}}
        members = _with_meta(members, {**meta, "root": {"object": ["NormalModeModel", bad]}})
    elif fault == "deep nesting":
        deep = 1
        for _ in range(200):
            deep = [deep]
        bad = {**fields, "info": {"dict": {"x": deep}}}
        members = _with_meta(members, {**meta, "root": {"object": ["NormalModeModel", bad]}})
    elif fault == "bad values":
        bad = {**fields, "omega_c": {"float": "-inf"}}
        members = _with_meta(members, {**meta, "root": {"object": ["NormalModeModel", bad]}})
    path = tmp_path / "bad.npz" if members is None else _zip(tmp_path / "bad.npz", members)
    with pytest.raises(ValueError, match=match) as err:
        sd.load(path)
    assert "bad.npz" in str(err.value)                          # the file is named


def _fe_archive(tmp_path, **changes):
    fe = sd.FEModel(sp.diags([1.0, 2.0, 3.0]).tocsr(), sp.diags([1.0, 1.0, 1.0]).tocsr())
    with zipfile.ZipFile(sd.save(fe, tmp_path / "fe")) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    meta = json.loads(np.load(io.BytesIO(members["__sdctrl__.npy"])).tobytes())
    M = meta["root"]["object"][1]["M"]["csr"]
    for key, value in changes.items():
        if key == "shape":
            M["shape"] = value
        else:
            members[f"{M[key]}.npy"] = _npy(value)
    return _zip(tmp_path / "bad.npz", _with_meta(members, meta))


@pytest.mark.parametrize("changes, match", [
    ({"indices": np.array([0, 1, 7], np.int32)}, "column index out of range"),
    ({"indptr": np.array([0, 2, 1, 3], np.int32)}, "inconsistent sparse"),
    ({"shape": [3, 10**15]}, "column index|symmetric|square"),
    ({"shape": [-1, 3]}, "malformed sparse shape"),
    ({"data": np.array([1.0, np.nan, 1.0])}, "finite"),
])
def test_hostile_sparse_matrices_refused(tmp_path, changes, match):
    with pytest.raises(ValueError, match=match):
        sd.load(_fe_archive(tmp_path, **changes))


def test_hostile_uncertain_parameters_refused(tmp_path):
    nm = sd.NormalModeModel(np.diag([4.0, 9.0]), np.diag([0.04, 0.06]), np.eye(2), np.ones((2, 1)))
    um = nm.uncertain(dOmega=np.diag([0.1, 0.2]))
    with zipfile.ZipFile(sd.save(um, tmp_path / "um")) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    meta = json.loads(np.load(io.BytesIO(members["__sdctrl__.npy"])).tobytes())
    params = meta["root"]["object"][1]["params"]
    params[0]["tuple"][1]["tuple"][1] = 5                         # index out of range
    with pytest.raises(ValueError, match="malformed uncertain parameter"):
        sd.load(_zip(tmp_path / "bad.npz", _with_meta(members, meta)))


def test_cli_info_prints_a_saved_model(tmp_path, capsys):
    from sdctrl.cli import main

    nm = sd.NormalModeModel(np.diag([4.0]), np.diag([0.04]), [[1.0]], [[1.0]])
    path = sd.save(nm, tmp_path / "m")
    assert main(["info", path]) == 0
    assert "NormalModeModel" in capsys.readouterr().out
    (tmp_path / "bad.npz").write_bytes(b"garbage")
    assert main(["info", str(tmp_path / "bad.npz")]) == 2
    assert "bad.npz" in capsys.readouterr().err


def test_fe_assembly_survives_save_load_and_apply_parameters(testbed_models, tmp_path):
    """The element record of an assembled model comes back (helpers build the same
    parameters) and is carried over by apply_parameters; a tampered record is refused."""
    from sdctrl.updating import apply_parameters

    fe = testbed_models["fe"]
    back = sd.load(sd.save(fe, tmp_path / "fe"))
    assert back.assembly is not None and not back.assembly.xyz.flags.writeable
    links, back_links = (m.stiffness_parameter("links", section=["post_AB", "post_C"])
                         for m in (fe, back))
    assert (links.dK != back_links.dK).nnz == 0
    plates = fe.mass_parameter("plates", ["N31", "N32"])
    assert (plates.dM != back.mass_parameter("plates", ["N31", "N32"]).dM).nnz == 0
    updated = apply_parameters(fe, [links], [0.5])
    assert updated.assembly is fe.assembly
    assert (updated.stiffness_parameter("links", section=["post_AB", "post_C"]).dK
            != links.dK).nnz == 0
    with zipfile.ZipFile(tmp_path / "fe.npz") as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    meta = json.loads(np.load(io.BytesIO(members["__sdctrl__.npy"])).tobytes())
    gidx = meta["root"]["object"][1]["assembly"]["object"][1]["gidx"]["array"]
    members[f"{gidx}.npy"] = _npy(np.full((len(fe.assembly.names), 6), 10**6))
    with pytest.raises(ValueError, match="gidx"):
        sd.load(_zip(tmp_path / "bad.npz", _with_meta(members, meta)))


def test_files_written_by_sdctrl_0_1_load_with_the_same_numbers():
    """Models saved by sdctrl 0.1 (flat layout; tests/data/legacy/make_legacy.py) load exactly."""
    ref = np.load(LEGACY / "reference.npz")
    cm = sd.load(LEGACY / "complex_modes.npz")
    assert isinstance(cm, sd.ComplexModeModel)
    assert np.array_equal(cm.poles, ref["cm_poles"]) and np.array_equal(cm.residues,
                                                                        ref["cm_residues"])
    nm = sd.load(LEGACY / "normal_modes.npz")
    assert type(nm) is sd.NormalModeModel
    assert np.array_equal(nm.Gamma, ref["nm_Gamma"]) and np.array_equal(nm.cphi, ref["nm_cphi"])
    hy = sd.load(LEGACY / "hybrid.npz")
    assert isinstance(hy, sd.HybridModel)
    assert np.array_equal(hy.Omega, ref["hy_Omega"])
    assert np.array_equal(hy.shapes[::9, :], ref["hy_shapes"])
    fe = sd.load(LEGACY / "fe.npz")
    assert isinstance(fe, sd.FEModel) and np.array_equal(fe.K.diagonal(), ref["fe_K_diag"])
    res = sd.load(LEGACY / "update_result.npz")
    assert isinstance(res, sd.UpdateResult)
    assert np.array_equal([res.values["links"], res.values["plates"], res.cost_after],
                          ref["res_values"])
    um = sd.load(LEGACY / "uncertain.npz")
    assert isinstance(um, sd.UncertainModel) and np.array_equal(um.dGamma, ref["um_dGamma"])
    ide = sd.load(LEGACY / "identifiability.npz")
    assert isinstance(ide, sd.Identifiability)
    assert np.array_equal(ide.correlation, ref["ide_corr"])
    # the loaded models still work
    f = np.linspace(14.0, 20.0, 7)
    assert np.all(np.isfinite(hy.frf(f).H)) and np.all(np.isfinite(cm.frf(f).H))


def test_typed_results_round_trip_and_files_of_sdctrl_0_1_fill_them(testbed_models, tmp_path):
    """The typed results of issue 21 (``properness``, ``search``, ``stabilisation``, a hybrid's
    ``kind``/``construction``, ``certified``) are saved and loaded exactly; files of sdctrl 0.1
    had them in ``info`` and load with them on the new fields, ``info`` keeping the rest."""
    cm, nm, hy = (testbed_models[k] for k in ("cm", "nm", "hybrid"))
    back = round_trip(cm, tmp_path, "cm")
    assert back.search.nfev == cm.search.nfev > 0 and back.search.converged is True
    assert len(back.stabilisation.poles) == back.stabilisation.orders.size > 2
    back = round_trip(nm, tmp_path, "nm")
    assert back.properness.pole_error == nm.properness.pole_error < 1e-6
    back = round_trip(hy, tmp_path, "hy")
    assert back.measured.sum() == back.construction.pairing.test_mode.size == nm.n
    r = RobustResult(1.5, 1.6, True, 3.0, np.zeros(1), np.ones(2), np.ones(2), {}, certified=True)
    assert round_trip(r, tmp_path, "r").certified is True
    # files of sdctrl 0.1 (tests/data/legacy/make_legacy.py): info entries on the new fields
    old = sd.load(LEGACY / "normal_modes.npz")
    p = old.properness
    assert set(old.info) == {"source"} and p.poles_used.tolist() == list(range(old.n))
    assert p.pole_error < 1e-12 and p.properness_after < 1e-12 < p.properness_before < 1e-2
    assert p.positive_definite == {"mass": True, "stiffness": True, "damping": True}
    assert p.in_band.tolist() == [False, True, True, True, True] and p.band[0] < p.band[1]
    old = sd.load(LEGACY / "complex_modes.npz")
    assert (old.search.nfev, old.search.compress_rank, old.warnings) == (63, 44, ())
    assert old.search.converged and set(old.info) == {"log"}
    assert len(old.stabilisation.poles) == old.stabilisation.orders.size == 7
    old = sd.load(LEGACY / "hybrid.npz")
    pairing = old.construction.pairing
    assert old.kind.size == old.n and old.measured.sum() == pairing.test_mode.size == 5
    assert pairing.mac.min() > 0.98 and pairing.poor.size == 0 and old.n_static == 0
    assert old.construction.residual.variant == "fe frequencies, mass+E"
    assert set(old.info) == {"source"}
    old = sd.load(LEGACY / "update_result.npz")
    assert old.test_modes == "given normal modes" and "from the data" in old.damping
    assert "damping" not in old.info and "test_modes" not in old.info
    assert sd.load(LEGACY / "uncertain.npz").model.properness.pole_error < 1e-12
