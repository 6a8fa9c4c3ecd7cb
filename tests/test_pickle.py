"""Every public model and result pickles to an equal object (issue 27).

A test walks every class exported by ``sd.__all__`` and by the packages' ``__all__``, builds a
real instance of it (from the built-in testbed and small closed-form models), pickles and
unpickles it, and compares the two field by field: same arrays (bit for bit, same dtype and
read-only flag), same labels, same nested objects.  Results computed after unpickling equal
those before (FE modes, static corrections, a hybrid model's closed-loop FRF).
"""

from __future__ import annotations

import copy
import functools
import importlib
import inspect
import math
import pickle
import warnings
from types import MappingProxyType

import control
import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl._lib.frozen import FrozenState, attribute_names
from sdctrl.testbeds import SENSORS, SHAKERS

PACKAGES = ["sdctrl", "sdctrl.data", "sdctrl.identification", "sdctrl.modal", "sdctrl.fe",
            "sdctrl.updating", "sdctrl.hybrids", "sdctrl.robust", "sdctrl.robust.mu",
            "sdctrl.closedloop", "sdctrl.testbeds", "sdctrl.diagnosis", "sdctrl.storage",
            "sdctrl.report"]
LINKS = ["post_AB", "post_C"]


def _public_classes():
    out = {}
    for pkg in PACKAGES:
        mod = importlib.import_module(pkg)
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isclass(obj):
                out[obj.__name__] = obj
    return out


CLASSES = _public_classes()


# ----------------------------------------------------------------------------------------
# field-by-field equality
# ----------------------------------------------------------------------------------------
def same(a, b, path="obj", skip=()):
    """Assert that ``b`` equals ``a`` exactly, recursively (arrays bit for bit); dict entries
    named in ``skip`` (wall-clock times of two runs) are not compared."""
    assert type(a) is type(b), f"{path}: {type(a).__name__} vs {type(b).__name__}"
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, path
        ro_a, ro_b = not a.flags.writeable, not b.flags.writeable
        assert ro_a == ro_b, f"{path}: read-only {ro_a} before pickling, {ro_b} after"
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), path
    elif sp.issparse(a):
        assert a.format == b.format and a.dtype == b.dtype and a.shape == b.shape, path
        assert (a != b).nnz == 0, path
    elif isinstance(a, dict | MappingProxyType):
        assert list(a) == list(b), f"{path}: keys {list(a)} vs {list(b)}"
        for k in a:
            if k not in skip:
                same(a[k], b[k], f"{path}[{k!r}]", skip)
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]", skip)
    elif isinstance(a, float | np.floating):
        assert a == b or (math.isnan(a) and math.isnan(b)), f"{path}: {a} vs {b}"
    elif isinstance(a, control.StateSpace):
        for m in "ABCD":
            same(getattr(a, m), getattr(b, m), f"{path}.{m}", skip)
        assert a.input_labels == b.input_labels and a.output_labels == b.output_labels, path
    elif inspect.isfunction(a) or inspect.isclass(a):
        assert a is b, path
    elif isinstance(a, BaseException):
        assert a.args == b.args, path
    elif type(a).__module__.startswith("sdctrl"):
        transient = getattr(a, "_transient", ())
        names = attribute_names(a)
        assert names == attribute_names(b), path
        for n in names:
            if n not in transient and hasattr(a, n):
                same(getattr(a, n), getattr(b, n), f"{path}.{n}", skip)
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


def round_trip(obj):
    back = pickle.loads(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))
    same(obj, back, type(obj).__name__)
    return back


# ----------------------------------------------------------------------------------------
# real instances (small, cached)
# ----------------------------------------------------------------------------------------
@functools.cache
def fe():
    return sd.testbed()


@functools.cache
def wrong():
    return sd.testbed(link_stiffness=0.5)


@functools.cache
def frf():
    return sd.testbed_frf(n=120, noise=0.01, seed=3)


@functools.cache
def identified():
    return sd.identify(frf().band(8, 30))


@functools.cache
def normal():
    cm = identified()
    return sd.normal_modes(cm, list(zip(frf().sensors[:6], frf().actuators)))


