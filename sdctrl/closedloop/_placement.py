"""Damper placement on a hybrid model (thesis 5.1, the use case of its reference [and2]).

For each candidate bar of an FE model, a D-strut ``F = -kv y' - kp y`` (5.3) on the bar's
relative axial extension is closed on the model (5.4); the closed-loop damping of every
mode of the band and the band-limited RMS of chosen outputs (:func:`sdctrl.rms`) are
computed, and the candidates are ranked.  Computed on a hybrid model (measured
frequencies, damping and expanded shapes), the ranking inherits the test's accuracy.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sdctrl._lib.bandappend import FixedBlock
from sdctrl._lib.parallel import chunked, map_chunks
from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import check_band, check_executor, check_int, check_scalar
from sdctrl.closedloop import _strut_chunks as chunks

__all__ = ["Candidate", "PlacementStudy", "placement_study"]

#: candidate bars per task of an executor
CHUNK = 25
#: threads of the default pool (``executor=None``) when the machine has that many CPUs
THREADS = 2


@dataclass(frozen=True, eq=False)
class Candidate:
    """One strut location of a :class:`PlacementStudy`.

    Parameters
    ----------
    bar : tuple of str
        The bar's node pair ``(node_a, node_b)``.
    frequency : ndarray
        Closed-loop frequency (Hz) of each open-loop mode of the band (tracked).
    damping : ndarray
        Closed-loop damping ratio of each of these modes.
    rms : ndarray
        Closed-loop RMS of the chosen outputs.
    reduction : ndarray
        ``1 - rms / rms_open`` per output (positive: the strut reduces the response).
    score : float
        Ranking score (see :func:`placement_study`, ``criterion``).
    """

    bar: tuple[str, str]
    frequency: np.ndarray
    damping: np.ndarray
    rms: np.ndarray
    reduction: np.ndarray
    score: float

    def __repr__(self) -> str:
        return (f"Candidate(bar={self.bar[0]}-{self.bar[1]}, score={self.score:.4g}, "
                f"mean RMS reduction={100 * np.mean(self.reduction):.1f} %, "
                f"min damping={100 * np.min(self.damping):.2f} %)")


@dataclass(frozen=True, eq=False)
class PlacementStudy:
    """Ranked result of :func:`placement_study` (best candidate first).

    Parameters
    ----------
    candidates : tuple of Candidate
        Ranked by decreasing score.
    band : tuple of float
        Frequency band (Hz).
    outputs : tuple of str
        Outputs whose RMS is compared.
    frequency : ndarray
        Open-loop frequencies (Hz) of the modes of the band.
    damping : ndarray
        Open-loop damping ratios of these modes.
    rms_open : ndarray
        Open-loop RMS of the outputs.
    kp : float
        Position gain of the strut (N/m).
    kv : float
        Velocity gain of the strut (N s/m).
    criterion : str
        Ranking criterion.
    skipped : tuple
        ``(bar, reason)`` of candidates that could not be evaluated.
    """

    candidates: tuple
    band: tuple
    outputs: tuple
    frequency: np.ndarray
    damping: np.ndarray
    rms_open: np.ndarray
    kp: float
    kv: float
    criterion: str
    skipped: tuple = ()

    def __repr__(self) -> str:
        best = f", best={self.best.bar[0]}-{self.best.bar[1]}" if self.candidates else ""
        return (f"PlacementStudy({len(self.candidates)} candidates{best}, "
                f"band={self.band[0]:g}-{self.band[1]:g} Hz, {len(self.outputs)} outputs, "
                f"kv={self.kv:g}, kp={self.kp:g}, criterion={self.criterion!r}, "
                f"{len(self.skipped)} skipped)")

    def _repr_markdown_(self) -> str:
        return self.table()

    @property
    def best(self) -> Candidate:
        """The best candidate."""
        return self.candidates[0]

    def table(self, k: int = 10) -> str:
        """Markdown table of the ``k`` best candidates.

        Parameters
        ----------
        k : int
            Number of rows.

        Returns
        -------
        str
        """
        k = check_int(k, "k", minimum=1)
        head = ("| rank | bar | mean RMS reduction | min damping in band | score |\n"
                "|---:|---|---:|---:|---:|\n")
        rows = [f"| {i + 1} | {c.bar[0]}-{c.bar[1]} | {100 * np.mean(c.reduction):.1f} % | "
                f"{100 * np.min(c.damping):.2f} % | {c.score:.4g} |"
                for i, c in enumerate(self.candidates[:k])]
        return head + "\n".join(rows)


def _track(p_open: np.ndarray, p_closed: np.ndarray) -> np.ndarray:
    """Closed-loop pole paired with each open-loop pole (minimal total distance)."""
    from scipy.optimize import linear_sum_assignment

    d = np.abs(p_open[:, None] - p_closed[None, :])
    rows, cols = linear_sum_assignment(d)
    out = np.empty(p_open.size, complex)
    out[rows] = p_closed[cols]
    return out


@dataclass(frozen=True, eq=False)
class _Loop:
    """What every candidate's evaluation reads (shared by the tasks of an executor, scattered
    once on a Dask client).

    ``reduced`` is the model without its shapes (the reduced model every candidate changes
    by a low-rank term); ``shapes`` (N, n) are read at a strut's few DOFs only; ``static``
    holds the :class:`~sdctrl.closedloop._strut_chunks.Statics` of a hybrid model whose
    struts get their own static correction mode (:meth:`HybridModel.with_feedback`), else
    None; ``fixed`` is the realisation (a :class:`~sdctrl._lib.bandappend.FixedBlock`) at
    the chosen outputs of what a strut on the modal coordinates leaves unchanged -- the
    model's ``E``, ``F`` and residual dynamics (a tested hybrid's terms at the tested I/O)
    -- appended to every closed loop; None when the reduced model is its second-order part
    only (2.15).
    """

    reduced: object
    shapes: np.ndarray
    fe: object
    static: chunks.Statics | None
    band: tuple
    out_idx: list
    psd: object
    kp: float
    kv: float
    criterion: str
    p_open: np.ndarray
    fixed: FixedBlock | None = None
    rms_open: np.ndarray | None = None


def _open_rms(loop) -> np.ndarray:
    """RMS of the chosen outputs in open loop (as matrices, like the closed loops)."""
    from sdctrl._lib.statespace import second_order

    m = loop.reduced
    A, B, C, _ = second_order(m.Omega, m.Gamma, m.phib, m.cphi[loop.out_idx])
    return _band_rms(loop, A, B, C, None)


def _fixed_part(model, out_idx, band, psd):
    """The block of the model's realisation (2.15)-(2.24) beyond its ``2 n`` modal states
    at the outputs ``out_idx`` (:func:`sdctrl.closedloop._loops.appended_block`); None
    without ``E``, ``F`` or residual dynamics."""
    from sdctrl.closedloop._loops import appended_block
    from sdctrl.modal._normal_realisation import realisation_matrices

    if model.E is None and model.F is None and (model.residual is None
                                                or not model.residual.m):
        return None
    A, B, C, D, _ = realisation_matrices(model, 0, None, False)
    k = 2 * model.n
    return appended_block(A[k:, k:], B[k:], C[out_idx, k:], D[out_idx], band, psd)


def _reduced(model):
    """The model's reduced part, without its (N, n) shapes: what a candidate changes."""
    from sdctrl.modal._normal_model import NormalModeModel
    from sdctrl._lib.statespace import default_omega_f

    return NormalModeModel(model.Omega, model.Gamma, model.cphi, model.phib, E=model.E,
                           sensors=model.sensors, actuators=model.actuators,
                           omega_c=model.omega_c, F=model.F, residual=model.residual,
                           omega_f=default_omega_f(model) if model.F is not None else None)


