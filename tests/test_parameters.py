"""Design parameters (4.15): validation, and the FE model's helpers that build them from its own
element groups and nodes."""

import numpy as np
import pytest
import scipy.sparse as sp

import sdctrl as sd
from sdctrl.fe import assemble
from sdctrl.fe._parameters import load_shapes

PLATES = [f"N{k}" for k in (31, 32, 33, 34, 35, 38, 39, 40, 41, 42, 45, 46, 47, 48, 49)]


@pytest.fixture(scope="module")
def fe():
    return sd.testbed()


def test_stiffness_parameter_is_the_group_stiffness(fe):
    """A 30% stiffer link group is exactly K + 0.3 dK (same element matrices as assembly)."""
    links = fe.stiffness_parameter("links", section=["post_AB", "post_C"])
    stiff = sd.testbed(link_stiffness=1.3)
    assert abs(stiff.K - (fe.K + 0.3 * links.dK)).max() < 1e-9 * abs(fe.K).max()
    assert abs(stiff.M - fe.M).max() == 0
    assert links.dM is None and links.dK.nnz > 0
    assert len(fe.members(section=["post_AB", "post_C"])) == 6
    # selection by node pairs (either order) gives the same matrix as by section
    pairs = [(b, a) for a, b in fe.members(section=["post_AB", "post_C"])]
    by_pair = fe.stiffness_parameter("links", elements=pairs)
    assert abs(by_pair.dK - links.dK).max() == 0
    # all members plus the 12 suspension springs of 800 N/m are the whole stiffness
    K, M = fe.member_matrices(kind=["bar", "beam"])
    spring = fe.K - K
    assert spring.diagonal().sum() == pytest.approx(12 * 800.0)
    assert np.all(M.diagonal() >= 0) and M.sum() < fe.M.sum()


def test_mass_parameter_scales_lumped_masses_or_adds_mass(fe):
    plates = fe.mass_parameter("plates", PLATES)
    heavy = sd.testbed(plate_mass=1.25)
    assert abs(heavy.M - (fe.M + 0.25 * plates.dM)).max() < 1e-12
    # translational lumped mass: 6 + 6 + 3 kg, three directions
    trans = [i for i, d in enumerate(fe.dofs) if d.rsplit(".", 1)[1] in "xyz"]
    assert plates.dM.diagonal()[trans].sum() == pytest.approx(3 * 15.0)
    no_rot = fe.mass_parameter("plates", PLATES, rotational=False)
    assert no_rot.dM.diagonal().sum() == pytest.approx(45.0)
    # an added mass of 0.5 kg spread over 4 corners, plus a rotary inertia on one node
    edge = fe.mass_parameter("edge", ["N32", "N33", "N34", "N35"], mass=0.5)
    d = edge.dM.diagonal()
    assert d.sum() == pytest.approx(1.5)
    assert d[fe.dof_index("N32.z")[0]] == pytest.approx(0.125)
    mirror = fe.mass_parameter("mirror", "N31", mass=0.5, inertia=(0.01, 0.02, 0.03))
    assert mirror.dM[fe.dof_index("N31.ry")[0], fe.dof_index("N31.ry")[0]] == pytest.approx(0.02)
    assert "0.5 kg over 1 nodes" in mirror.description


def test_helpers_reject_bad_selections(fe):
    with pytest.raises(ValueError, match="unknown"):
        fe.stiffness_parameter("x", section="nope")
    with pytest.raises(ValueError, match="no member"):
        fe.stiffness_parameter("x", elements=[("N1", "N49")])
    with pytest.raises(ValueError, match="unknown node"):
        fe.stiffness_parameter("x", elements=[("N1", "Q")])
    with pytest.raises(ValueError, match="no lumped mass"):
        fe.mass_parameter("x", ["N1"])
    with pytest.raises(ValueError, match="mass"):
        fe.mass_parameter("x", ["N1"], mass=-1.0)
    with pytest.raises(ValueError, match="no DOF N1.rx"):
        fe.mass_parameter("x", ["N1"], mass=1.0, inertia=(1.0, 0.0, 0.0))
    bare = sd.FEModel(fe.M, fe.K, dofs=fe.dofs)
    with pytest.raises(ValueError, match="no element records"):
        bare.stiffness_parameter("x", section="spider")
    assert bare.mass_parameter("x", ["N1"], mass=1.0).dM.sum() == pytest.approx(3.0)


