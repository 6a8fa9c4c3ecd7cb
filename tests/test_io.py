"""UFF dataset 58 and npz I/O: exact round trips, labels, units, clear errors."""

import os
import re
import warnings

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
    sd.save(frf, tmp_path / "a.npz")
    back = sd.load(tmp_path / "a.npz")
    for name in ("freq", "H", "coherence"):
        assert np.array_equal(getattr(back, name), getattr(frf, name))
    assert (back.sensors, back.actuators, back.collocated, back.quantity, back.units) == \
        (frf.sensors, frf.actuators, frf.collocated, frf.quantity, frf.units)


# ------------------------------------------------------------------------------------------
# labels, collocation, single lines
# ------------------------------------------------------------------------------------------
def _small(ns=2, na=2, nf=8, seed=1, **kw):
    rng = np.random.default_rng(seed)
    f = np.sort(rng.uniform(1.0, 100.0, nf))
    H = rng.standard_normal((nf, ns, na)) + 1j * rng.standard_normal((nf, ns, na))
    return sd.FRF(f, H, **kw)


@pytest.mark.parametrize("binary", [True, False])
def test_uff_any_label_round_trips(tmp_path, binary):
    sensors = ["a|b", "line\nbreak", " lead", "trail ", "caf\u00e9 \u2013 \u6e2c", "100%", ""]
    actuators = ["N1.x", "tab\there", "|"]
    frf = _small(len(sensors), len(actuators), nf=5, sensors=sensors, actuators=actuators)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                    # ASCII uneven axis
        sd.write_uff(frf, tmp_path / "l.uff", binary=binary)
    back = sd.read_uff(tmp_path / "l.uff")
    assert back.sensors == tuple(sensors) and back.actuators == tuple(actuators)
    assert back.collocated == ()


def test_uff_too_long_labels_refused_up_front(tmp_path):
    """A round trip keeps what it is given or refuses it: no silent fall back to node numbers."""
    frf = _small(1, 1, sensors=["s" * 75], actuators=["N3.y"])
    with pytest.raises(ValueError, match=r"frf labels .* too long for a UFF ID line \(\d+ "
                                         r"characters encoded, at most 80\).*sdctrl.save"):
        sd.write_uff(frf, tmp_path / "long.uff")
    assert not (tmp_path / "long.uff").exists()
    ok = _small(1, 1, sensors=["s" * 40], actuators=["N3.y"])
    sd.write_uff(ok, tmp_path / "ok.uff")
    assert sd.read_uff(tmp_path / "ok.uff").sensors == ("s" * 40,)
    with pytest.raises(ValueError, match="cannot be encoded"):
        sd.write_uff(_small(1, 1, sensors=["\ud800"]), tmp_path / "bad.uff")


@pytest.mark.parametrize("collocated", [[], [(1, 0)], [(0, 0), (1, 1)], [(1, 1), (0, 0)]])
def test_uff_collocation_never_invented_or_dropped(tmp_path, collocated):
    # sensor 0 and actuator 0 share a label; sensor 1 / actuator 1 do not
    frf = _small(sensors=["N1.x", "tip"], actuators=["N1.x", "shaker"], collocated=collocated)
    for binary in (True, False):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sd.write_uff(frf, tmp_path / "c.uff", binary=binary)
        assert sd.read_uff(tmp_path / "c.uff").collocated == tuple(collocated)


def test_uff_foreign_files_collocated_at_driving_points(tmp_path):
    import pyuff

    sets = []
    for (rn, rd), (fn, fd) in [((1, 1), (1, 1)), ((2, 3), (1, 1)), ((1, 1), (2, 3)),
                               ((2, 3), (2, 3))]:
        sets.append(pyuff.prepare_58(
            binary=1, func_type=4, rsp_node=rn, rsp_dir=rd, ref_node=fn, ref_dir=fd,
            data=np.ones(4, complex) * (rn + 1j * fn), x=np.arange(1.0, 5.0),
            abscissa_spacing=0, ord_data_type=6, ordinate_spec_data_type=12,
            orddenom_spec_data_type=13, ver_num=0, load_case_id=0))
    pyuff.UFF(str(tmp_path / "f.uff")).write_sets(sets, "add")
    back = sd.read_uff(tmp_path / "f.uff")
    assert back.sensors == ("N1.x", "N2.z") and back.actuators == ("N1.x", "N2.z")
    assert back.collocated == ((0, 0), (1, 1))
    assert np.array_equal(back.H[0], [[1 + 1j, 1 + 2j], [2 + 1j, 2 + 2j]])


