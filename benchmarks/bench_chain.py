"""The whole chain at 10^3, 10^4 (and, with ``--big``, 10^5) DOFs on the scalable lattice
plate of :func:`sdctrl.testbeds.lattice` (issue 27).

Plain script::

    python benchmarks/bench_chain.py [--sizes 1000,10000] [--big] [--bars 1000]
                                     [--locations 10000] [--no-diagnose]

Steps, each timed at every size in one run (wall seconds and the process's CPU seconds:
on a shared machine the wall time follows the load, the CPU time much less):

``build``      the lattice's true and wrong FE models (assembly; the band from its modes)
``test``       its simulated test (modal synthesis, 24 x 3 FRFs, 400 lines)
``eigsh``      a plain scipy shift-invert ``eigsh(K, 20, M, sigma)`` of the wrong model's
               matrices (the shift ``FEModel.modes`` uses): the reference of ``modes``
``modes``      ``sd.FEModel(M, K, C, dofs)`` built from the same matrices (its checks
               included) and its ``modes(20)``: the user's cost (asked: <= 1.5x ``eigsh``)
``static``     ``static_correction(b, phi)`` of the 3 shakers on that model
``update``     ``sd.update`` with the 2 parameters of the structure (errors printed)
``identify``   ``sd.identify`` + ``sd.normal_modes`` (independent of N)
``hybrid``     ``sd.hybrid(updated fe, nm, sensor_c)`` (default ``residual="auto"``)
``placement``  ``sd.placement_study`` of a D-strut over ``--bars`` bars of the updated model
``retest``     a mass planted in the TRUE FE model at a top-layer node that is not tested
               (:func:`planted_node`), sized to shift its most affected in-band mode by
               0.5% (:data:`PLANTED_SHIFT`, a rule on the modes, not on one lattice), and
               the retest simulated as ``test`` is (same modal synthesis, 400 lines) with
               1% relative noise
``diagnose``   ``sd.diagnose(hybrid, retest, fe=updated fe, locations=...)`` over the
               ``--locations`` (default 10,000: issue 27's "10^4 candidate locations")
               nodes and elements nearest to the planted node (an element by its midpoint;
               :func:`near_locations`): a user who knows the area of the change lists it,
               and the scan grows with the locations listed, not with the FE model.
               ``--locations 0`` scans every element and every node instead
               (``reach=1e-9``: 16,474 pairs and 3,364 nodes at 10^4 DOFs, 166,000 and
               33,000 at 10^5)

The last columns are the growth exponent ``log(t2 / t1) / log(N2 / N1)`` of the CPU time
between the two largest sizes (asked: <= 1.2), then the ratio ``modes / eigsh`` per size
and the per-candidate placement time.  Each step's figure is printed as soon as it is
measured (a long run can be followed), with, after the diagnosis, the planted mass, the
effects found (kind, location) and the fitted mass's rank and relative error.
``--no-diagnose`` stops after the placement (the diagnosis over 10^5 candidate
locations takes long on a loaded machine).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
import scipy.sparse.linalg as spla

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import sdctrl as sd  # noqa: E402

STEPS = ("build", "test", "eigsh", "modes", "static", "update", "identify", "hybrid",
         "placement", "retest", "diagnose")
#: relative noise of the retest; the planted mass shifts its most affected in-band mode by
#: this fraction of its frequency (half a half-power bandwidth at 1% damping)
RETEST_NOISE, PLANTED_SHIFT = 0.01, 0.005
#: ``--locations 0``: the diagnosis scans every element and node (no unconnected pair)
REACH = 1e-9


class Clock:
    """Wall and CPU seconds of named steps."""

    def __init__(self):
        self.wall, self.cpu = {}, {}

    def __call__(self, name, fn, *args, **kw):
        w, c = time.perf_counter(), time.process_time()
        out = fn(*args, **kw)
        self.wall[name] = time.perf_counter() - w
        self.cpu[name] = time.process_time() - c
        print(f"  {name}: {self.wall[name]:.2f} s ({self.cpu[name]:.2f} CPU)", flush=True)
        return out


def chain(dofs: int, bars: int, diagnose: bool = True,
          locations: int = 10_000) -> tuple[int, Clock, dict]:
    """Run the chain on a lattice of about ``dofs`` DOFs; ``(N, clock, figures)``."""
    clk = Clock()

    def build():
        s = sd.testbeds.lattice(dofs)
        return s, s.fe(), s.wrong()

    s, fe, wrong = clk("build", build)
    frf = clk("test", s.frf, n=400)
    sigma = -1e-6 * float(np.median(wrong.K.diagonal() / wrong.M.diagonal()))
    K, M = wrong.K.tocsc(), wrong.M.tocsc()
    clk("eigsh", spla.eigsh, K, k=20, M=M, sigma=sigma, which="LM")

    def modes():
        model = sd.FEModel(wrong.M, wrong.K, wrong.C, dofs=wrong.dofs)
        return model, model.modes(20)

    model, (freq, phi) = clk("modes", modes)
    clk("static", model.static_correction, model.point(list(s.shakers)), phi)
    up = clk("update", sd.update, wrong, frf, s.parameters())

    def ident():
        cm = sd.identify(frf)
        return sd.normal_modes(cm, frf.collocated)

    nm = clk("identify", ident)
    h = clk("hybrid", sd.hybrid, up.fe, nm, up.fe.point(list(s.sensors)).T)
    els = list(up.fe.elements)
    cand = els[:: max(1, len(els) // bars)][:bars]
    st = clk("placement", sd.placement_study, h, up.fe, s.band, kv=300.0, candidates=cand,
             progress=False)
    figures = {"update": {k: round(v, 4) for k, v in up.values.items()},
               "update error": {k: float(f"{up.values[k] - v:.2g}") for k, v in s.truth.items()},
               "truth": s.truth, "hybrid modes": h.n, "bars": len(st.candidates),
               "best bar": st.best.bar}
    if diagnose:
        retest, planted = clk("retest", planted_retest, s, h, n=400)
        where = ({"locations": near_locations(up.fe, planted[0], locations)} if locations
                 else {"reach": REACH})
        d = clk("diagnose", sd.diagnose, h, retest, fe=up.fe, progress=False, **where)
        figures.update(found(d, planted), candidates=d.info.get("candidates"),
                       steps=len(d.steps))
    return fe.N, clk, figures


def near_locations(fe, node: str, count: int) -> list:
    """The ``count`` nodes and elements (an element at its midpoint) nearest to ``node``,
    nodes first, each in the FE model's order: the area a user suspects, listed."""
    names = list(fe.nodes)
    X = np.array([fe.nodes[n] for n in names], float)
    pos = {n: i for i, n in enumerate(names)}
    els = list(fe.elements)
    E = np.array([[pos[a], pos[b]] for a, b in els], int)
    P = np.vstack([X, 0.5 * (X[E[:, 0]] + X[E[:, 1]])])
    dist = np.linalg.norm(P - X[pos[node]], axis=1)
    keep = np.sort(np.argsort(dist, kind="stable")[:count])
    return [names[i] if i < len(names) else tuple(els[i - len(names)]) for i in keep]


