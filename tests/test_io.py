"""UFF dataset 58 and npz I/O: exact round trips, labels, units, clear errors."""

import numpy as np
import pytest

import sdctrl as sd


def _frf(seed=0, coherence=True, quantity="acceleration"):
    rng = np.random.default_rng(seed)
    f = np.sort(rng.uniform(1.0, 200.0, 64))           # an uneven axis on purpose
    H = rng.standard_normal((64, 4, 2)) + 1j * rng.standard_normal((64, 4, 2))
    coh = rng.uniform(0.2, 1.0, H.shape) if coherence else None
    return sd.FRF(f, H * 10.0 ** rng.uniform(-6, 3, H.shape), quantity=quantity,
                  sensors=["N1.x", "N7.y", "N12.z", "N3.rz"], actuators=["N1.x", "N12.z"],
                  collocated=[(0, 0), (2, 1)], coherence=coh, units="m/s^2/N")


@pytest.mark.parametrize("quantity", ["displacement", "velocity", "acceleration"])
def test_uff_round_trip_exact(tmp_path, quantity):
    frf = _frf(quantity=quantity)
    path = tmp_path / "test.uff"
    sd.write_uff(frf, path)
    back = sd.read_uff(path)
    assert np.array_equal(back.freq, frf.freq)
    assert np.array_equal(back.H, frf.H)                       # bit-exact complex doubles
    assert np.array_equal(back.coherence, frf.coherence)
    assert back.sensors == frf.sensors and back.actuators == frf.actuators
    assert back.quantity == quantity
    assert back.units == "m/s^2/N"
    assert back.collocated == ((0, 0), (2, 1))                 # same node and direction


def test_uff_node_direction_recorded(tmp_path):
    import pyuff

    frf = _frf(coherence=False)
    path = tmp_path / "dirs.uff"
    sd.write_uff(frf, path)
    sets = pyuff.UFF(str(path)).read_sets()
    got = {(d["rsp_node"], d["rsp_dir"], d["ref_node"], d["ref_dir"]) for d in sets}
    assert (7, 2, 12, 3) in got and (3, 6, 1, 1) in got        # N7.y / N12.z, N3.rz / N1.x
    assert all(d["func_type"] == 4 and d["ordinate_spec_data_type"] == 12 for d in sets)
    # a foreign file without sdctrl's ID line: labels rebuilt from node/direction
    for d in sets:
        d["id2"] = "NONE"
    other = tmp_path / "foreign.uff"
    pyuff.UFF(str(other)).write_sets(sets, "add")
    back = sd.read_uff(other)
    assert back.sensors == frf.sensors and back.actuators == frf.actuators
    assert np.array_equal(back.H, frf.H)


def test_uff_ascii_round_trip(tmp_path):
    frf = _frf(coherence=False)
    even = sd.FRF(np.linspace(0.125, 64.0, 64 * 8), np.repeat(frf.H, 8, axis=0),
                  frf.quantity, frf.sensors, frf.actuators)
    path = tmp_path / "ascii.uff"
    sd.write_uff(even, path, binary=False)
    back = sd.read_uff(path)
    assert np.allclose(back.H, even.H, rtol=1e-9)              # ASCII keeps ~11 digits
    assert np.allclose(back.freq, even.freq, rtol=1e-9)        # even axis: min + k * inc
    with pytest.warns(UserWarning, match="single precision"):
        sd.write_uff(frf, tmp_path / "uneven.uff", binary=False)
    back = sd.read_uff(tmp_path / "uneven.uff")
    assert np.allclose(back.freq, frf.freq, rtol=1e-5)


def test_uff_free_labels_survive(tmp_path):
    f = np.linspace(1, 10, 10)
    frf = sd.FRF(f, np.ones((10, 2, 1)) * (1 + 2j), sensors=["tip accel", "root"],
                 actuators=["shaker A"])
    sd.write_uff(frf, tmp_path / "free.uff")
    back = sd.read_uff(tmp_path / "free.uff")
    assert back.sensors == ("tip accel", "root") and back.actuators == ("shaker A",)


def test_uff_no_dataset_58(tmp_path):
    import pyuff

    path = tmp_path / "nodes.uff"
    pyuff.UFF(str(path)).write_sets(pyuff.prepare_15(
        node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1],
        x=[0.0, 1.0], y=[0.0, 0.0], z=[0.0, 0.0]), "add")
    with pytest.raises(ValueError, match="no UFF dataset 58"):
        sd.read_uff(path)


def test_uff_inconsistent_axes(tmp_path):
    import pyuff

    path = tmp_path / "mixed.uff"
    sets = []
    for i, f in enumerate([np.linspace(1, 10, 10), np.linspace(1, 20, 10)]):
        sets.append(pyuff.prepare_58(
            binary=1, func_type=4, rsp_node=i + 1, rsp_dir=1, ref_node=1, ref_dir=1,
            data=np.ones(10, complex), x=f, abscissa_spacing=0, ord_data_type=6,
            ordinate_spec_data_type=12, orddenom_spec_data_type=13, ver_num=0, load_case_id=0))
    pyuff.UFF(str(path)).write_sets(sets, "add")
    with pytest.raises(ValueError, match="inconsistent frequency axes"):
        sd.read_uff(path)


def test_uff_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        sd.read_uff(tmp_path / "missing.uff")
    with pytest.raises(TypeError, match="path must be a file path"):
        sd.read_uff(3)
    with pytest.raises(TypeError, match="frf must be an sdctrl.FRF"):
        sd.write_uff(np.ones(3), tmp_path / "x.uff")


def test_npz_round_trip(tmp_path):
    frf = _frf()
    sd.save_npz(frf, tmp_path / "a.npz")
    back = sd.load_npz(tmp_path / "a.npz")
    for name in ("freq", "H", "coherence"):
        assert np.array_equal(getattr(back, name), getattr(frf, name))
    assert (back.sensors, back.actuators, back.collocated, back.quantity, back.units) == \
        (frf.sensors, frf.actuators, frf.collocated, frf.quantity, frf.units)