def test_uff_foreign_negative_directions_read_as_positive(tmp_path):
    """A survey's hammer recorded along -z (direction -3) at the accelerometer's node: the
    +z reference with the FRF negated, so the driving point is collocated; a response along
    -y likewise."""
    import pyuff

    sets = []
    for (rn, rd), (fn, fd), v in [((5, 3), (5, -3), 1.0), ((6, -2), (5, -3), 2.0),
                                  ((5, 3), (7, 3), 3.0), ((6, -2), (7, 3), 4.0)]:
        sets.append(pyuff.prepare_58(
            binary=1, func_type=4, rsp_node=rn, rsp_dir=rd, ref_node=fn, ref_dir=fd,
            data=np.full(4, v + 1j), x=np.arange(1.0, 5.0), abscissa_spacing=0,
            ord_data_type=6, ordinate_spec_data_type=12, orddenom_spec_data_type=13,
            ver_num=0, load_case_id=0))
    pyuff.UFF(str(tmp_path / "s.uff")).write_sets(sets, "add")
    back = sd.read_uff(tmp_path / "s.uff")
    assert back.sensors == ("N5.z", "N6.y") and back.actuators == ("N5.z", "N7.z")
    assert back.collocated == ((0, 0),)
    # sign: one negative direction negates, two cancel
    assert np.array_equal(back.H[0], [[-(1 + 1j), 3 + 1j], [2 + 1j, -(4 + 1j)]])


@pytest.mark.parametrize("binary", [True, False])
def test_uff_single_line_round_trip_exact(tmp_path, binary):
    frf = sd.FRF([7.123456789012345], [[[1.5 - 2j, 3j]]], sensors=["s"], actuators=["s", "b"],
                 coherence=[[[0.25, 1.0]]])
    sd.write_uff(frf, tmp_path / "one.uff", binary=binary)
    back = sd.read_uff(tmp_path / "one.uff")
    assert np.array_equal(back.freq, frf.freq)                   # exact, also in ASCII
    assert np.array_equal(back.coherence, frf.coherence)
    assert back.collocated == frf.collocated == ((0, 0),)     # same label: a driving point
    if binary:
        assert np.array_equal(back.H, frf.H)
    else:
        assert np.allclose(back.H, frf.H, rtol=1e-10)


def test_uff_ascii_even_axis_exact(tmp_path):
    f = 0.1 + 0.3 * np.arange(40)                               # not 6-digit representable
    frf = sd.FRF(f, np.ones((40, 1, 1)) * (1 + 1j))
    sd.write_uff(frf, tmp_path / "even.uff", binary=False)
    back = sd.read_uff(tmp_path / "even.uff")
    assert np.allclose(back.freq, f, rtol=1e-15, atol=0)         # min + k*inc from exact floats
    raw = (tmp_path / "even.uff").read_bytes()
    line = re.search(rb"sdctrl:axis=\S+", raw).group(0)
    for bad in (b"sdctrl:axis=0x1p+99999,0x1p+0", b"sdctrl:axis=0x1p+1,0x1p-2"):
        (tmp_path / "even.uff").write_bytes(raw.replace(line, bad.ljust(len(line))))
        with pytest.raises(ValueError, match="axis of ID line 5 disagrees"):
            sd.read_uff(tmp_path / "even.uff")


@pytest.mark.parametrize("units", ["a very long units label, m/s^2/N", "m/s^2\n/N", " m/N"])
def test_uff_units_that_do_not_fit_are_refused(tmp_path, units):
    frf = _small(1, 1, units=units)
    for binary in (True, False):
        with pytest.raises(ValueError, match="frf.units .* at most 20 printable ASCII"):
            sd.write_uff(frf, tmp_path / "u.uff", binary=binary)
    sd.write_uff(_small(1, 1, units="m/s^2/N"), tmp_path / "v.uff")
    assert sd.read_uff(tmp_path / "v.uff").units == "m/s^2/N"


@pytest.mark.parametrize("units", ["", "NONE", "none", "  "])
def test_uff_units_that_would_read_back_as_none_are_refused(tmp_path, units):
    """Issue 25 (fuzz): UFF writes missing units as NONE, so '' or 'NONE' would come back as
    units=None -- refused up front; None itself round-trips."""
    for binary in (True, False):
        with pytest.raises(ValueError, match=r"frf.units .* reads an empty or NONE label back"):
            sd.write_uff(_small(1, 1, units=units), tmp_path / "u.uff", binary=binary)
    sd.write_uff(_small(1, 1), tmp_path / "v.uff")
    assert sd.read_uff(tmp_path / "v.uff").units is None
    back = sd.load(sd.save(_small(1, 1, units=units), tmp_path / "w"))   # npz keeps it
    assert back.units == units


