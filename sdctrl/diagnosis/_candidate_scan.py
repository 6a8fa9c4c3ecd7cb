"""The scan of physical candidates on an FE model: a vectorised screen, then full fits.

1. **set-up** (once per model): the model's shapes on the FE DOFs, one complex-mode
   factorisation (:class:`~sdctrl.diagnosis._lowrank.Resolvent`) and the static corrections
   (4.23) of the test's own unit loads (one solve per tested DOF).  Each candidate is a
   low-rank change of that reduced model: its load (a few DOFs) projected on the modes and
   on those static corrections, so that the scan grows with the candidates, not with the
   FE size;
2. **screen**: every candidate of every family at every size of its grid, by the Woodbury
   update (rank 1, 3, or up to 6 for a beam) on a subset of lines, in single precision,
   log-magnitude logLS: a coarse grid on half those lines for all, the full grid for the best share
   of each family, and the best of those again with their exact static correction (their own
   flexibility, one solve each; the screen projects it on the test's static corrections)
   and, for the best of those, their cost refined in size between grid points
   (:mod:`._exact_screen`) --
   batched over candidates, in chunks that an executor may run anywhere (the chunks and
   their order do not depend on the executor, so the ranking is identical); what every
   chunk reads (the data's lines) is shared, scattered once on a Dask client;
3. **fits**: the best candidates of each family and overall, with their exact static
   correction (one solve each), are fitted again on all the data with the complex logLS
   (3.12), :mod:`._finalist_fit`: a bounded 1-D minimisation of ``log(base + size)`` from the
   best grid point, or (resonators) a least-squares fit of mass, frequency and damping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from sdctrl._lib.parallel import dask_client, map_chunks, share
from sdctrl.diagnosis._candidates import Candidates, families
from sdctrl.diagnosis._finalist_fit import fit_task
from sdctrl.diagnosis._global_effects import proposal
from sdctrl.diagnosis._lowrank import Resolvent, screen_chunk, static_terms
from sdctrl.diagnosis._exact_screen import (
    rescreen,
    single as _single,
    sub_group as _sub,
    transfers32 as _transfers32,
)

__all__ = ["Setup", "physical_proposals", "setup"]

#: at most this many lines in the screen (every k-th line)
SCREEN_LINES = 200
#: candidates per screen task
CHUNK = 48
#: finalists per family, and overall
FIN_FAMILY, FIN_OVERALL = 2, 6
#: the second stage of the screen takes this share of each family (at least FINE_MIN)
FINE_FRAC, FINE_MIN = 0.12, 8
#: the first (coarse) stage reads every COARSE_EVERY-th line of the screen's lines
COARSE_EVERY = 2
#: resonator tunings tried around the frequency of the extra mode seen in the data
RES_TUNING = (0.97, 1.0, 1.03)


@dataclass(frozen=True, eq=False)
class Setup:
    """A model placed on an FE model for the candidate scan (internal).

    Parameters
    ----------
    fe : FEModel
        The FE model.
    model : NormalModeModel
        The model (shapes on FE DOFs).
    rows_fe : ndarray of int
        FE DOF of each row of ``model.shapes``.
    T : ndarray, shape (N, n)
        The shapes in FE DOF order.
    res : Resolvent
        Factored ``Z(s)^-1``.
    C, B : ndarray
        Modal observability of the data sensors (ns, n), controllability of the data
        actuators (n, na).
    dof_idx : ndarray of int
        Candidate DOFs.
    phid : ndarray, shape (nd, n)
        Shapes at the candidate DOFs.
    static : StaticTerms
        Static corrections of the test's unit loads (and of any load on demand).
    families : list of Family
        The candidate families.
    kinv : dict
        ``Candidates.kinv``: the candidates' ``b^T K^-1 b`` solved so far in this diagnosis.
    """

    fe: object
    model: object
    rows_fe: np.ndarray
    T: np.ndarray
    res: Resolvent
    C: np.ndarray
    B: np.ndarray
    dof_idx: np.ndarray
    phid: np.ndarray
    static: object
    families: list
    kinv: dict


def _fe_rows(model, fe):
    if model.dofs is not None:
        return fe.dof_index(list(model.dofs))
    if model.shapes.shape[0] == fe.N:
        return np.arange(fe.N)
    raise ValueError(f"model: its shapes have {model.shapes.shape[0]} rows and no dofs labels; "
                     f"they must be on the DOFs of fe (N={fe.N})")


def _labels_on(fe, labels):
    index = {lab: i for i, lab in enumerate(fe.dofs)}
    return np.array([index.get(str(lab), -1) for lab in labels], int)


def setup(model, fe, placed, cand: Candidates) -> Setup:
    """Place a normal-mode model with shapes on the FE model for the scan.

    Parameters
    ----------
    model : NormalModeModel
        With ``shapes`` on the FE DOFs.
    fe : FEModel
        The FE model.
    placed : Placed
        The data.
    cand : Candidates
        Where the diagnosis looks.

    Returns
    -------
    Setup
    """
    dof_idx, groups, n_el = cand.dof_idx, cand.groups, cand.n_elements
    rows_fe = _fe_rows(model, fe)
    T = np.zeros((fe.N, model.n))
    T[rows_fe] = model.shapes
    res = Resolvent.of(model.Omega, model.Gamma)
    st = static_terms(fe, T, dof_idx, _labels_on(fe, model.sensors),
                      _labels_on(fe, model.actuators))
    phid = T[dof_idx]
    w = np.sqrt(np.clip(np.diag(model.Omega), 0, None))
    lo, hi = 2 * np.pi * placed.freq[0], 2 * np.pi * placed.freq[-1]
    inb = (w >= lo) & (w <= hi)
    if not inb.any():
        inb = w > 0
    modal_b = {k: g.project(phid[:, inb]) for k, g in groups.items()}
    Md = fe.M.diagonal() if sp.issparse(fe.M) else np.diag(np.asarray(fe.M))
    g = groups["nodes"]
    used = np.any(g.val != 0, axis=2)                                  # (nn, 3)
    node_mass = np.sum(Md[dof_idx][g.idx] * used, axis=1) / np.maximum(used.sum(axis=1), 1)
    fams = families(fe, groups, n_el, modal_b, w[inb], np.diag(model.Gamma)[inb], node_mass)
    return Setup(fe, model, rows_fe, T, res, np.asarray(model.cphi)[placed.rows],
                 np.asarray(model.phib)[:, placed.cols], dof_idx, phid, st, fams, cand.kinv)


def _grids(S, mode):
    """Full screen grid and resonator tunings of each family, and its coarse columns."""
    out = {}
    for fi, fam in enumerate(S.families):
        if fam.kind != "resonator":
            m = fam.grid.shape[1]
            out[fi] = (fam.grid, None, np.unique(np.r_[np.arange(0, m, 3), m - 1]))
        elif mode is not None:
            t = np.asarray(RES_TUNING)
            grid = np.repeat(fam.grid, t.size, axis=1)
            w = np.broadcast_to(np.tile(mode[0] * t, fam.grid.shape[1]), grid.shape)
            coarse = np.array([t.size * i + j for i in range(0, fam.grid.shape[1], 2)
                               for j in range(t.size)])
            out[fi] = (grid, (w, np.full(grid.shape, mode[1])), coarse)
    return out


def _screen(S, placed, H, mode, executor, progress):
    """Three-stage screen: the coarse grid on every :data:`COARSE_EVERY`-th screen line for
    all, the full grid for the best of each family, the best of those again with their exact
    static correction (:func:`~._exact_screen.rescreen`).

    The candidates' transfers are computed chunk by chunk as the chunks run (serially or
    on an executor's threads), on the lines of the stage only: memory grows with a chunk,
    not with the candidates times the lines (at 10^5 DOFs, 166,000 bars' transfers on
    200 lines and 24 sensors are 6.4 GB in single precision).  On a Dask client they are
    computed once for all and scattered (tasks carry indices).

    Returns ``({family: (best cost (nc,), best column of the full grid (nc,))}, grids,
    {(family, position) screened exactly})``.
    """
    base = _screen_lines(placed, H)
    base.pop("step")
    grids = _grids(S, mode)
    # on Dask the transfers are scattered once for both stages, tasks carry indices
    scattered = dask_client(executor) is not None
    G = {}
    for fi in grids if scattered else ():
        group = S.families[fi].group
        if group.name not in G:
            G[group.name] = _transfers32(S, placed, base["s"], group)
    shared = share(executor, {"base": base, "G": G})
    best = {fi: (np.full(S.families[fi].size, np.inf), np.zeros(S.families[fi].size, int))
            for fi in grids}
    stage1 = {fi: (np.arange(S.families[fi].size), g[2]) for fi, g in grids.items()}
    for sel in (stage1, None):
        if sel is None:         # stage 2: the full grid for the best of each family
            sel = {}
            for fi, (c, _) in best.items():
                n2 = min(c.size, max(FINE_MIN, int(np.ceil(FINE_FRAC * c.size))))
                sel[fi] = (np.sort(np.argsort(c, kind="stable")[:n2]),
                           np.arange(grids[fi][0].shape[1]))
        every = COARSE_EVERY if sel is stage1 else 1
        tl = _screen_chunks(S, grids, sel, every)
        tasks = _Tasks(S, placed, base["s"][::every], tl, scattered)
        res = map_chunks(_screen_task, tasks, shared, executor, progress, "screen")
        for (fi, p, cols, _), sc in zip(tl, res):       # stage 2 supersedes stage 1
            j = np.argmin(sc, axis=1)
            best[fi][0][p] = sc[np.arange(p.size), j]
            best[fi][1][p] = cols[j]
    exact = rescreen(S, placed, grids, best, base)
    return best, grids, exact


class _Tasks:
    """The screen's tasks, each built when it is read: its candidates' transfers on the
    stage's lines ``s`` (or, ``scattered``, their indices in the shared ones)."""

    def __init__(self, S, placed, s, chunks, scattered):
        self.S, self.placed, self.s, self.chunks = S, placed, s, chunks
        self.scattered = scattered

    def __len__(self) -> int:
        return len(self.chunks)

    def __getitem__(self, i) -> dict:
        fi, p, _cols, t = self.chunks[i]
        fam = self.S.families[fi]
        m = fam.members[p]
        if self.scattered:
            return {**t, "group": fam.group.name, "m": m}
        Gyk, Gkk, Gku = _transfers32(self.S, self.placed, self.s, _sub(fam.group, m))
        return {**t, "Gyk": Gyk, "Gkk": Gkk, "Gku": Gku}


