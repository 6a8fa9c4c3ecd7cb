"""The scan of physical candidates on an FE model: a vectorised screen, then full fits.

1. **set-up** (once per model): the model's shapes on the FE DOFs, one complex-mode
   factorisation (:class:`~sdctrl.diagnosis._lowrank.Resolvent`), the static corrections
   (4.23) of unit loads on every node translation, and the transfers between sensors,
   actuators and node translations;
2. **screen**: every candidate of every family at every size of its grid, by the Woodbury
   update (rank 1 or 3) on a subset of lines, in single precision, log-magnitude logLS --
   batched over candidates, in chunks that an executor may run anywhere (the chunks and
   their order do not depend on the executor, so the ranking is identical); what every
   chunk reads (the data's lines) is shared, scattered once on a Dask client;
3. **fits**: the best candidates of each family and overall are fitted again on all the data
   with the complex logLS (3.12): a bounded 1-D minimisation of ``log(base + size)`` from the
   best grid point, or (resonators) a least-squares fit of mass, frequency and damping.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares, minimize_scalar

from sdctrl._lib.parallel import dask_client, map_chunks, share
from sdctrl._lib.threads import single_thread
from sdctrl.diagnosis._candidates import families
from sdctrl.diagnosis._global_effects import proposal
from sdctrl.diagnosis._lowrank import (
    Resolvent,
    dynamic_stiffness,
    screen_chunk,
    static_terms,
    woodbury,
)
from sdctrl.diagnosis._residual_map import complex_residual

__all__ = ["Setup", "fit_task", "physical_proposals", "setup"]

#: at most this many lines in the screen (every k-th line)
SCREEN_LINES = 200
#: candidates per screen task
CHUNK = 48
#: finalists per family, and overall
FIN_FAMILY, FIN_OVERALL = 2, 6
#: the second stage of the screen takes this share of each family (at least FINE_MIN)
FINE_FRAC, FINE_MIN = 0.12, 8
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
        Static corrections of unit loads at the candidate DOFs.
    families : list of Family
        The candidate families.
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


def setup(model, fe, placed, cand) -> Setup:
    """Place a normal-mode model with shapes on the FE model for the scan.

    Parameters
    ----------
    model : NormalModeModel
        With ``shapes`` on the FE DOFs.
    fe : FEModel
        The FE model.
    placed : Placed
        The data.
    cand : tuple
        ``(dof_idx, groups, n_elements)`` from :func:`~.candidates.candidate_groups`.

    Returns
    -------
    Setup
    """
    dof_idx, groups, n_el = cand
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
    modal_b = {k: np.einsum("cdk,dm->ckm", g.beta, phid[:, inb]) for k, g in groups.items()}
    Md = fe.M.diagonal() if sp.issparse(fe.M) else np.diag(np.asarray(fe.M))
    node_mass = [float(np.mean(Md[dof_idx][np.any(b != 0, axis=1)]))
                 for b in groups["nodes"].beta]
    fams = families(fe, groups, n_el, modal_b, w[inb], np.diag(model.Gamma)[inb], node_mass)
    return Setup(fe, model, rows_fe, T, res, np.asarray(model.cphi)[placed.rows],
                 np.asarray(model.phib)[:, placed.cols], dof_idx, phid, st, fams)


def _transfers(S, placed, s, beta):
    """``G_yk, G_kk, G_ku`` (with static terms) of load shapes ``beta`` (nc, nd, k) on ``s``."""
    nc, nd, k = beta.shape
    Fy = S.static.Fyd[placed.rows]                                     # (ns, nd)
    Fu = S.static.Fdu[:, placed.cols]                                  # (nd, na)
    Gyd = S.res.transfer(s, S.C.T, S.phid.T) + Fy                      # (nf, ns, nd)
    Gdu = S.res.transfer(s, S.phid.T, S.B) + Fu                        # (nf, nd, na)
    Bs = sp.csr_matrix(beta.transpose(1, 0, 2).reshape(nd, nc * k))
    nf, ns, na = Gyd.shape[0], Gyd.shape[1], Gdu.shape[2]
    Gyk = (Bs.T @ Gyd.transpose(2, 0, 1).reshape(nd, nf * ns)).reshape(nc, k, nf, ns)
    Gku = (Bs.T @ Gdu.transpose(1, 0, 2).reshape(nd, nf * na)).reshape(nc, k, nf, na)
    bm = (S.phid.T @ beta.transpose(1, 0, 2).reshape(nd, nc * k))      # (n, nc k)
    if S.res.lam is not None:
        Rs = 1.0 / (s[:, None] - S.res.lam[None, :])
        Lv = (bm.T @ S.res.Vt).reshape(nc, k, -1)
        Rv = (S.res.Wb @ bm).reshape(-1, nc, k).transpose(1, 0, 2)
        Gkk = np.einsum("fj,cpj,cjq->cfpq", Rs, Lv, Rv)
    else:
        Gkk = np.stack([S.res.transfer(s, bm[:, c * k:(c + 1) * k], bm[:, c * k:(c + 1) * k])
                        for c in range(nc)])
    Gkk = Gkk + np.einsum("cdp,de,ceq->cpq", beta, S.static.Fdd, beta)[:, None]
    return Gyk.transpose(0, 2, 3, 1), Gkk, Gku.transpose(0, 2, 1, 3)


def _single(S, placed, beta):
    """``G_yk, G_kk, G_ku`` of one load shape ``beta`` (nd, k) on all the lines."""
    s = placed.s
    bm = S.phid.T @ beta
    Gyk = S.res.transfer(s, S.C.T, bm) + S.static.Fyd[placed.rows] @ beta
    Gku = S.res.transfer(s, bm, S.B) + beta.T @ S.static.Fdu[:, placed.cols]
    Gkk = S.res.transfer(s, bm, bm) + beta.T @ S.static.Fdd @ beta
    return Gyk, Gkk, Gku


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
    """Two-stage screen: coarse grid for all, full grid for the best of each family.

    Returns ``{family: (best cost (nc,), best column of the full grid (nc,))}``.
    """
    step = -(-placed.freq.size // SCREEN_LINES)
    s, Hd = placed.s[::step], placed.Hd[::step]
    base = {"A": (H[::step] / Hd).astype(np.complex64), "iHd": (1.0 / Hd).astype(np.complex64),
            "s": s}
    G = {}
    grids = _grids(S, mode)
    for fi in grids:
        name = S.families[fi].group.name
        if name not in G:
            G[name] = [x.astype(np.complex64)
                       for x in _transfers(S, placed, s, S.families[fi].group.beta)]

    # on Dask the transfers are scattered once for both stages, tasks carry indices
    scattered = dask_client(executor) is not None
    shared = share(executor, {"base": base, "G": G if scattered else {}})
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
        tl = _screen_chunks(S, G, grids, sel, scattered)
        res = map_chunks(_screen_task, [t for *_, t in tl], shared, executor, progress,
                         "screen")
        for (fi, p, cols, _), sc in zip(tl, res):
            j = np.argmin(sc, axis=1)
            c = sc[np.arange(p.size), j]
            better = c < best[fi][0][p]
            best[fi][0][p[better]] = c[better]
            best[fi][1][p[better]] = cols[j[better]]
    return best, grids


def _screen_chunks(S, G, grids, sel, scattered) -> list:
    """``(family, positions, grid columns, task)`` of the screen's chunks of ``sel``; a task
    holds its candidates' transfers, or (``scattered``) their indices in the shared ones."""
    out = []
    for fi, (pos, cols) in sel.items():
        fam = S.families[fi]
        grid, extra, _ = grids[fi]
        Gyk, Gkk, Gku = G[fam.group.name]
        for a in range(0, pos.size, CHUNK):
            p = pos[a:a + CHUNK]
            m = fam.members[p]
            ex = None if extra is None else (extra[0][p][:, cols], extra[1][p][:, cols])
            t = {"kind": fam.kind, "sizes": grid[p][:, cols], "extra": ex}
            if scattered:
                t.update(group=fam.group.name, m=m)
            else:
                t.update(Gyk=Gyk[m], Gkk=Gkk[m], Gku=Gku[m])
            out.append((fi, p, cols, t))
    return out