def planted_node(s) -> str:
    """A node of the top layer, not tested, at fixed fractions of the plate (any size)."""
    return f"L{round(0.6 * (s.nx - 1))}_{round(s.ny / 3)}_1"


def planted_retest(s, h, n=400):
    """``(retest FRF, (node, dm))``: the TRUE FE model with a mass added at
    :func:`planted_node`, tested as ``s.frf`` tests it (the same modal synthesis: 40 modes,
    projected damping, exact static correction of the rest) plus 1% relative noise.  The
    mass shifts the in-band mode it affects most by :data:`PLANTED_SHIFT` (first order,
    ``dw / w = dm |phi_node|^2 / 2`` on the hybrid model's mass-normalised shapes): a rule,
    not a size tuned on one lattice."""
    import scipy.sparse as sp

    fe = s.fe()
    node = planted_node(s)
    rows = fe.dof_index([f"{node}.{a}" for a in "xyz"])
    hrows = {lab: i for i, lab in enumerate(h.dofs)}
    phi = h.shapes[[hrows[f"{node}.{a}"] for a in "xyz"]]
    inb = (h.frequency >= s.band[0]) & (h.frequency <= s.band[1])
    q2 = np.sum(np.abs(phi[:, inb]) ** 2, axis=0)
    dm = float(2 * PLANTED_SHIFT / q2.max())
    dM = sp.csr_matrix((np.full(3, dm), (rows, rows)), shape=fe.M.shape)
    fe2 = sd.FEModel(fe.M + dM, fe.K, fe.C, dofs=fe.dofs, nodes=dict(fe.nodes),
                     elements=fe.elements, assembly=fe.assembly)
    nm = fe2.normal_mode_model(list(s.shakers), list(s.sensors), 40, static="E")
    freq = np.linspace(*s.band, n)
    H = nm.frf(freq, "acceleration").H
    e = np.random.default_rng(27).standard_normal(H.shape + (2,)) @ np.array([1, 1j])
    frf = sd.FRF(freq, H * (1 + RETEST_NOISE * e / np.sqrt(2)), quantity="acceleration",
                 sensors=s.sensors, actuators=s.shakers,
                 collocated=[(i, i) for i in range(len(s.shakers))])
    return frf, (node, dm)