def _screen_chunks(S, grids, sel, every=1) -> list:
    """``(family, positions, grid columns, task)`` of the screen's chunks of ``sel`` on every
    ``every``-th line; a task holds its candidates' sizes, not yet their transfers
    (:class:`_Tasks`)."""
    out = []
    for fi, (pos, cols) in sel.items():
        fam = S.families[fi]
        grid, extra, _ = grids[fi]
        for a in range(0, pos.size, CHUNK):
            p = pos[a:a + CHUNK]
            ex = None if extra is None else (extra[0][p][:, cols], extra[1][p][:, cols])
            t = {"kind": fam.kind, "sizes": grid[p][:, cols], "extra": ex, "every": every}
            out.append((fi, p, cols, t))
    return out


def _screen_task(chunk, shared):
    t = {**shared["base"], **chunk}
    k = t.pop("every")
    t.update(A=t["A"][::k], iHd=t["iHd"][::k], s=t["s"][::k])
    if "group" in chunk:                     # transfers scattered once (Dask), all lines
        Gyk, Gkk, Gku = shared["G"][t.pop("group")]
        m = t.pop("m")
        t.update(Gyk=Gyk[m, ::k], Gkk=Gkk[m, ::k], Gku=Gku[m, ::k])
    return screen_chunk(t)