def test_a_collocated_pair_given_twice_is_one_pair_and_round_trips(tmp_path):
    """Issue 25 (fuzz): ((0, 0), (0, 0)) was kept twice in the FRF but read back once."""
    frf = sd.FRF(np.linspace(1, 2, 3), np.ones((3, 2, 2)), collocated=[(0, 0), (1, 1), (0, 0)])
    assert frf.collocated == ((0, 0), (1, 1))
    sd.write_uff(frf, tmp_path / "c.uff")
    assert sd.read_uff(tmp_path / "c.uff").collocated == frf.collocated


def test_read_uff_on_an_npz_points_to_load(tmp_path):
    path = sd.save(_small(1, 1), tmp_path / "f")
    with pytest.raises(ValueError, match=r"f\.npz.* zip archive .*sdctrl\.load"):
        sd.read_uff(path)


# ------------------------------------------------------------------------------------------
# truncated, inconsistent, damaged files
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("fraction", [0.3, 0.5, 0.75, 0.99])
def test_uff_truncated_files_refused_never_shrunk(tmp_path, binary, fraction):
    frf = _small(coherence=np.full((8, 2, 2), 0.5))
    path = tmp_path / "t.uff"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sd.write_uff(frf, path, binary=binary)
    raw = path.read_bytes()
    path.write_bytes(raw[:int(fraction * len(raw))])
    with pytest.raises(ValueError, match="t.uff"):
        sd.read_uff(path)


def test_uff_truncated_at_a_record_boundary_refused(tmp_path):
    frf = _small()
    path = tmp_path / "b.uff"
    sd.write_uff(frf, path)
    raw = path.read_bytes()
    ends = [i + 7 for i in range(len(raw)) if raw.startswith(b"    -1\n", i)][1::2]
    for end in ends[:-1]:                                        # 1, 2, 3 complete records
        path.write_bytes(raw[:end])
        with pytest.raises(ValueError, match="truncated or incomplete"):
            sd.read_uff(path)
    path.write_bytes(raw[:ends[-1]] + b"\n\n  \n")               # trailing blanks are fine
    assert np.array_equal(sd.read_uff(path).H, frf.H)


def test_uff_foreign_truncated_inside_a_record_refused(tmp_path):
    import pyuff

    frf = _small()
    path = tmp_path / "f.uff"
    sd.write_uff(frf, path)
    sets = pyuff.UFF(str(path)).read_sets()
    for d in sets:
        d["id2"], d["id4"] = "NONE", "NONE"
    other = tmp_path / "foreign.uff"
    pyuff.UFF(str(other)).write_sets(sets, "add")
    assert sd.read_uff(other).H.shape == (8, 2, 2)
    raw = other.read_bytes()
    other.write_bytes(raw[:int(0.3 * len(raw))])
    with pytest.raises(ValueError, match=r"foreign.uff.*block opened by the '    -1' line \d+ "
                                         r"is not closed"):
        sd.read_uff(other)


def test_uff_damaged_content_refused_with_the_file_named(tmp_path):
    frf = _small()
    path = tmp_path / "d.uff"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sd.write_uff(frf, path, binary=False)
    raw = path.read_bytes()
    first = sum(len(line) for line in raw.splitlines(True)[:13])   # first data line
    nan = raw[:first + 13] + b"nan".rjust(20) + raw[first + 33:]    # a value, not the axis
    cases = {
        "garbage outside": raw + b"garbage\n",
        "bad number": raw.replace(b"e+0", b"x+0", 1),
        "nan": nan,
        "wrong count": raw.replace(b"         6         8", b"         6         9", 1),
        "bad size": raw.replace(b" 2x2 ", b" 3x2 ", 1),
        "bad index": raw.replace(b"sdctrl:1,0 ", b"sdctrl:0,0 ", 1),
        "bad label": raw.replace(b"sdctrl:s0|a0", b"sdctrl:s0|a0|x", 1),
        "bad escape": raw.replace(b"sdctrl:s0|a0", b"sdctrl:s0%FF|a0", 1),
        "no dataset 58": raw.replace(b"    58", b"    15"),
        "empty": b"",
    }
    for what, data in cases.items():
        assert data != raw or what == "empty", what
        path.write_bytes(data)
        with pytest.raises(ValueError, match="d.uff") as err:
            sd.read_uff(path)
        assert type(err.value) is ValueError, what
        assert what != "nan" or "NaN" in str(err.value)


