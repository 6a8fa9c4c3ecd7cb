"""Mutation suite over the file readers: byte flips, truncations, insertions, deletions and
overwrites of UFF (binary, ASCII, foreign) and npz files (an FRF of the former save_npz, sd.save of
models).

Every outcome must be a correct read or a ``ValueError``/``OSError``; nothing else escapes and
nothing hangs (each read runs under a deadline).  "Correct" is as strict as the format allows:
an npz is protected by CRCs, so a mutated archive either loads *exactly* as saved or is refused;
a UFF file written by sdctrl carries its matrix size in every record, so it either reads with the
original shape (values may differ: UFF has no checksum) or is refused -- and a truncated one is
refused unless only trailing blanks were cut.  Examples are derandomised under the ``ci``
hypothesis profile; ``SDCTRL_HYPOTHESIS_PROFILE=deep`` runs twenty times more, at random.
Run with ``-s`` to print the outcome counts.
"""

import pathlib
import collections
import tracemalloc
import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from exact import assert_same
from hypothesis import given, settings
from hypothesis import strategies as st

import sdctrl as sd

OUTCOMES = collections.Counter()
_SCALE = 5 * settings.default.max_examples           # 500 per file kind under "ci"


def _frf(ns=2, na=2, nf=6, seed=0):
    rng = np.random.default_rng(seed)
    f = np.sort(rng.uniform(1.0, 100.0, nf))
    H = rng.standard_normal((nf, ns, na)) + 1j * rng.standard_normal((nf, ns, na))
    return sd.FRF(f, H, quantity="acceleration", sensors=["N1.x", "tip|a"][:ns],
                  actuators=["N1.x", "sh\u00e9"][:na], collocated=[(1, 0)] if ns > 1 else [],
                  coherence=rng.uniform(0, 1, (nf, ns, na)), units="m/s^2/N")


def _models():
    rng = np.random.default_rng(1)
    nm = sd.NormalModeModel(np.diag([4.0, 9.0]), np.diag([0.04, 0.06]), rng.normal(size=(2, 2)),
                            rng.normal(size=(2, 1)), E=np.zeros((2, 1)), sensors=["a", "b"],
                            info={"x": [1, (2.5, None)], "v": np.arange(3)})
    K = sp.diags([[-1.0] * 3, [2.0] * 4, [-1.0] * 3], [-1, 0, 1]).tocsr()
    fe = sd.FEModel(sp.identity(4, format="csr"), K, dofs=[f"N{i}.x" for i in range(4)],
                    nodes={f"N{i}": (i, 0, 0) for i in range(4)},
                    elements=[(f"N{i}", f"N{i + 1}") for i in range(3)])
    return {"save_nm": nm, "save_fe": fe, "save_frf": _frf(1, 2, nf=4)}


@pytest.fixture(scope="module")
def samples(tmp_path_factory):
    """name -> (file bytes, reader, original object, kind of check)."""
    import pyuff

    d = tmp_path_factory.mktemp("originals")
    out = {}
    frf = _frf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, binary in (("uff_binary", True), ("uff_ascii", False)):
            sd.write_uff(frf, d / name, binary=binary)
            out[name] = ((d / name).read_bytes(), sd.read_uff, sd.read_uff(d / name), "uff")
        sets = pyuff.UFF(str(d / "uff_binary")).read_sets()
        for s in sets:
            s["id2"], s["id4"] = "NONE", "NONE"
        pyuff.UFF(str(d / "uff_foreign")).write_sets(sets, "add")
        out["uff_foreign"] = ((d / "uff_foreign").read_bytes(), sd.read_uff, None, "foreign")
    path = pathlib.Path(__file__).resolve().parent / "data" / "legacy" / "frf_save_npz.npz"
    out["npz_frf"] = (open_bytes(path), sd.load, sd.load(path), "exact")
    for name, obj in _models().items():
        path = sd.save(obj, d / name)
        out[name] = (open_bytes(path), sd.load, obj, "exact")
    yield out
    if OUTCOMES:
        print("\nmutated files tried:", sum(OUTCOMES.values()))
        for key, n in sorted(OUTCOMES.items()):
            print(f"  {key[0]:12s} {key[1]:10s} {key[2]:22s} {n}")


def open_bytes(path):
    with open(path, "rb") as fh:
        return fh.read()