def _screen_task(chunk, shared):
    t = {**shared["base"], **chunk}
    if "group" in chunk:                     # transfers scattered once (Dask)
        Gyk, Gkk, Gku = shared["G"][t.pop("group")]
        m = t.pop("m")
        t.update(Gyk=Gyk[m], Gkk=Gkk[m], Gku=Gku[m])
    return screen_chunk(t)


def _fit_task(t, lines):
    return fit_task({**lines, **t})


def fit_task(t) -> tuple:
    """Full fit of one finalist on all the data (complex logLS); runs on any executor.

    Parameters
    ----------
    t : dict
        ``H0``, ``Hd``, ``s``, ``Gyk``, ``Gkk``, ``Gku`` (on all lines), ``kind``,
        ``base``, ``bounds``, ``grid`` (screen sizes), ``best`` (index in it) and, for a
        resonator, ``omega`` and ``zeta`` (its screen tuning).

    Returns
    -------
    tuple
        ``(cost, size, omega, zeta)`` (NaN omega/zeta for non-resonators).
    """
    with single_thread():
        H0, Hd, s = t["H0"], t["Hd"], t["s"]
        Gyk, Gkk, Gku, kind = t["Gyk"], t["Gkk"], t["Gku"], t["kind"]

        def J(size, w=None, z=None):
            D = dynamic_stiffness(kind, s, size, None if w is None else (w, z))
            r = complex_residual(woodbury(H0, Gyk, Gkk, Gku, D), Hd)
            return r

        def c1(u):
            r = J(np.exp(u) - t["base"])
            return float(np.mean(r.real**2 + r.imag**2))

        if kind != "resonator":
            u = np.sort(np.log(t["base"] + t["grid"]))
            j = int(np.searchsorted(u, np.log(t["base"] + t["grid"][t["best"]])))
            lo = np.log(t["base"] + t["bounds"][0])
            hi = np.log(t["base"] + t["bounds"][1])
            a = u[j - 1] if j > 0 else lo
            b = u[j + 1] if j + 1 < u.size else hi
            res = minimize_scalar(c1, bounds=(a, b), method="bounded",
                                  options={"xatol": 1e-6})
            return float(res.fun), float(np.exp(res.x) - t["base"]), np.nan, np.nan
        x0 = np.log([t["grid"][t["best"]], t["omega"], t["zeta"]])

        def rv(x):
            r = J(np.exp(x[0]), np.exp(x[1]), np.exp(x[2])).reshape(-1)
            return np.r_[r.real, r.imag]

        lb = [np.log(t["bounds"][0]), x0[1] - 0.3, np.log(1e-5)]
        ub = [np.log(t["bounds"][1]), x0[1] + 0.3, np.log(0.5)]
        res = least_squares(rv, np.clip(x0, lb, ub), bounds=(lb, ub), x_scale=[1, 0.01, 1],
                            xtol=1e-10, ftol=1e-12, max_nfev=100)
        m, w, z = np.exp(res.x)
        return float(np.mean(res.fun**2) * 2), float(m), float(w), float(z)


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


