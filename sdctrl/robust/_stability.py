"""Robust stability of the closed loop over the structured uncertainty of section 5.2 (5.5).

The Delta channels of the closed loop ``u = -K y`` read and drive a few signals (modal
displacements and velocities, modal forces, sensors, actuators; :meth:`UncertainModel.compact_lft`),
so their response is ``M(s) = L Mc(s) R`` with a small core ``Mc``.  The margin is bracketed by

- a lower bound: the smallest destabilising real Delta found
  (:func:`sdctrl.robust.mu._lower.destabilise`, the real-parameter form of the mu power iteration),
  returned so that it can be checked;
- an upper bound of the mixed real mu (real parameters regularised by a small complex part
  ``eps``) by D-G scalings (:mod:`sdctrl.robust.mu._upper`), certified on intervals covering the
  whole frequency axis (:mod:`sdctrl.robust.mu._frequency_sweep`): the guaranteed margin holds
  between grid points too.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from sdctrl._lib.progress import progress_bar
from sdctrl._lib.statespace import ss_frf
from sdctrl._lib.threads import single_thread
from sdctrl._lib.validate import check_executor, check_freq, check_int, check_scalar, check_seed
from sdctrl._lib.signals import as_statespace
from sdctrl.robust.mu._upper import BlockStructure, Factored, certify_dg, dg_upper, mu_upper
from sdctrl.robust.mu._lower import destabilise, perturbed_A
from sdctrl.robust.mu._frequency_sweep import FactoredSystem, cheap_bounds, cover

__all__ = [
    "RobustResult",
    "certify_dg",
    "closed_loop_lft",
    "mu_upper",
    "robust_stability",
    "worst_case_gain",
]


@dataclass(frozen=True, eq=False)
class RobustResult:
    """Result of :func:`robust_stability`.

    Parameters
    ----------
    margin : float
        Guaranteed margin, 1/(upper bound of mu over all frequencies): the loop is stable for
        every Delta up to ``margin`` times the bounds.
    margin_lower : float
        Size (max-norm of the normalised parameters) of the smallest destabilising Delta found.
    stable : bool
        Nominal closed-loop stability.
    frequency : float
        Critical frequency (Hz): where the upper bound of mu is largest.
    worst_delta : ndarray
        The destabilising normalised parameters found (size ``margin_lower``, one per block):
        ``um.perturbed(worst_delta)`` closed with the controller has a pole on or right of the
        axis (also :attr:`delta`).
    mu_freq : ndarray
        Frequencies (Hz) where the upper bound was computed.
    mu : ndarray
        Upper bound of mu at ``mu_freq``.
    info : dict
        Diagnostics: ``mu_lower``, ``mu_upper``, ``crossing_frequency`` (Hz, of ``delta``),
        ``n_freq``, ``n_dg`` (frequencies needing the D-G optimisation), ``eps``, ``seconds``.
    certified : bool
        True when the certified intervals of the upper bound cover every frequency, so that
        ``margin`` holds between the computed frequencies too (always True without
        uncertain parameters, False for an unstable nominal loop).
    """

    margin: float
    margin_lower: float
    stable: bool
    frequency: float
    worst_delta: np.ndarray
    mu_freq: np.ndarray
    mu: np.ndarray
    info: dict
    certified: bool = False

    @property
    def delta(self) -> np.ndarray:
        """The destabilising normalised parameters found (:attr:`worst_delta`)."""
        return self.worst_delta

    def __repr__(self) -> str:
        return (f"RobustResult(margin={self.margin:.4g}, margin_lower={self.margin_lower:.4g}, "
                f"stable={self.stable}, frequency={self.frequency:.4g} Hz, "
                f"{len(self.worst_delta)} blocks, {len(self.mu_freq)} frequencies)")


def _controller(um, controller):
    """Validated ``(Ak, Bk, Ck, Dk)`` of a continuous-time controller from outputs to inputs."""
    if not hasattr(um, "compact_lft"):
        raise TypeError(f"um must be an UncertainModel (sdctrl.robust._uncertainty.uncertain), "
                        f"got {type(um).__name__}")
    controller = as_statespace(controller, "controller")
    m = um.model
    if (controller.ninputs, controller.noutputs) != (m.ns, m.na):
        raise ValueError(f"controller must map the model's {m.ns} outputs to its {m.na} inputs, "
                         f"got a {controller.ninputs}-input {controller.noutputs}-output system")
    nom = um.nominal
    for got, want, side in ((controller.input_labels, nom.output_labels, "inputs"),
                            (controller.output_labels, nom.input_labels, "outputs")):
        if set(got) & set(want) and list(got) != list(want):
            raise ValueError(f"controller {side} are named {list(got)} but must be the model's "
                             f"{'outputs' if side == 'inputs' else 'inputs'} {list(want)} in "
                             "that order")
    mats = [np.asarray(x, float).reshape(s) for x, s in zip(
        (controller.A, controller.B, controller.C, controller.D),
        ((controller.nstates,) * 2, (controller.nstates, m.ns), (m.na, controller.nstates),
         (m.na, m.ns)))]
    if not all(np.all(np.isfinite(x)) for x in mats):
        raise ValueError("controller has non-finite (NaN or inf) gains")
    return mats


def _closed_loop(um, controller, perf: bool = False):
    """Closed-loop Delta channels as a :class:`FactoredSystem` (and the disturbance channels
    ``d -> y`` with ``u = -K y + d`` when ``perf``)."""
    Ak, Bk, Ck, Dk = _controller(um, controller)
    c = um.compact_lft()
    na, ns, nk, nx = c.B.shape[1], c.C.shape[0], Ak.shape[0], c.A.shape[0]
    try:
        F = np.linalg.inv(np.eye(na) + Dk @ c.D)
    except np.linalg.LinAlgError:
        raise ValueError("the loop is algebraically singular (I + K(inf) E is singular)") from None
    Ux = -F @ np.hstack([Dk @ c.C, Ck])          # u = Ux X + Uv v + F d
    Uv = -F @ Dk @ c.Dyv
    Yx = np.hstack([c.C, np.zeros((ns, nk))]) + c.D @ Ux
    Yv = c.Dyv + c.D @ Uv
    Bu = np.vstack([c.B, np.zeros((nk, na))])
    By = np.vstack([np.zeros((nx, ns)), Bk])
    A = np.block([[c.A, np.zeros((nx, nk))], [np.zeros((nk, nx)), Ak]]) + Bu @ Ux + By @ Yx
    Bc = np.vstack([c.Bv, np.zeros((nk, c.Bv.shape[1]))]) + Bu @ Uv + By @ Yv
    Cc = np.hstack([c.Cv, np.zeros((c.Cv.shape[0], nk))]) + c.Dvu @ Ux
    fs = FactoredSystem(A, Bc, Cc, c.Dvu @ Uv, c.L, c.R)
    if not perf:
        return fs, c.reps
    Bd, Dqd = Bu @ F + By @ c.D @ F, c.Dvu @ F
    return fs, c.reps, (Bd, Dqd, Yx, Yv, c.D @ F)


def closed_loop_lft(um, controller):
    """Closed-loop matrices ``(A, Bw, Cz, Dzw)`` of the Delta channels with ``u = -K y``.

    Parameters
    ----------
    um : UncertainModel
        Uncertain model.
    controller : control.StateSpace
        Controller from the model's outputs to its inputs.

    Returns
    -------
    tuple of ndarray
        ``M(s) = Cz (sI - A)^-1 Bw + Dzw`` is the response seen by ``Delta`` (channel order).
    """
    fs, _ = _closed_loop(um, controller)
    return fs.A, fs.Bc @ fs.R, fs.L @ fs.Cc, fs.L @ fs.Dc @ fs.R


def _start_frequencies(A, freq, w_cross):
    """Closed-loop modal frequencies and their half-power neighbourhoods, a log grid, extras."""
    lam = np.linalg.eigvals(A)
    wn = np.abs(lam)
    wn = wn[wn > 0]
    lo, hi = (wn.min() / 10, wn.max() * 10) if wn.size else (1e-2, 1e2)
    osc = lam[lam.imag > 0]
    near = (osc.imag[:, None] + (-osc.real)[:, None] * np.array([-2, -1, 0, 1, 2])[None]).ravel()
    pts = [[0.0], np.geomspace(lo, hi, 24), wn, near[near > 0]]
    if freq is not None:
        pts.append(2 * np.pi * np.asarray(freq, float).ravel())
    if np.isfinite(w_cross):
        pts.append([w_cross])
    return np.unique(np.concatenate([np.asarray(p, float) for p in pts]))


def _check_options(eps, rtol, n_directions, freq):
    eps = check_scalar(eps, "eps", positive=True)
    if not eps <= 1:
        raise ValueError(f"eps must be a small positive regularisation in (0, 1] (e.g. 0.005), "
                         f"got {eps:g}")
    rtol = check_scalar(rtol, "rtol", positive=True)
    if not rtol < 1:
        raise ValueError(f"rtol must be in (0, 1), got {rtol:g}")
    n_directions = check_int(n_directions, "n_directions", minimum=0, maximum=10**5)
    return eps, rtol, n_directions, None if freq is None else check_freq(freq, "freq")


def robust_stability(um, controller, freq=None, eps: float = 0.005, n_directions: int = 20,
                     seed: int = 0, rtol: float = 0.005, progress: bool | None = None,
                     executor=None) -> RobustResult:
    """Robust stability margin of ``u = -K y`` over the structured uncertainty (5.5).

    Parameters
    ----------
    um : UncertainModel
        Uncertain model (see :func:`sdctrl.robust._uncertainty.uncertain`).
    controller : control.StateSpace
        Continuous-time controller from the model's outputs to its inputs, closed as
        ``u = -K y`` (python-control's negative feedback).
    freq : array_like, optional
        Extra frequencies (Hz) where the upper bound is computed first; the certified intervals
        cover all frequencies whatever this grid.
    eps : float
        Complex regularisation of the real parameters (``delta + eps delta_c``, conservatism
        about ``1 + eps``); in ``(0, 1]``.
    n_directions : int
        Random sign patterns tried by the lower-bound search (besides one per pole; 0 allowed).
    seed : int or Generator
        Random seed of the lower-bound search (None: not reproducible).
    rtol : float
        Relative slack between the largest upper bound computed and the certified level.
    progress : bool, optional
        Progress bar over frequencies (default: :mod:`sdctrl.config` policy).
    executor : concurrent.futures.Executor, optional
        Runs the frequencies of each round in parallel; results are identical to the serial run.

    Returns
    -------
    RobustResult
    """
    t0 = time.perf_counter()
    eps, rtol, n_directions, freq = _check_options(eps, rtol, n_directions, freq)
    seed, executor = check_seed(seed), check_executor(executor)
    fs, reps = _closed_loop(um, controller)
    nb = len(reps)
    stable = bool(np.all(np.linalg.eigvals(fs.A).real < 0))
    info = {"eps": eps}
    if not stable:
        warnings.warn("nominal closed loop is unstable: robust margin is 0", stacklevel=2)
        return RobustResult(0.0, 0.0, False, 0.0, np.zeros(nb), np.zeros(0), np.zeros(0), info)
    if nb == 0:
        return RobustResult(np.inf, np.inf, True, np.nan, np.zeros(0), np.zeros(0), np.zeros(0),
                            info, certified=True)
    with single_thread(), progress_bar(desc="mu upper bound", unit="freq",
                                            enabled=progress) as bar:
        low = destabilise(fs, reps, n_random=n_directions, seed=seed)
        mu_lo = 1.0 / low.alpha
        st = BlockStructure.real_repeated(reps, eps)
        fsa = fs.augmented(eps)
        w0 = _start_frequencies(fs.A, freq, low.frequency)
        if np.isfinite(low.alpha):
            w_pk = low.frequency
        else:
            w_pk = float(w0[np.argmax(cheap_bounds(fsa.core(w0), fsa.L, fsa.R, st)[0])])
        b_pk, x_pk = dg_upper(Factored(fsa.core(w_pk)[0], fsa.L, fsa.R), st)
        res = cover(fsa, st, w0, max(b_pk, mu_lo) * (1 + rtol), rtol, executor, bar,
                    warm=(w_pk, x_pk))
        if res.level * low.alpha > 1 + 5 * rtol:      # refine the lower bound at the peak
            better = destabilise(fs, reps, n_random=4 * n_directions,
                                 seed=seed + 1 if isinstance(seed, int) else seed,
                                 near=res.peak_w)
            if better.alpha < low.alpha:
                low = better
    margin = 1.0 / res.level
    if margin > low.alpha * (1 + 1e-9):
        warnings.warn(f"certified margin {margin:.6g} above a destabilising perturbation of size "
                      f"{low.alpha:.6g}: numerical trouble; margin set to the latter",
                      stacklevel=2)
        margin = low.alpha
    if not res.certified:
        warnings.warn("the frequency axis could not be covered by certified intervals: the "
                      "margin holds at the computed frequencies only", stacklevel=2)
    info.update(mu_lower=1.0 / low.alpha, mu_upper=res.level,
                crossing_frequency=low.frequency / (2 * np.pi), n_freq=len(res.w),
                n_dg=res.n_dg, intervals=len(res.intervals), seconds=time.perf_counter() - t0)
    return RobustResult(float(margin), float(low.alpha), stable, res.peak_w / (2 * np.pi),
                        low.delta, res.w / (2 * np.pi), res.bound, info,
                        certified=bool(res.certified))


def _sample_gain(fs, chan_block, perf, out, inp, w, d):
    """``|y_out / d_inp|`` over ``w`` for the block parameters ``d`` (exact LFT closure)."""
    Bd, Dqd, Yx, Yv, Dyd = perf
    Psi = fs.R @ (d[chan_block][:, None] * fs.L)
    X = np.linalg.solve(np.eye(Psi.shape[0]) - Psi @ fs.Dc, Psi)
    A = perturbed_A(fs, chan_block, d)
    B = Bd[:, [inp]] + fs.Bc @ X @ Dqd[:, [inp]]
    C = Yx[[out]] + Yv[[out]] @ X @ fs.Cc
    D = Dyd[[out]][:, [inp]] + Yv[[out]] @ X @ Dqd[:, [inp]]
    return np.abs(ss_frf(A, B, C, D, w)[:, 0, 0])


def worst_case_gain(um, controller, output: int = 0, input: int = 0, freq=None,
                    n_samples: int = 200, seed: int = 0, executor=None,
                    progress: bool | None = None) -> dict:
    """Worst-case closed-loop gain from a plant input disturbance to a plant output over Delta.

    The disturbance ``d`` is added to the plant input (``u = -K y + d``); the gain ``|y/d|`` is
    maximised over the box vertices (all of them up to 256, else 256 random ones) and random
    samples of the normalised parameters (a lower estimate of the worst case).

    Parameters
    ----------
    um : UncertainModel
        Uncertain model.
    controller : control.StateSpace
        Continuous-time controller closed as ``u = -K y``.
    output : int
        Plant output index.
    input : int
        Plant input index.
    freq : array_like, optional
        Frequencies (Hz); default a log grid around the model's modes.
    n_samples : int
        Random samples (besides vertices; 0 allowed).
    seed : int
        Random seed.
    executor : concurrent.futures.Executor, optional
        Evaluates the samples in parallel (results identical to the serial run).
    progress : bool, optional
        Progress bar over samples (default: :mod:`sdctrl.config` policy).

    Returns
    -------
    dict
        ``freq``, ``nominal`` gain, ``worst`` gain per frequency, ``peak``, ``delta`` (the
        normalised parameters of the peak; also under ``worst_delta``).
    """
    fs, reps, perf = _closed_loop(um, controller, perf=True)
    m = um.model
    for name, val, n in (("output", output, m.ns), ("input", input, m.na)):
        if isinstance(val, bool) or not isinstance(val, int | np.integer) or not 0 <= val < n:
            raise ValueError(f"{name} must be an index in [0, {n}), got {val!r}")
    n_samples = check_int(n_samples, "n_samples", minimum=0, maximum=10**6)
    seed, executor = check_seed(seed), check_executor(executor)
    if freq is None:
        f0 = np.asarray(m.frequency, float)
        f0 = f0[f0 > 0] if np.any(f0 > 0) else np.array([1.0])
        freq = np.geomspace(f0.min() / 5, f0.max() * 5, 400)
    freq = check_freq(freq, "freq")
    w = 2 * np.pi * freq
    nb = len(reps)
    chan_block = np.repeat(np.arange(nb), reps)
    rng = np.random.default_rng(seed)
    verts = (np.array(np.meshgrid(*[[-1.0, 1.0]] * nb, indexing="ij")).reshape(nb, -1).T
             if 2 ** nb <= 256 else rng.choice([-1.0, 1.0], size=(256, nb)))
    ds = np.vstack([np.zeros((1, nb)), verts, rng.uniform(-1, 1, (n_samples, nb))])
    run = executor.map if executor is not None else map
    args = [(fs, chan_block, perf, int(output), int(input), w, d) for d in ds]
    gains = []
    with single_thread(), progress_bar(total=len(ds), desc="worst-case gain", unit="sample",
                                       enabled=progress) as bar:
        for H in run(_sample_gain, *zip(*args)):
            gains.append(H)
            bar.update()
    gains = np.array(gains)
    k = int(np.argmax(gains.max(axis=1)))
    return {"freq": np.asarray(freq, float), "nominal": gains[0], "worst": gains.max(axis=0),
            "peak": float(gains[k].max()), "delta": ds[k], "worst_delta": ds[k]}