def _evaluate(bars, loop) -> list:
    """``(bar, Candidate or None, reason or None)`` of each bar of a chunk (5.4), as arrays.

    Single-threaded BLAS: the reduced matrices are small, and threaded BLAS on them is many
    times slower on a loaded machine (and oversubscribes an executor's workers).  The
    chunk's struts are compact, the static correction modes of all of them are computed
    at once, the closed-loop poles of all candidates in one stacked eigenvalue call, no
    model or StateSpace per candidate; what the strut leaves unchanged (``E``, ``F``,
    residual dynamics) is appended to each closed loop (:attr:`_Loop.fixed`).
    """
    from sdctrl.fe._static import strut_entries

    with single_thread():
        struts, out = {}, {}
        for i, bar in enumerate(bars):
            try:
                struts[i] = strut_entries(loop.fe, *bar)
            except ValueError as exc:
                out[i] = (tuple(bar), None, str(exc))
        keys = list(struts)
        exts = (chunks.static_modes(loop, [struts[i] for i in keys])
                if loop.static is not None and keys else [None] * len(keys))
        mats = [chunks.closed_matrices(loop, struts[i], e) for i, e in zip(keys, exts)]
        lams = chunks.stacked_eigvals([A for A, _, _ in mats])
        for i, (A, B, C), lam in zip(keys, mats, lams):
            out[i] = _scored(bars[i], loop, chunks.upper(lam),
                             lambda A=A, B=B, C=C, lam=lam: _band_rms(loop, A, B, C, lam))
        return [out[i] for i in range(len(bars))]