def test_parameter_validation():
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    p = sd.Parameter("k", dK=K)
    assert p.N == 2 and p.bounds == (-0.9, 9.0) and p.standard_change == 1.0
    assert not p.dK.flags.writeable and K.flags.writeable
    assert sd.Parameter("k", dK=K, bounds=(-0.5, 0.2)).standard_change == 0.2
    assert sd.Parameter("k", dK=K, bounds=(-0.5, 0.0)).standard_change == -0.5
    assert sd.Parameter("k", dK=K, scale=0.3).standard_change == 0.3
    # scale is the size of the change; its direction follows the bounds
    assert sd.Parameter("k", dK=K, scale=0.3, bounds=(-0.5, 0.0)).standard_change == -0.3
    with pytest.raises(ValueError, match="scale must be a positive"):
        sd.Parameter("k", dK=K, scale=-0.3)
    with pytest.raises(TypeError, match="description must be a string"):
        sd.Parameter("k", dK=K, description=["links"])
    assert sd.Parameter("k", dK=K, description=None).description == ""
    with pytest.raises(ValueError, match="symmetric"):
        sd.Parameter("k", dK=[[1.0, 2.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="square"):
        sd.Parameter("k", dM=np.ones((2, 3)))
    with pytest.raises(ValueError, match="must contain 0"):
        sd.Parameter("k", dK=K, bounds=(0.1, 2.0))
    with pytest.raises(ValueError, match="lo < hi"):
        sd.Parameter("k", dK=K, bounds=(1.0, -1.0))
    with pytest.raises(ValueError, match="at least one"):
        sd.Parameter("k")
    with pytest.raises(ValueError, match=r"dK must have shape \(3, 3\) like the other"):
        sd.Parameter("k", dK=K, dM=np.eye(3))
    with pytest.raises(TypeError, match="name"):
        sd.Parameter(3, dK=K)
    with pytest.raises(ValueError, match="finite"):
        sd.Parameter("k", dK=[[np.nan, 0.0], [0.0, 1.0]])
    assert "Parameter('k', dK, N=2" in repr(p)


def test_load_shapes_factorise_the_change():
    rng = np.random.default_rng(0)
    N = 40
    A = rng.standard_normal((N, 3))
    X = A @ np.diag([2.0, -1.0, 0.5]) @ A.T              # rank 3, indefinite
    X[:, 30:] = 0
    X[30:, :] = 0
    F = load_shapes(sp.csr_matrix(X))
    assert F.shape == (N, 3)
    d = np.linalg.eigvalsh(X[:30, :30])
    sign = np.sign(d[np.argsort(-np.abs(d))][:3])
    assert np.allclose(F @ np.diag(sign) @ F.T, X, atol=1e-10)
    assert np.allclose(load_shapes(X), F) or np.allclose(np.abs(load_shapes(X)), np.abs(F))


def test_assembly_record_survives_a_small_model():
    fe = assemble({"A": (0, 0, 0), "B": (1, 0, 0), "C": (2, 0, 0)},
                  [("bar", "A", "B", "al", "rod"), ("bar", "B", "C", "al", "rod"),
                   ("mass", "C", 2.0)],
                  {"al": {"E": 70e9, "rho": 2700}}, {"rod": {"A": 1e-4}}, bc=["A"])
    p = fe.stiffness_parameter("BC", elements=[("B", "C")])
    k = 70e9 * 1e-4
    i, j = fe.dof_index(["B.x", "C.x"])
    assert p.dK[i, i] == pytest.approx(k) and p.dK[i, j] == pytest.approx(-k)
    assert fe.mass_parameter("m", ["C"]).dM.sum() == pytest.approx(6.0)
    assert "2 members" in repr(fe.assembly)