@functools.cache
def fe_normal():
    return fe().normal_mode_model(list(SHAKERS), list(SENSORS), 12)


@functools.cache
def hybrid():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.hybrid(wrong(), fe_normal(), list(SENSORS), list(SHAKERS))


@functools.cache
def params():
    w = wrong()
    return (w.stiffness_parameter("links", section=LINKS),
            w.mass_parameter("plates", [f"N{k}" for k in (31, 32, 33, 34, 35)]))


def two_mode():
    return sd.NormalModeModel(Omega=np.diag([1.0, 1.21]), Gamma=np.diag([0.04, 0.022]),
                              cphi=np.array([[1.0, 1], [2, -1]]), phib=np.array([[1.0], [1]]),
                              sensors=["s1", "s2"], actuators=["a"])


@functools.cache
def uncertain():
    return two_mode().uncertain(dGamma=0.3 * two_mode().Gamma, dOmega=[[0.05, 0], [0, 0.02]])


@functools.cache
def identifiability():
    return sd.identifiability(wrong(), frf(), list(params()))


@functools.cache
def update():
    return sd.update(wrong(), sd.testbed_frf(n=120), list(params()), progress=False)


@functools.cache
def diagnosis():
    model = fe().normal_mode_model(list(SHAKERS), list(SENSORS), 28, static=True,
                                   static_damping="projected")
    f = np.linspace(8.0, 60.0, 150)
    dM = fe().mass_parameter("m", "N20", mass=0.5).dM
    changed = sd.FEModel(fe().M + dM, fe().K, fe().C, dofs=fe().dofs, nodes=dict(fe().nodes),
                         elements=fe().elements, assembly=fe().assembly)
    B = np.hstack([changed.point(list(SHAKERS)), changed.point([f"N20.{a}" for a in "xyz"])])
    data = changed.normal_mode_model(B, list(SENSORS), 28, static=True,
                                     static_damping="projected",
                                     actuators=list(SHAKERS) + ["e1", "e2", "e3"])
    data = data.frf(f, "acceleration").select(actuators=list(SHAKERS))
    return sd.diagnose(model, data, fe(), max_effects=1, progress=False)


def _instance(name):
    from sdctrl.diagnosis import DelayedModel
    from sdctrl.report import Check, Document
    from sdctrl.robust import multi_test_statistics
    from sdctrl.robust.mu import BlockStructure
    from sdctrl.storage import registered
    from sdctrl.storage._registry import CODECS
    from sdctrl.updating import reanalysis_errors, reduced_basis, reduced_model

    def basis():
        return reduced_basis(wrong(), list(params()), inputs=wrong().point(list(SHAKERS)),
                             n_modes=12)

    def document():
        doc = Document("pickled", "a report")
        doc.section("id", "Identification").paragraph("12 modes").key_numbers(
            [Check("modes", 12, 12)])
        return doc

    def multi():
        m = two_mode()
        return multi_test_statistics([m, m.replace(Omega=m.Omega * 1.01),
                                      m.replace(Gamma=m.Gamma * 0.9)])

    makers = {
        "FRF": frf, "ComplexModeModel": identified, "NormalModeModel": normal,
        "FEModel": fe, "Assembly": lambda: fe().assembly, "Parameter": lambda: params()[0],
        "HybridModel": hybrid, "UncertainModel": uncertain,
        "RobustResult": lambda: sd.robust_stability(uncertain(),
                                                    control.ss([], [], [], [[0.5, 0.2]])),
        "MultiTestResult": multi,
        "BlockStructure": lambda: BlockStructure((1, 2), ("real", "complex")),
        "Identifiability": identifiability,
        "CostMap": lambda: identifiability().cost_map("links", "plates", n=3, progress=False),
        "UpdateResult": update,
        "ReducedBasis": basis,
        "ReducedModel": lambda: reduced_model(basis(), list(params()), wrong().point(
            list(SENSORS)).T, wrong().point(list(SHAKERS))),
        "ReanalysisErrors": lambda: reanalysis_errors(wrong(), params()[0], [0.5], n_modes=10,
                                                      progress=False),
        "PlacementStudy": lambda: sd.placement_study(
            fe_normal(), fe(), (8, 60), kv=4e4, candidates=list(fe().elements[:4]),
            progress=False),
        "Diagnosis": diagnosis, "Effect": lambda: diagnosis().effects[0],
        "DelayedModel": lambda: DelayedModel(fe_normal(), 1e-3, 100.0),
        "Codec": lambda: CODECS[registered()[0]],
        "Check": lambda: Check("frequency", 10.01, 10.0, tolerance=0.01, unit=" Hz"),
        "Document": document, "Section": lambda: document().sections[0],
        "IdentificationWarning": lambda: CLASSES["IdentificationWarning"]("poles moved"),
        "StorageWarning": lambda: CLASSES["StorageWarning"]("old file"),
        "Survey": lambda: sd.testbeds.survey("plate", noise=0.01, seed=1, lines=200,
                                             averages=1),
        "ImpactWarning": lambda: CLASSES["ImpactWarning"]("double hit in hit 2"),
        "TestStructure": lambda: sd.testbeds.structure("plate"),
        "ResidualDynamics": lambda: normal().residual or CLASSES["ResidualDynamics"](
            identified().poles[:2], identified().residues[:2], identified().sensors,
            identified().actuators, ("out of band", "Riccati"), np.array([0, 1])),
    }
    return makers[name]()


