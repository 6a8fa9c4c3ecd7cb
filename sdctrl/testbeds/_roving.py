"""Simulated roving-hammer surveys of the family's structures: :func:`survey`.

What a real modal survey is: a few accelerometers stay in place while the hammer roves over
many hit points; one hit point is at an accelerometer (the single driving point).  Each hit
point is hit a few times; each hit is a short force pulse measured by the hammer's load cell,
the records are taken with a force window and an exponential window and the FRF column of
the hit point is the H1 estimate over its hits (:func:`sdctrl.impact_frf`).

The records are exact, built in the frequency domain: the windowed impulse response
``h(t) exp(-t/tau)`` has the FRF ``H(j w + 1/tau)`` (every pole shifted by ``-1/tau``), which
the complex modes of the full damped FE model give exactly (all ``2N`` state-space modes,
the symmetric first-order form ``U z' + V z = [b; 0] u`` with ``U = [[C, M], [M, 0]]``,
``V = [[K, 0], [0, -M]]``, the thesis's complex modes (2.8)-(2.10)).  Each windowed response
record is the inverse DFT of ``H(j w_k + 1/tau) F_k`` (``F_k`` the DFT of the windowed force),
"unwindowed" into the raw record, and noise is added to the raw records: the estimator then
sees what it would see in a test, with no leakage.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sdctrl._lib.validate import check_band, check_int, check_scalar, check_seed

__all__ = ["Survey", "survey"]

#: value of the exponential window at the record's end
EXPONENTIAL = 0.01
#: amplitudes (shares of a mode's largest) closer than this are equal when sensors are placed
TIE = 1e-5
#: fraction of each record kept on the force (the pulse sits in its first percent)
FORCE_WINDOW = 0.05


@dataclass(frozen=True, eq=False)
class Survey:
    """A simulated roving-hammer survey and the truth it was made from.

    Parameters
    ----------
    frf : FRF
        Accelerances (``quantity="acceleration"``) of the fixed accelerometers (sensors) for
        every hit point (actuators, DOF labels), lines ``df .. 2 fmax`` Hz, coherence per
        line and ``exponential_tau``; the driving point is the collocated pair (same label).
    band : (float, float)
        The band to analyse (Hz).
    poles : ndarray (n,)
        Exact poles (rad/s, Im > 0) of the true structure's modes in the band.
    shapes : ndarray (n_hits, n)
        Exact complex mode shapes ``psi`` (2.10) of those modes at the hit points.
    sensor_shapes : ndarray (n_sensors, n)
        The same at the accelerometers.
    driving_point : str
        Label of the hit point that is also an accelerometer.
    """

    frf: object
    band: tuple
    poles: np.ndarray
    shapes: np.ndarray
    sensor_shapes: np.ndarray
    driving_point: str

    def __repr__(self) -> str:
        f = self.frf
        return (f"Survey({len(f.sensors)} accelerometers x {len(f.actuators)} hit points, "
                f"{f.freq.size} lines, {self.poles.size} modes in {self.band[0]:g}-"
                f"{self.band[1]:g} Hz, driving point {self.driving_point!r})")


@dataclass(frozen=True, eq=False)
class _Plan:
    """Sampling and hammer of a survey: ``n`` samples at ``fs`` Hz, pulse width (s)."""

    fs: float
    n: int
    pulse: float
    averages: int
    noise: float
    drift: float = 0.0

    @property
    def tau(self) -> float:
        return -((self.n - 1) / self.fs) / np.log(EXPONENTIAL)


def survey(structure, n_hits: int | None = None, sensors: int = 3, noise: float = 0.01,
           seed: int | None = None, band=None, lines: int = 1600, averages: int = 3,
           drift: float = 0.0) -> Survey:
    """Simulate a roving-hammer survey of a test structure of the family.

    Three accelerometers (by default) are placed among the structure's sensor DOFs by a
    greedy rule: each added one maximises the smallest (over the band's modes) share of a
    mode's largest amplitude seen by the accelerometers; the first is the driving point.
    The hit points are translational DOFs spread over the structure: nodes ordered by
    farthest-point sampling from the driving point, and at each node its directions in
    decreasing modal motion (in-band modes), one direction per node per round.  Each hit
    point is hit ``averages`` times with half-sine pulses (width ``2/(3 fmax)`` +-15%,
    size +-20%: the force spectrum is 4 dB down at ``fmax``, 22 dB at ``2 fmax``) and the
    column is estimated by :func:`sdctrl.impact_frf` (H1, force window, exponential window
    ending at 0.01; its coherence warnings are not repeated: the coherence of every line is
    in the FRF).

    Noise: each accelerometer carries white noise whose spectral level is ``noise`` times
    its median FRF level (over the band's lines and the hit points) at the force spectrum's
    peak, per hit.  The relative noise of a line is therefore about ``noise`` where the FRF
    has its median level, more near antiresonances and at low frequency (small accelerance) and
    toward ``fmax`` (the force spectrum falls), less at resonances.

    Parameters
    ----------
    structure : str or TestStructure
        A member of :func:`sdctrl.testbeds.family`.
    n_hits : int, optional
        Number of hit points, the driving point included (default ``min(60, number of
        translational DOFs)``).
    sensors : int
        Number of fixed accelerometers (1 to 6).
    noise : float
        Relative noise level (see above); 0 gives exact H1 estimates.
    seed : int, optional
        Seed of the pulses and the noise.
    band : (float, float), optional
        Band to analyse (Hz); default the structure's own.  ``fmax`` is its upper end.
    lines : int
        Lines from 0 to ``fmax`` (line spacing ``fmax / lines``); data run to ``2 fmax``,
        from the first line ``df``, so suspension modes lie in the data below the band.
    averages : int
        Hits per hit point.
    drift : float
        Relative frequency drift over the survey, as temperature or a changing suspension
        gives between the first and the last hit point (real surveys: 0.1-0.3%): the
        ``a``-th hit point (in survey order) sees the structure with stiffness ``(1 + d)^2 K``
        and damping ``(1 + d) C``, ``d = drift (2 a / (n_hits - 1) - 1)``: every pole times
        ``1 + d``, from ``1 - drift`` to ``1 + drift`` (the ``poles`` returned are the
        structure's, at the survey's middle).  0 (default): a time-invariant structure.

    Returns
    -------
    Survey
        The FRF and the exact in-band poles and complex mode shapes.

    Raises
    ------
    ValueError
        An unknown structure, a band holding no mode, counts or levels out of range; the
        message names the argument.

    Examples
    --------
    >>> import sdctrl as sd
    >>> s = sd.testbeds.survey("plate", lines=200, averages=1, seed=0)
    >>> s.frf.shape, float(s.frf.freq[0]), s.driving_point, s.poles.size
    ((400, 3, 46), 0.31, 'G2_0.z', 5)
    """
    from sdctrl.testbeds._family import TestStructure, family, structure as by_name

    if not isinstance(structure, TestStructure) and structure not in family():
        raise ValueError(f"structure must be a TestStructure or one of {family()}, got "
                         f"{structure!r}")
    st = structure if isinstance(structure, TestStructure) else by_name(structure)
    lo, hi = check_band(st.band if band is None else band, "band")
    sensors = check_int(sensors, "sensors", minimum=1, maximum=6)
    noise = check_scalar(noise, "noise", nonneg=True)
    seed = check_seed(seed, "seed")
    lines = check_int(lines, "lines", minimum=16, maximum=50_000)
    averages = check_int(averages, "averages", minimum=1, maximum=20)
    drift = check_scalar(drift, "drift", nonneg=True)
    if drift >= 0.1:
        raise ValueError(f"drift must be below 0.1 (a relative frequency change), got {drift!r}")
    lam, psi, dofs = _modes_of(st.builder)
    f = np.abs(lam) / (2 * np.pi)
    inb = (f > lo) & (f < hi) & (lam.imag > 0)
    if not inb.any():
        raise ValueError(f"band must hold at least one mode of {st.name!r}, got {lo:g}-{hi:g} Hz")
    idx = {d: i for i, d in enumerate(dofs)}
    amp = np.abs(psi[:, inb]) / np.abs(psi[:, inb]).max(axis=0)
    sens = _place_sensors(amp, [idx[s] for s in st.sensors], sensors)
    trans = [i for i, d in enumerate(dofs) if d.split(".")[-1] in ("x", "y", "z")]
    n_hits = min(60, len(trans)) if n_hits is None else n_hits
    n_hits = check_int(n_hits, "n_hits", minimum=2, maximum=len(trans))
    hits = _place_hits(st.fe().nodes, dofs, trans, amp, sens, n_hits)
    plan = _Plan(fs=4 * hi, n=4 * lines, pulse=2 / (3 * hi), averages=averages, noise=noise,
                 drift=drift)
    frf = _measure(lam, psi[sens], psi[hits], plan, np.random.default_rng(seed), (lo, hi),
                   [dofs[i] for i in sens], [dofs[i] for i in hits])
    order = np.argsort(f[inb])
    return Survey(frf=frf, band=(lo, hi), poles=lam[inb][order],
                  shapes=psi[hits][:, inb][:, order], sensor_shapes=psi[sens][:, inb][:, order],
                  driving_point=dofs[sens[0]])


@lru_cache(maxsize=8)
def _modes_of(builder):
    """All ``2N`` complex modes of the true structure ``builder()``: poles (Im > 0 first,
    then their conjugates), displacement parts ``psi`` (N, 2N) scaled so ``psi_z^T U psi_z
    = 1``, DOFs (members built alike -- the truss over two bands -- share them; any
    :class:`TestStructure`, in the family or not, by its builder)."""
    import scipy.linalg as sl
    import scipy.sparse as sp

    fe = builder()
    M, K, C = (np.asarray(x.toarray() if sp.issparse(x) else x, dtype=float)
               for x in (fe.M, fe.K, fe.C))
    N = M.shape[0]
    Z = np.zeros((N, N))
    U = np.block([[C, M], [M, Z]])
    V = np.block([[K, Z], [Z, -M]])
    lam, vec = sl.eig(-V, U)
    keep = lam.imag > 0
    lam, vec = lam[keep], vec[:, keep]
    vec = vec / np.sqrt(np.einsum("ij,ik,kj->j", vec, U, vec))
    lam = np.concatenate([lam, lam.conj()])
    psi = np.concatenate([vec[:N], vec[:N].conj()], axis=1)
    for a in (lam, psi):
        a.setflags(write=False)
    return lam, psi, tuple(fe.dofs)


def _place_sensors(amp: np.ndarray, candidates: list, k: int) -> list:
    """Greedy: each accelerometer added maximises the smallest share of a mode's largest
    amplitude seen so far; ties (within :data:`TIE` of the largest amplitude: a symmetric
    structure's mirror nodes, equal but for the eigenvectors' rounding on the machine) go to
    the largest total, then to the lowest DOF index."""
    chosen, seen = [], np.zeros(amp.shape[1])
    for _ in range(min(k, len(candidates))):
        rest = [c for c in candidates if c not in chosen]
        share = np.array([np.min(np.maximum(seen, amp[c])) for c in rest])
        total = np.array([np.sum(amp[c]) for c in rest])
        tie = share >= share.max() - TIE
        tie &= total >= total[tie].max() - TIE * amp.shape[1]
        best = min(c for c, t in zip(rest, tie) if t)
        chosen.append(best)
        seen = np.maximum(seen, amp[best])
    return chosen


def _place_hits(nodes, dofs, trans: list, amp: np.ndarray, sens: list, n_hits: int) -> list:
    """Hit DOFs: the driving point first, then nodes by farthest-point sampling, each
    node's directions in decreasing modal motion, one per node per round; no other
    accelerometer DOF is hit (a single driving point)."""
    by_node: dict = {}
    for i in trans:
        by_node.setdefault(dofs[i].rsplit(".", 1)[0], []).append(i)
    names = list(by_node)
    xyz = np.array([nodes[m] for m in names], dtype=float)
    first = names.index(dofs[sens[0]].rsplit(".", 1)[0])
    order, dist = [first], np.linalg.norm(xyz - xyz[first], axis=1)
    for _ in range(len(names) - 1):
        j = int(np.argmax(dist))
        order.append(j)
        dist = np.minimum(dist, np.linalg.norm(xyz - xyz[j], axis=1))
    motion = amp.sum(axis=1)
    queues = [sorted(by_node[names[j]], key=lambda i: -motion[i]) for j in order]
    queues[0].remove(sens[0])
    hits, banned = [sens[0]], set(sens)
    while len(hits) < n_hits and any(queues):
        for q in queues:
            while q and q[0] in banned:
                q.pop(0)
            if q and len(hits) < n_hits:
                hits.append(q.pop(0))
    return hits


def _measure(lam, psi_s, psi_h, plan: _Plan, rng, band, sensors, hits):
    """The survey's FRF: per hit point ``plan.averages`` hits through ``impact_frf``."""
    from sdctrl.data import FRF, ImpactWarning, impact_frf

    n, fs = plan.n, plan.fs
    w = 2 * np.pi * np.arange(n // 2 + 1) * fs / n
    s = 1j * w + 1 / plan.tau                    # the windowed accelerance at the DFT lines
    Hw = _accelerance(lam, psi_s, psi_h, s)
    k = (w / (2 * np.pi) >= band[0]) & (w / (2 * np.pi) <= band[1])
    level = np.median(np.abs(Hw[k]), axis=(0, 2))                         # (ns,)
    t = np.arange(n) / fs
    win = np.exp(-t / plan.tau)
    cols, cohs, tau = [], [], None
    for a in range(len(hits)):
        Ha = Hw[:, :, a] if plan.drift == 0 else _accelerance(
            lam, psi_s, psi_h[a:a + 1], s, plan.drift * (2 * a / (len(hits) - 1) - 1))[:, :, 0]
        records = []
        for _ in range(plan.averages):
            t0 = (0.002 + 0.004 * rng.random()) * n / fs
            wid = plan.pulse * (1 + 0.3 * (rng.random() - 0.5))
            size = 100.0 * (1 + 0.4 * (rng.random() - 0.5))
            f = np.where((t >= t0) & (t < t0 + wid), size * np.sin(np.pi * (t - t0) / wid), 0.0)
            Fk = np.fft.rfft(f * win)
            y = np.fft.irfft(Ha * Fk[:, None], n=n, axis=0) / win[:, None]
            sig = plan.noise * level * np.abs(Fk).max() / np.sqrt(np.sum(win**2))
            y = y + sig * rng.standard_normal(y.shape)
            f = f + 1e-3 * plan.noise * size * rng.standard_normal(n)
            records.append((f, y))
        with warnings.catch_warnings():          # the coherence is in the FRF, per line
            warnings.simplefilter("ignore", ImpactWarning)
            one = impact_frf(records, fs, force_window=FORCE_WINDOW, exponential=EXPONENTIAL,
                             quantity="acceleration", sensors=sensors, actuator=hits[a])
        cols.append(one.H[:, :, 0])
        cohs.append(one.coherence.reshape(one.H.shape[:2]))
        tau, freq = one.exponential_tau, one.freq
    return FRF(freq, np.stack(cols, axis=2), quantity="acceleration", sensors=sensors,
               actuators=hits, coherence=np.stack(cohs, axis=2), exponential_tau=tau,
               averages=plan.averages)


def _accelerance(lam, psi_s, psi_h, s, d=0.0):
    """Accelerance ``sum_j (c psi_j)(psi_j^T b) s^2 / (s - lam_j)`` (2.10) at the Laplace points
    ``s`` (nl, ns, n_hits), of the structure ``((1 + d)^2 K, (1 + d) C, M)`` when ``d`` is
    given (a drift): poles ``lam (1 + d)``, shapes ``psi / sqrt(1 + d)`` (the normalisation
    ``psi^T U psi = 1`` with ``U = [[C, M], [M, 0]]``, 2.8-2.10)."""
    G = 1.0 / ((1 + d) * (s[:, None] - (1 + d) * lam[None, :]))          # (nl, 2N)
    return np.einsum("fj,sj,aj->fsa", G, psi_s, psi_h, optimize=True) * (s**2)[:, None, None]