def _band_rms(loop, A, B, C, lam) -> np.ndarray:
    """RMS of the chosen outputs of the modal loop ``(A, B, C)`` (eigenvalues ``lam`` or
    None) with the model's fixed part appended."""
    from sdctrl.closedloop._loops import rms_appended, rms_of_matrices

    if loop.fixed is not None:
        return rms_appended(A, B, C, loop.fixed, lam)
    return rms_of_matrices(A, B, C, np.zeros((C.shape[0], B.shape[1])), loop.band, loop.psd,
                           lam=lam)


def _scored(bar, loop, poles, measure) -> tuple:
    """``(bar, Candidate or None, reason or None)`` from the closed loop's poles and RMS."""
    p = _track(loop.p_open, poles)
    freq = np.abs(p) / (2 * np.pi)
    damp = -p.real / np.abs(p)
    try:
        r = measure()
    except ValueError as exc:
        return (tuple(bar), None,
                f"closed loop with kv={loop.kv:g}, kp={loop.kp:g}: {exc}")
    with np.errstate(invalid="ignore", divide="ignore"):
        red = np.where(loop.rms_open > 0, 1 - r / loop.rms_open, 0.0)
    score = float(np.mean(red)) if loop.criterion == "rms" else float(np.min(damp))
    return tuple(bar), Candidate(tuple(bar), freq, damp, r, red, score), None


def placement_study(model, fe, band, kv, kp=0.0, candidates=None, outputs=None, psd=1.0,
                    criterion: str = "rms", progress: bool | None = None,
                    executor=None) -> PlacementStudy:
    """Rank candidate bars for a D-strut by closed-loop damping and RMS reduction.

    For each bar ``(a, b)``: ``s = fe.strut(a, b)``, the loop ``F = -kv s^T q' - kp s^T q``
    is closed on ``model`` (:meth:`NormalModeModel.with_feedback`, 5.4), each open-loop
    mode of ``band`` is tracked to its closed-loop pole (frequency, damping), and the RMS
    of ``outputs`` for white noise of PSD ``psd`` on every model input over ``band``
    (:func:`sdctrl.rms`, exact band integral) is compared with the open loop.

    Each candidate is a low-rank change of the reduced model (4.17), (5.4): the strut's
    modal vector ``phi^T s`` is read from the shapes at the strut's own DOFs (O(n)), the
    reduced model is closed and its poles and RMS computed -- nothing of size N is copied or
    multiplied by ``n x n``.  On a hybrid model that carries its FE model
    (:attr:`HybridModel.static_ready`) each strut also gets its own static correction mode
    (4.23)-(4.24), as :meth:`HybridModel.with_feedback` does (the local flexibility of the
    bar, thesis 5.1.2): one sparse solve with the FE model's cached factorisation per
    candidate.  The results equal ``model.with_feedback(s, s.T, kp, kv)`` per bar.

    Parameters
    ----------
    model : NormalModeModel
        Hybrid (or FE-derived) model whose ``shapes`` are on ``fe.dofs``; its inputs are
        the disturbances.
    fe : FEModel
        Gives the node coordinates of the bars.
    band : (float, float)
        Frequency band (Hz) of the modes and of the RMS.
    kv : float
        Velocity gain of the strut (N s/m).
    kp : float
        Position gain (N/m), e.g. negative for a strut softer than the bar it replaces.
    candidates : sequence of (str, str), optional
        Bars to try; default every element node pair of ``fe`` (``fe.elements``).
    outputs : sequence of str, optional
        Output labels (``model.sensors``) whose RMS is reduced; default all.
    psd : float or array_like
        One-sided PSD of the disturbance inputs (units^2/Hz), scalar or one per input.
    criterion : {"rms", "damping"}
        Score: mean relative RMS reduction over the outputs, or the smallest closed-loop
        damping ratio of the band's modes.
    progress : bool or None
        Progress bar over the candidates; None (default) follows ``sdctrl.config.progress``
        (shown only on a terminal or in a notebook).
    executor : concurrent.futures.Executor, optional
        Evaluates the candidates in chunks of ``CHUNK`` bars (threads, processes, a Dask
        client's ``get_executor()``: the model and the FE model are then scattered to the
        workers once); the result is identical to the serial run's.  None (default): a
        pool of ``THREADS`` (2) threads with one BLAS thread each when the machine has
        that many CPUs and there are two chunks or more, else serially -- the same
        result either way.

    Returns
    -------
    PlacementStudy
        Candidates ranked best first, the open-loop reference, skipped candidates.

    Raises
    ------
    TypeError
        Wrong model types.
    ValueError
        No shapes on ``fe.dofs``, unknown outputs, bad band, no mode in the band, no
        candidate.
    """
    from sdctrl.fe import FEModel
    from sdctrl.modal._normal_model import NormalModeModel

    if not isinstance(model, NormalModeModel):
        raise TypeError(f"model must be a NormalModeModel, got {type(model).__name__}")
    if not isinstance(fe, FEModel):
        raise TypeError(f"fe must be an FEModel, got {type(fe).__name__}")
    if model.shapes is None or model.shapes.shape[0] != fe.N:
        raise ValueError(f"model must have shapes on the DOFs of fe (N={fe.N})")
    lo, hi = check_band(band)
    if criterion not in ("rms", "damping"):
        raise ValueError(f"criterion must be 'rms' or 'damping', got {criterion!r}")
    kv = check_scalar(kv, "kv", nonneg=True)
    kp = check_scalar(kp, "kp")
    sensors = list(model.sensors)
    out_idx = [sensors.index(o) for o in _outputs(outputs, sensors)]
    candidates = _candidates(candidates, fe)
    executor = check_executor(executor)
    p_all = model.poles
    f_all = np.abs(p_all) / (2 * np.pi)
    p_open = p_all[(f_all >= lo) & (f_all <= hi) & (p_all.imag > 0)]
    if p_open.size == 0:
        raise ValueError(f"band: no mode of the model between {lo:g} and {hi:g} Hz")
    # one BLAS thread for the set-up too (the open loop's band integrals: expm, logm of the
    # reduced model), as for the chunks: threaded BLAS on these small matrices took ~3x the
    # CPU time on the loaded 2-core machine (issue 27)
    with single_thread():
        static = chunks.statics(model) if getattr(model, "static_ready", False) else None
        reduced = _reduced(model)
        loop = _Loop(reduced, np.asarray(model.shapes), fe, static, (lo, hi), out_idx, psd,
                     kp, kv, criterion, p_open, _fixed_part(reduced, out_idx, (lo, hi), psd))
        loop = replace(loop, rms_open=_open_rms(loop))
        done = _sweep(loop, chunked(candidates, CHUNK), executor, progress)
    results = [c for chunk in done for _, c, _ in chunk if c is not None]
    skipped = [(bar, why) for chunk in done for bar, c, why in chunk if c is None]
    rms_open = loop.rms_open
    if not results:
        raise ValueError("candidates: none could be evaluated "
                         f"({skipped[0][1] if skipped else 'empty'})")
    results.sort(key=lambda c: -c.score)
    return PlacementStudy(tuple(results), (lo, hi), tuple(sensors[i] for i in out_idx),
                          np.abs(p_open) / (2 * np.pi), -p_open.real / np.abs(p_open),
                          rms_open, kp, kv, criterion, tuple(skipped))