def found(d, planted) -> dict:
    """Rank, location and size error of the planted mass among the diagnosis's effects."""
    node, dm = planted
    kinds = [(e.kind, e.location) for e in d.effects]
    out = {"planted": f"{dm:.4g} kg at {node}",
           "effects": [f"{k} {loc}" for k, loc in kinds]}
    for i, e in enumerate(d.effects):
        if e.kind == "mass_change" and e.location == node:
            out["found"] = (f"rank {i + 1}, dm {e.parameters['dm']:.4g} kg, "
                            f"error {e.parameters['dm'] / dm - 1:+.1%}")
            break
    else:
        out["found"] = "no"
    return out


def table(runs) -> str:
    """Markdown table: wall (CPU) seconds per step and size, growth exponent."""
    sizes = [n for n, _, _ in runs]
    head = "| step | " + " | ".join(f"N = {n:,}" for n in sizes)
    head += " | growth exponent |\n|---|" + "---:|" * (len(sizes) + 1) + "\n"
    rows = []
    for step in STEPS:
        if not all(step in c.wall for _, c, _ in runs):
            continue
        cells = [f"{c.wall[step]:.2f} s ({c.cpu[step]:.2f})" for _, c, _ in runs]
        g = ""
        if len(runs) > 1:
            (n1, c1, _), (n2, c2, _) = runs[-2], runs[-1]
            g = f"{np.log(c2.cpu[step] / c1.cpu[step]) / np.log(n2 / n1):.2f}"
        rows.append(f"| {step} | " + " | ".join(cells) + f" | {g} |")
    ratio = [f"{c.wall['modes'] / c.wall['eigsh']:.2f} ({c.cpu['modes'] / c.cpu['eigsh']:.2f})"
             for _, c, _ in runs]
    rows.append("| modes / eigsh | " + " | ".join(ratio) + " | |")
    per = [f"{1e3 * c.wall['placement'] / f['bars']:.0f} ms "
           f"({1e3 * c.cpu['placement'] / f['bars']:.0f})" for _, c, f in runs]
    rows.append("| placement per bar | " + " | ".join(per) + " | |")
    return head + "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000")
    ap.add_argument("--big", action="store_true", help="add the 10^5-DOF run (minutes)")
    ap.add_argument("--bars", type=int, default=1000)
    ap.add_argument("--locations", type=int, default=10_000,
                    help="candidate locations of the diagnosis (0: every element and node)")
    ap.add_argument("--no-diagnose", action="store_true", help="stop after the placement")
    a = ap.parse_args(argv)
    sizes = [int(x) for x in a.sizes.split(",")] + ([100_000] if a.big else [])
    runs = []
    for n in sizes:
        print(f"lattice({n}):", flush=True)
        N, clk, fig = chain(n, a.bars, not a.no_diagnose, a.locations)
        runs.append((N, clk, fig))
        print(f"N = {N:,}: " + ", ".join(f"{k} {v:.1f} s" for k, v in clk.wall.items())
              + f"; {fig}", flush=True)
    print("\nwall seconds (CPU seconds of the process); growth exponent of the CPU time "
          "between the two largest sizes\n")
    print(table(runs))


if __name__ == "__main__":
    main()
