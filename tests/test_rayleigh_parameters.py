"""Parameters that carry the model's Rayleigh damping law (``FEModel.stiffness_parameter``,
``FEModel.mass_parameter``, ``Parameter.rayleigh``): a model assembled with
``C = alpha M + beta K + dashpots`` keeps that law when its members or masses change.

Measured: the family's ladder, noise-free, updated with ``C`` fixed ended with its rungs
4.5e-4 off (20x its floor); with the law carried (and the true ``C`` reached at the true
parameters, below) 2e-11 (``tests/test_family_update.py``).
"""

import os
import tempfile
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.fe import assemble


def _dense(X):
    return X.toarray() if sp.issparse(X) else np.asarray(X)


@pytest.mark.parametrize("name", ["ladder", "plate", "cluster", "truss"])
def test_the_true_damping_is_reached_at_the_true_parameters(name):
    st = sd.testbeds.structure(name)
    wrong, true = st.wrong(), st.fe()
    pars = st.parameters()
    C = _dense(wrong.C) + sum(v * _dense(par.matrices()[1]) for par, v in
                             zip(pars, st.truth.values()))
    assert np.abs(C - _dense(true.C)).max() <= 1e-12 * np.abs(_dense(true.C)).max()
    fixed = [wrong.stiffness_parameter("k", section=next(iter(wrong.assembly.sections)),
                                       rayleigh=False)]
    assert fixed[0].matrices()[1] is None and fixed[0].rayleigh == (0.0, 0.0)


def test_law_follows_the_assembly_and_the_keyword():
    nodes = {"A": (0, 0, 0), "B": (1, 0, 0), "C": (2, 0, 0)}
    els = [("bar", "A", "B", "al", "rod"), ("bar", "B", "C", "al", "rod"),
           ("mass", "C", 2.0)]
    mat, sec = {"al": {"E": 70e9, "rho": 2700}}, {"rod": {"A": 1e-4}}
    fe = assemble(nodes, els, mat, sec, bc=["A"], rayleigh=(0.3, 2e-5))
    assert fe.assembly.rayleigh == (0.3, 2e-5)
    k = fe.stiffness_parameter("rod", section="rod")
    m = fe.mass_parameter("tip", "C")
    added = fe.mass_parameter("extra", "C", mass=1.0)
    assert k.rayleigh == (0.0, 2e-5) and m.rayleigh == (0.3, 0.0)
    assert added.rayleigh == (0.0, 0.0) and added.matrices()[1] is None
    np.testing.assert_allclose(_dense(k.matrices()[1]), 2e-5 * _dense(k.dK), rtol=1e-15)
    np.testing.assert_allclose(_dense(m.matrices()[1]), 0.3 * _dense(m.dM), rtol=1e-15)
    assert k.matrices(law=False)[1] is None and k.dC is None
    bare = assemble(nodes, els, mat, sec, bc=["A"])
    assert bare.assembly.rayleigh == (0.0, 0.0)
    assert bare.stiffness_parameter("rod", section="rod").matrices()[1] is None


def test_bad_laws_are_refused():
    nodes = {"A": (0, 0, 0), "B": (1, 0, 0)}
    args = ({"al": {"E": 70e9, "rho": 2700}}, {"rod": {"A": 1e-4}})
    els = [("bar", "A", "B", "al", "rod")]
    with pytest.raises(ValueError, match="rayleigh"):
        assemble(nodes, els, *args, bc=["A"], rayleigh=(0.1,))
    with pytest.raises(ValueError, match="rayleigh"):
        assemble(nodes, els, *args, bc=["A"], rayleigh=(0.1, -1e-5))
    with pytest.raises(TypeError, match="rayleigh"):
        assemble(nodes, els, *args, bc=["A"], rayleigh=("a", "b"))
    fe = assemble(nodes, els, *args, bc=["A"], rayleigh=(0.1, 1e-5))
    with pytest.raises(TypeError, match="rayleigh"):
        fe.stiffness_parameter("rod", section="rod", rayleigh=1)
    with pytest.raises(ValueError, match="rayleigh"):
        sd.Parameter("k", dK=np.eye(3), rayleigh=(np.inf, 0.0))


def test_the_law_is_stored():
    st = sd.testbeds.structure("ladder")
    fe, par = st.wrong(), st.parameters()[0]
    with tempfile.TemporaryDirectory() as tmp:
        sd.save(fe, os.path.join(tmp, "fe.npz"))
        sd.save(par, os.path.join(tmp, "par.npz"))
        assert sd.load(os.path.join(tmp, "fe.npz")).assembly.rayleigh == (0.05, 2e-5)
        back = sd.load(os.path.join(tmp, "par.npz"))
    assert back.rayleigh == (0.0, 2e-5)
    np.testing.assert_array_equal(_dense(back.matrices()[1]), _dense(par.matrices()[1]))


def test_modal_damping_replaces_the_law():
    """A given damping ratio holds on every mode of the updated model: the parameters' law
    is the model's own ``C``'s, which a modal damping model replaces."""
    st = sd.testbeds.structure("plate")
    frf = st.frf(n=200, noise=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = sd.update(st.wrong(), frf, st.parameters(), damping=0.02, progress=False)
    G, w = r.model.Gamma, np.sqrt(np.diag(r.model.Omega))
    np.testing.assert_allclose(np.diag(G), 0.04 * w, rtol=1e-8)