def _describe(S, fam, pos, cost_, size, w, z):
    """Proposal of a fitted physical candidate (with what apply needs)."""
    g = fam.group
    c = int(fam.members[pos])
    beta = g.beta[c]
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
    Fb = beta.T @ st.Fdd @ beta
    payload = {"kind": kind, "size": size, "omega": w, "zeta": z,
               "b": b[S.rows_fe], "bpsi": Fb,
               "static": {"psi": (st.Psi @ beta)[S.rows_fe], "Kpsi": Fb,
                          "cy": st.Fyd @ beta, "bu": beta.T @ st.Fdu}}
    return proposal("missing_mode" if kind == "resonator" else kind, loc, params, cost_, k,
                    fam.size, "lowrank", payload)


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
    best, grids = _screen(S, placed, H, mode, executor, progress)
    fin = _finalists(best)
    fits = []
    for fi, pos in fin:
        fam = S.families[fi]
        c = int(fam.members[pos])
        Gyk, Gkk, Gku = _single(S, placed, fam.group.beta[c])
        grid, extra, _ = grids[fi]
        j = int(best[fi][1][pos])
        t = {"Gyk": Gyk, "Gkk": Gkk, "Gku": Gku,
             "kind": fam.kind, "base": float(fam.base[pos]), "bounds": fam.bounds[pos],
             "grid": grid[pos], "best": j}
        if extra is not None:
            t["omega"], t["zeta"] = float(extra[0][pos, j]), float(extra[1][pos, j])
        fits.append(t)
    lines = {"H0": H, "Hd": placed.Hd, "s": placed.s}
    res = map_chunks(_fit_task, fits, lines, executor, progress, "fits")
    return [_describe(S, S.families[fi], pos, *r) for (fi, pos), r in zip(fin, res)]