@st.composite
def mutations(draw, size):
    kind = draw(st.sampled_from(["flip", "flips", "truncate", "insert", "delete", "overwrite"]))
    pos = draw(st.integers(0, size - 1))
    if kind == "flip":
        return kind, [(pos, draw(st.integers(1, 255)))]
    if kind == "flips":
        return kind, draw(st.lists(st.tuples(st.integers(0, size - 1), st.integers(1, 255)),
                                   min_size=2, max_size=8))
    if kind == "truncate":
        return kind, pos
    if kind == "delete":
        return kind, (pos, draw(st.integers(1, 64)))
    junk = draw(st.one_of(st.binary(min_size=1, max_size=64),
                          st.sampled_from([b"    -1\n", b"\n", b"    58\n", b"PK\x03\x04",
                                           b"\x93NUMPY", b"nan", b"|", b" -1.0e+300"])))
    return kind, (pos, junk)


def mutate(raw: bytes, m) -> bytes:
    kind, arg = m
    if kind in ("flip", "flips"):
        b = bytearray(raw)
        for pos, mask in arg:
            b[pos] ^= mask
        return bytes(b)
    if kind == "truncate":
        return raw[:arg]
    if kind == "delete":
        pos, n = arg
        return raw[:pos] + raw[pos + n:]
    pos, junk = arg
    if kind == "insert":
        return raw[:pos] + junk + raw[pos:]
    return raw[:pos] + junk + raw[pos + len(junk):]           # overwrite


def _read(reader, path, deadline):
    with deadline(10), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return reader(path), None
        except (ValueError, OSError) as exc:                   # the only allowed failures
            return None, exc


def _check(name, sample, m, data, result, exc):
    raw, _, original, check = sample
    kind = m[0]
    if result is None:
        assert str(exc), f"{name}: empty error message"
        OUTCOMES[(name, kind, "refused")] += 1
        return
    if check == "exact":
        assert_same(original, result)                           # CRC: exact or refused
        OUTCOMES[(name, kind, "read, identical")] += 1
        return
    assert isinstance(result, sd.FRF)
    assert np.all(np.isfinite(result.H)) and np.all(np.diff(result.freq) > 0)
    if check == "uff":
        assert result.shape == original.shape, f"{name}: {kind} read as {result.shape}"
        if kind == "truncate":                                  # only trailing blanks cut
            assert not raw[len(data):].strip()
            assert_same(original, result)
    OUTCOMES[(name, kind, "read" if check != "uff" or not _same(original, result)
              else "read, identical")] += 1


def _same(a, b) -> bool:
    try:
        assert_same(a, b)
    except AssertionError:
        return False
    return True


_NAMES = ["uff_binary", "uff_ascii", "uff_foreign", "npz_frf", "save_frf", "save_nm", "save_fe"]


@pytest.mark.parametrize("name", _NAMES)
@settings(max_examples=_SCALE)
@given(data=st.data())
def test_mutated_files_read_correctly_or_are_refused(samples, tmp_path_factory, deadline,
                                                     name, data):
    sample = samples[name]
    raw, reader = sample[0], sample[1]
    m = data.draw(mutations(len(raw)), label="mutation")
    mutated = mutate(raw, m)
    path = tmp_path_factory.getbasetemp() / f"mutated_{name}"
    path.write_bytes(mutated)
    result, exc = _read(reader, path, deadline)
    _check(name, sample, m, mutated, result, exc)


@pytest.mark.parametrize("name", ["uff_binary", "uff_ascii", "npz_frf", "save_nm"])
def test_every_truncation_refused(samples, tmp_path, deadline, name):
    """Exhaustive: each prefix of the file is refused, or reads exactly (only blanks cut)."""
    raw, reader, original, _ = samples[name]
    path = tmp_path / name
    step = max(1, len(raw) // 1500)
    for n in list(range(0, len(raw), step)) + [len(raw) - 1]:
        path.write_bytes(raw[:n])
        result, _ = _read(reader, path, deadline)
        if result is not None:
            assert not raw[n:].strip() and _same(original, result), f"{name}[:{n}]"
        OUTCOMES[(name, "every-trunc", "refused" if result is None else "read, identical")] += 1


@settings(max_examples=settings.default.max_examples // 2)
@given(data=st.data())
def test_mutated_archives_allocate_little(samples, tmp_path_factory, deadline, data):
    """A tampered archive never allocates more than a small multiple of its size."""
    raw, reader = samples["save_fe"][:2]
    m = data.draw(mutations(len(raw)), label="mutation")
    mutated = mutate(raw, m)
    path = tmp_path_factory.getbasetemp() / "mutated_alloc.npz"
    path.write_bytes(mutated)
    tracemalloc.start()
    try:
        _read(reader, path, deadline)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 * len(mutated) + (1 << 20), (m[0], peak, len(mutated))