def _fit_task(t, lines):
    return fit_task({**lines, **t})


def _screen_lines(placed, H):
    """What a screen task reads of the lines: every k-th line, single precision."""
    step = -(-placed.freq.size // SCREEN_LINES)
    Hd = placed.Hd[::step]
    return {"A": (H[::step] / Hd).astype(np.complex64),
            "iHd": (1.0 / Hd).astype(np.complex64), "s": placed.s[::step], "step": step}


def _best_size(base, kind, grid, extra, G):
    """Best point of a finalist's screen grid with its exact transfers ``G`` (all lines):
    the screen ranked the candidates with their own flexibility projected on the test's
    static corrections, the fit starts from the grid point its exact static correction
    prefers."""
    k = base["step"]
    t = {"A": base["A"], "iHd": base["iHd"], "s": base["s"], "kind": kind,
         "sizes": grid[None], "extra": None if extra is None else (extra[0][None],
                                                                   extra[1][None])}
    t.update({name: g[::k][None].astype(np.complex64)
              for name, g in zip(("Gyk", "Gkk", "Gku"), G)})
    return int(np.argmin(screen_chunk(t)[0]))


def _finalists(best):
    """(family index, member position) of the candidates fitted on all the data."""
    keep = set()
    overall = []
    for fi, (c, _) in best.items():
        order = np.argsort(c, kind="stable")
        keep.update((fi, int(i)) for i in order[:FIN_FAMILY])
        overall += [(float(c[i]), fi, int(i)) for i in order[:FIN_OVERALL]]
    keep.update((fi, i) for _, fi, i in sorted(overall)[:FIN_OVERALL])
    return sorted(keep)


def _describe(S, fam, pos, static, m, cost_, size, w, z):
    """Proposal of a fitted physical candidate (with what apply needs); ``m`` the number of
    hypotheses of its kind (every family of that kind)."""
    g = fam.group
    c = int(fam.members[pos])
    beta, psi, Fb = static
    loc = g.locations[c]
    kind = fam.kind
    if kind == "added_damper":
        params, k = {"c": size}, 1
    elif kind == "stiffness_change":
        params, k = {"dk": size}, 1
        if np.isfinite(fam.reference[pos]):
            params["relative"] = size / fam.reference[pos]
    elif kind == "mass_change":
        params, k = {"dm": size}, 1
    else:
        params = {"frequency": w / (2 * np.pi), "damping": z, "mass": size,
                  "stiffness": size * w * w}
        k = 3
    st = S.static
    b = np.zeros((S.fe.N, beta.shape[1]))
    b[S.dof_idx] = beta
    payload = {"kind": kind, "size": size, "omega": w, "zeta": z,
               "b": b[S.rows_fe], "bpsi": Fb,
               "static": {"psi": psi[S.rows_fe], "Kpsi": Fb,
                          "cy": st.Fyd @ beta, "bu": beta.T @ st.Fdu}}
    return proposal("missing_mode" if kind == "resonator" else kind, loc, params, cost_, k,
                    m, "lowrank", payload)


def physical_proposals(S, placed, H, mode=None, executor=None, progress=None):
    """Screen every physical candidate, fit the best on all the data.

    Parameters
    ----------
    S : Setup
        The placed model.
    placed : Placed
        The data (a known delay removed).
    H : ndarray, shape (nf, ns, na)
        The model's response on the data lines.
    mode : (float, float), optional
        ``(omega rad/s, zeta)`` of the extra mode seen in the data; resonators are scanned
        only when given.
    executor : concurrent.futures.Executor, optional
        Runs the screen chunks and the fits.
    progress : bool, optional
        Progress bars.

    Returns
    -------
    list of dict
        Proposals of the finalists.
    """
    best, grids, exact = _screen(S, placed, H, mode, executor, progress)
    fin = _finalists(best)
    fits, statics = [], []
    base = _screen_lines(placed, H)
    for fi, pos in fin:
        fam = S.families[fi]
        c = int(fam.members[pos])
        (Gyk, Gkk, Gku), static = _single(S, placed, fam.group, c)
        statics.append(static)
        grid, extra, _ = grids[fi]
        ex = None if extra is None else (extra[0][pos], extra[1][pos])
        j = (int(best[fi][1][pos]) if (fi, pos) in exact else
             _best_size(base, fam.kind, grid[pos], ex, (Gyk, Gkk, Gku)))
        t = {"Gyk": Gyk, "Gkk": Gkk, "Gku": Gku,
             "kind": fam.kind, "base": float(fam.base[pos]), "bounds": fam.bounds[pos],
             "grid": grid[pos], "best": j}
        if extra is not None:
            t["omega"], t["zeta"] = float(extra[0][pos, j]), float(extra[1][pos, j])
        fits.append(t)
    lines = {"H0": H, "Hd": placed.Hd, "s": placed.s}
    res = map_chunks(_fit_task, fits, lines, executor, progress, "fits")
    m = {}
    for fam in S.families:
        m[fam.kind] = m.get(fam.kind, 0) + fam.size
    return [_describe(S, S.families[fi], pos, st, m[S.families[fi].kind], *r)
            for (fi, pos), st, r in zip(fin, statics, res)]