@pytest.mark.parametrize("name", sorted(CLASSES))
def test_every_public_class_round_trips(name):
    obj = _instance(name)
    assert isinstance(obj, CLASSES[name])
    back = round_trip(obj)
    if isinstance(obj, FrozenState) and not isinstance(obj, Exception):
        field = attribute_names(obj)[0]
        with pytest.raises(AttributeError):
            setattr(back, field, None)              # still immutable
    same(obj, copy.deepcopy(obj), name)             # deepcopy takes the same path


def test_the_walk_covers_the_public_models_and_results():
    assert {"FRF", "FEModel", "HybridModel", "ComplexModeModel", "NormalModeModel",
            "UncertainModel", "UpdateResult", "Identifiability", "RobustResult", "Diagnosis",
            "Effect", "PlacementStudy", "Parameter"} <= set(CLASSES)


def test_fe_model_drops_its_factorisations_and_rebuilds_them():
    model = fe()
    f0, phi0 = model.modes(5)
    b = model.point(list(SHAKERS))
    s0 = model.static_correction(b, phi0)
    assert model._cache                               # factorisations cached (SuperLU)
    back = round_trip(model)
    assert back._cache == {}
    f1, phi1 = back.modes(5)
    np.testing.assert_array_equal(f1, f0)
    np.testing.assert_array_equal(np.abs(phi1), np.abs(phi0))
    np.testing.assert_array_equal(back.static_correction(b, phi0), s0)
    assert back.nodes == model.nodes and isinstance(back.nodes, MappingProxyType)
    assert back.dof_index(["N30.z"])[0] == model.dof_index(["N30.z"])[0]
    assert model._cache                               # the original keeps its own


def test_hybrid_feedback_after_unpickling():
    h = hybrid()
    s = wrong().strut("N12", "N16")
    f = np.linspace(8, 60, 40)
    before = h.with_feedback(s, s.T, kv=4e4).frf(f)
    back = round_trip(h)
    after = back.with_feedback(s, s.T, kv=4e4).frf(f)
    np.testing.assert_array_equal(after.H, before.H)
    assert after.sensors == before.sensors and after.actuators == before.actuators


def test_frf_and_model_results_after_unpickling():
    back = round_trip(frf())
    np.testing.assert_array_equal(back.band(10, 20).H, frf().band(10, 20).H)
    with pytest.raises(AttributeError, match="immutable"):
        back.H = None
    with pytest.raises(ValueError):
        back.H[0, 0, 0] = 1.0                         # read-only again
    cm = round_trip(identified())
    np.testing.assert_array_equal(cm.frf(frf().freq).H, identified().frf(frf().freq).H)
    um = round_trip(uncertain())
    P, blocks = um.lft()
    P0, blocks0 = uncertain().lft()
    same(P0, P, "lft")
    assert blocks == blocks0