def test_uff_write_failure_keeps_the_old_file(tmp_path, monkeypatch):
    import pyuff

    path = tmp_path / "keep.uff"
    sd.write_uff(_small(), path)
    before = path.read_bytes()

    def fail(self, sets, mode="add", force_double=True):
        self._write_set(sets[0], "add")
        raise Exception("disk on fire")  # noqa: TRY002  (what pyuff raises)

    monkeypatch.setattr(pyuff.UFF, "write_sets", fail)
    with pytest.raises(ValueError, match="keep.uff.*disk on fire"):
        sd.write_uff(_small(seed=5), path)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["keep.uff"]          # no temporary file left


def test_uff_append_after_other_datasets(tmp_path):
    import pyuff

    path = tmp_path / "geo.uff"
    pyuff.UFF(str(path)).write_sets(pyuff.prepare_15(
        node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1],
        x=[0.0, 1.0], y=[0.0, 0.0], z=[0.0, 0.0]), "add")
    frf = _small()
    sd.write_uff(frf, path, overwrite=False)
    assert np.array_equal(sd.read_uff(path).H, frf.H)
    sd.write_uff(frf, path, overwrite=False)                     # a second FRF in the file
    with pytest.raises(ValueError, match="geo.uff"):
        sd.read_uff(path)


# ------------------------------------------------------------------------------------------
# paths that are not regular files: refused at once, never blocking
# ------------------------------------------------------------------------------------------
_READERS = [sd.read_uff, sd.load]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
@pytest.mark.parametrize("reader", _READERS, ids=lambda r: r.__name__)
def test_fifo_and_devices_refused_without_blocking(tmp_path, reader, deadline):
    fifo = tmp_path / "pipe.npz"
    os.mkfifo(fifo)
    with deadline(5), pytest.raises(ValueError, match="pipe.npz.*FIFO"):
        reader(fifo)
    if os.path.exists("/dev/zero"):
        with deadline(5), pytest.raises(ValueError, match="character device"):
            reader("/dev/zero")
    with deadline(5), pytest.raises(IsADirectoryError, match=tmp_path.name):
        reader(tmp_path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_writers_refuse_fifo_targets(tmp_path, deadline):
    fifo = tmp_path / "pipe.uff"
    os.mkfifo(fifo)
    for write in (lambda: sd.write_uff(_small(), fifo, overwrite=False),
                  lambda: sd.write_uff(_small(), fifo),
                  lambda: sd.save(_small(), str(fifo) + ".npz") if os.mkfifo(
                      str(fifo) + ".npz") is None else None):
        with deadline(5), pytest.raises(ValueError, match="FIFO"):
            write()


def test_unreadable_path_is_an_oserror_naming_it(tmp_path, monkeypatch):
    path = tmp_path / "secret.uff"
    sd.write_uff(_small(), path)
    real_open = os.open

    def denied(file, *args, **kwargs):        # as chmod 0 would, even when run as root
        if os.fspath(file) == os.fspath(path):
            raise PermissionError(13, "Permission denied")
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(os, "open", denied)
    with pytest.raises(PermissionError, match="secret.uff"):
        sd.read_uff(path)


@pytest.mark.parametrize("binary", [True, False])
def test_uff_round_trip_keeps_the_exponential_window(tmp_path, binary):
    """Issue 26: an impact test's exponential window travels through UFF (ID line 3), so that
    identify corrects the damping of a file as of the FRF it was written from."""
    f = np.linspace(1.0, 10.0, 50)
    H = np.ones((50, 2, 1)) * (1 + 1j)
    frf = sd.FRF(f, H, sensors=["a.x", "b.x"], actuators=["a.x"], exponential_tau=0.123)
    path = tmp_path / "hits.uff"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                    # ASCII: single-precision axis
        sd.write_uff(frf, path, binary=binary)
    assert sd.read_uff(path).exponential_tau == 0.123
    plain = sd.FRF(f, H, sensors=["a.x", "b.x"], actuators=["a.x"])
    sd.write_uff(plain, tmp_path / "plain.uff", binary=True)
    assert sd.read_uff(tmp_path / "plain.uff").exponential_tau is None