def _sweep(loop, parts, executor, progress) -> list:
    """The chunks' results, on ``executor``, else on a pool of :data:`THREADS` threads.

    The default pool needs two chunks and as many CPUs; its workers share the model, the
    FE model and its factorisation (built here first, not by two workers at once), and the
    whole sweep runs under one BLAS thread limit (the limit is process-wide: a worker
    leaving its chunk's limit must not lift the other's).  Each chunk is evaluated by the
    same function on the same numbers as in a serial run, so the results are identical.
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    pool = None
    if executor is None and len(parts) > 1 and (os.cpu_count() or 1) >= THREADS > 1:
        pool = ThreadPoolExecutor(THREADS)
        if loop.static is not None:
            loop.static.fe.factorise()
    try:
        with single_thread():
            return map_chunks(_evaluate, parts, loop, executor or pool, progress,
                              "D-strut placement", "chunk")
    finally:
        if pool is not None:
            pool.shutdown()


def _outputs(outputs, sensors) -> list[str]:
    """Output labels (default: all sensors)."""
    if outputs is None:
        return list(sensors)
    outs = [outputs] if isinstance(outputs, str) else outputs
    if not isinstance(outs, list | tuple) or not all(isinstance(o, str) for o in outs):
        raise TypeError(f"outputs must be a sensor label or a sequence of them, got "
                        f"{outputs!r:.60}")
    if not outs:
        raise ValueError("outputs must name at least one sensor")
    for o in outs:
        if o not in sensors:
            raise ValueError(f"outputs: unknown output {o!r}, expected model sensors")
    return list(outs)


def _candidates(candidates, fe) -> list[tuple[str, str]]:
    """Node pairs to try (default: every element of ``fe``)."""
    if candidates is None:
        if not fe.elements:
            raise ValueError("candidates: fe has no elements; give node pairs")
        return list(fe.elements)
    if isinstance(candidates, str | bytes) or not isinstance(candidates, list | tuple):
        raise TypeError(f"candidates must be a sequence of (node_a, node_b) pairs, got "
                        f"{type(candidates).__name__}")
    out = []
    for c in candidates:
        if isinstance(c, str) or not isinstance(c, list | tuple) or len(c) != 2 or not all(
                isinstance(x, str) for x in c):
            raise ValueError(f"candidates must be (node_a, node_b) pairs of node names, got "
                             f"{c!r:.60}")
        out.append((c[0], c[1]))
    if not out:
        raise ValueError("candidates must be a non-empty sequence of (node_a, node_b)")
    return out
