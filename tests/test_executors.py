"""Users' sweeps in other processes (issue 27): identify, update and diagnose run in a
``ProcessPoolExecutor`` and on a ``distributed.LocalCluster`` of two worker processes and give
the serial run's results bit for bit; the sweeps that take an ``executor`` (placement_study,
frf_envelope, diagnose's candidate scan) give the serial result on both.

One pool and one cluster serve the whole module (each costs seconds to start).  Their workers
are fresh interpreters (spawned), which import sdctrl from this checkout (``PYTHONPATH``) and
receive every model, result and FRF by pickle.
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import importlib.util
import multiprocessing
import os
import pathlib

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.testbeds import SENSORS, SHAKERS
from test_pickle import same as _same

distributed = pytest.importorskip("distributed")

ROOT = pathlib.Path(sd.__file__).resolve().parent.parent
LINKS = ["post_AB", "post_C"]
#: wall-clock entries of diagnostics (``info``): the only difference between two runs
CLOCKS = ("time", "step_times", "seconds")
#: a diagnosis of the small case (a public function, pickled by reference)
DIAGNOSE = functools.partial(sd.diagnose, max_effects=1, progress=False)


def same(a, b, where):
    _same(a, b, where, skip=CLOCKS)


@pytest.fixture(scope="module")
def pools():
    """``{"process": ProcessPoolExecutor, "dask": a LocalCluster client's executor}``."""
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + ([old] if old else []))
    try:
        with cf.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool, \
                distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                         dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            yield {"process": pool, "dask": client.get_executor(), "client": client}
    finally:
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old


@pytest.fixture(params=["process", "dask"])
def executor(request, pools):
    return pools[request.param]


def test_workers_run_this_checkout(pools):
    here = sd.__file__
    assert pools["process"].submit(importlib.util.find_spec, "sdctrl").result().origin == here
    assert pools["dask"].submit(importlib.util.find_spec, "sdctrl").result().origin == here


# ----------------------------------------------------------------------------------------
# small cases, computed once serially
# ----------------------------------------------------------------------------------------
@functools.cache
def four_tests():
    return [sd.testbed_frf(n=200, noise=0.01, seed=seed).band(8, 30) for seed in range(4)]


@functools.cache
def update_case():
    wrong = sd.testbed(link_stiffness=0.5)
    return wrong, sd.testbed_frf(n=120), [wrong.stiffness_parameter("links", section=LINKS)]


@functools.cache
def diagnose_case():
    """The testbed's FE-derived model, data of the testbed with 0.5 kg added at N20."""
    fe = sd.testbed()
    model = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 20, static=True,
                                 static_damping="projected")
    dM = fe.mass_parameter("m", "N20", mass=0.5).dM
    changed = sd.FEModel(fe.M + dM, fe.K, fe.C, dofs=fe.dofs, nodes=dict(fe.nodes),
                         elements=fe.elements, assembly=fe.assembly)
    data = changed.normal_mode_model(list(SHAKERS), list(SENSORS), 20, static=True,
                                     static_damping="projected")
    return model, data.frf(np.linspace(8.0, 40.0, 60), "acceleration"), fe


@functools.cache
def serial(what):
    if what == "identify":
        return [sd.identify(f) for f in four_tests()]
    if what == "update":
        return sd.update(*update_case(), progress=False)
    if what == "diagnose":
        return DIAGNOSE(*diagnose_case())
    raise ValueError(what)


# ----------------------------------------------------------------------------------------
# the whole call in another process
# ----------------------------------------------------------------------------------------
def test_identify_four_tests(executor):
    got = list(executor.map(sd.identify, four_tests()))
    ref = serial("identify")
    assert len(got) == 4 and len({m.poles.size for m in ref}) >= 1
    for k, (a, b) in enumerate(zip(ref, got)):
        same(a, b, f"identify[{k}]")
    # the four noise draws give four different models (the comparison is not trivial)
    assert not np.array_equal(ref[0].poles, ref[1].poles)


def test_update(executor):
    got = executor.submit(sd.update, *update_case(), progress=False).result()
    ref = serial("update")
    assert ref.values["links"] == pytest.approx(1.0, abs=0.01)     # 50% too soft: p = 1
    same(ref, got, "update")


def test_diagnose(executor):
    got = executor.submit(DIAGNOSE, *diagnose_case()).result()
    ref = serial("diagnose")
    top = ref.effects[0]
    assert (top.kind, top.location) == ("mass_change", "N20")
    assert top.parameters["dm"] == pytest.approx(0.5, rel=0.02)
    same(ref, got, "diagnose")


# ----------------------------------------------------------------------------------------
# sweeps given the executor
# ----------------------------------------------------------------------------------------
def test_diagnose_scan_on_the_executor(executor):
    got = DIAGNOSE(*diagnose_case(), executor=executor)
    same(serial("diagnose"), got, "diagnose")


def test_placement_study(executor):
    fe = sd.testbed()
    model = fe.normal_mode_model(list(SHAKERS), list(SENSORS), 24)
    bars = list(fe.elements[:60]) + [("N1", "N99")]          # one unknown node: skipped
    kw = {"candidates": bars, "outputs": list(SENSORS[:6]), "progress": False}
    ref = sd.placement_study(model, fe, (8, 60), 4e4, **kw)
    got = sd.placement_study(model, fe, (8, 60), 4e4, executor=executor, **kw)
    assert len(ref.candidates) == 60 and len(ref.skipped) == 1
    scores = [c.score for c in ref.candidates]
    assert scores == sorted(scores, reverse=True) and scores[0] > 0
    same(ref, got, "placement")


def test_frf_envelope(executor):
    nm = sd.testbed().normal_mode_model(list(SHAKERS[:2]), list(SENSORS[:3]), 8)
    um = nm.uncertain(dGamma=0.3 * np.abs(np.diag(np.diag(nm.Gamma))),
                      dOmega=0.02 * np.diag(np.diag(nm.Omega)))
    f = np.linspace(5, 60, 80)
    ref = um.frf_envelope(f, n_samples=120, seed=4, max_vertices=64)
    got = um.frf_envelope(f, n_samples=120, seed=4, max_vertices=64, executor=executor)
    same(ref, got, "envelope")
    # the band holds the nominal and is not empty
    assert np.all(ref["mag_min"] <= np.abs(ref["nominal"]))
    assert np.all(np.abs(ref["nominal"]) <= ref["mag_max"])
    assert np.max(ref["mag_max"] / ref["mag_min"]) > 1.2
