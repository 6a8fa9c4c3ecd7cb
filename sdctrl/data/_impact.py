"""Impact (hammer) tests: FRF from a list of separate hits, :func:`impact_frf`.

Each hit is one force record (the hammer's load cell) and the simultaneous response records,
the whole transient in one record.  The spectra of every hit are averaged (one average per
hit, no Welch segments: a segment would cut the transient) and the FRF is estimated per
sensor by H1, H2 or Hv with the ordinary coherence.  Two windows of impact testing:

- a *force window* keeps the pulse and zeroes the rest of the force record (the load cell's
  noise after the hit carries no force);
- an *exponential window* ``exp(-t/tau)`` forces lightly damped responses to die out within
  the record (no leakage).  It is applied to the force record too (a short pulse is hardly
  changed), so the windowed records are those of the impulse response ``h(t) exp(-t/tau)``
  exactly: every pole ``lambda_j`` of the structure appears as ``lambda_j - 1/tau``.  The FRF
  remembers ``tau`` (``FRF.exponential_tau``) and :func:`~sdctrl.identify` adds ``1/tau``
  back to the identified decay rates.

Checks, each a warning naming the hit: a second force pulse (double hit), a clipped flat top
on the force or a response (overload: the amplifier or the converter saturated), and poor
coherence at the resonances.
"""

from __future__ import annotations

import warnings

import numpy as np

from sdctrl._lib.validate import as_array, check_labels, check_quantity, check_scalar
from sdctrl.data._frf import FRF

__all__ = ["ImpactWarning", "impact_frf"]

#: a force pulse is where ``|f|`` exceeds this fraction of its peak (double-hit detection)
PULSE_LEVEL = 0.1
#: coherence below this at a resonance line is reported as poor
POOR_COHERENCE = 0.9
#: a clipped flat top holds the extreme value over at least this many samples
FLAT_SAMPLES = 3
ESTIMATORS = ("H1", "H2", "Hv")


class ImpactWarning(UserWarning):
    """A fault of an impact test: double hit, overload, poor coherence at resonances."""


def impact_frf(hits, fs: float, *, force_window: float | None = None,
               exponential: float | None = None, estimator: str = "H1",
               quantity: str = "acceleration", sensors=None, actuator: str | None = None) -> FRF:
    """FRF of an impact test from a list of hammer hits, with coherence.

    Parameters
    ----------
    hits : sequence of (force, responses)
        One pair per hit: ``force`` of shape ``(n,)`` and ``responses`` of shape ``(n,)`` or
        ``(n, ns)``, sampled together; every hit has the same ``n`` and ``ns``.
    fs : float
        Sampling frequency in Hz.
    force_window : float, optional
        Fraction of the record kept on the force, from its start (``0 < force_window <= 1``);
        the rest of the force record is zeroed.  None keeps it all.
    exponential : float, optional
        Value of the exponential window ``exp(-t/tau)`` at the record's end (``0 < exponential
        < 1``, e.g. 0.01), applied to the responses and the force; ``tau = -T / ln(exponential)``
        with ``T = (n - 1) / fs``.  None applies none.
    estimator : {"H1", "H2", "Hv"}
        ``H1 = G_yf / G_ff`` (noise on the response), ``H2 = G_yy / G_fy`` (noise on the
        force), ``Hv`` the total-least-squares estimate between them (equal noise on both,
        in the records' own units).  They agree on noise-free data.
    quantity : str
        Quantity the responses measure (default acceleration: accelerometers); any name
        :class:`FRF` accepts.
    sensors : sequence of str, optional
        Labels of the response channels.
    actuator : str, optional
        Label of the hit point (default ``"a0"``); a sensor of the same label makes the
        pair collocated (a driving point).

    Returns
    -------
    FRF
        Lines ``k fs / n`` for ``k = 1 .. n // 2`` (Hz), one actuator (the force's offset, the
        median of its record, removed; the responses as recorded), ``coherence`` the
        ordinary coherence of each sensor over the hits (identically 1 for a single hit),
        ``exponential_tau`` the window's ``tau`` in s (None without it), ``averages`` the
        number of hits (the statistics of :func:`~sdctrl.identify` use it, 3.59).

    Raises
    ------
    ValueError
        No hit, records of different lengths or channel counts, NaN/inf, a force record
        without a pulse, options out of range; the message names the argument (and the hit).

    Warns
    -----
    ImpactWarning
        A double hit (a second force pulse), an overload (a clipped flat top on the force or
        a response), each naming the hit; coherence below 0.9 at the strong resonances
        (peaks within 20 dB of the strongest) where the force spectrum lies within 20 dB of
        its maximum (the hammer's band).

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> fs, n = 1000.0, 1000
    >>> t = np.arange(n) / fs
    >>> f = np.where(t < 0.004, np.sin(np.pi * t / 0.004), 0.0)
    >>> h = np.exp(-0.5 * t) * np.sin(2 * np.pi * 50 * t)          # one mode at 50 Hz
    >>> y = np.convolve(f, h)[:n] / fs
    >>> frf = sd.impact_frf([(f, y)], fs, exponential=0.01, quantity="displacement")
    >>> frf.shape, round(frf.exponential_tau, 4)
    ((500, 1, 1), 0.2169)
    """
    fs = check_scalar(fs, "fs", positive=True)
    F, Y = _hit_records(hits)
    nh, n, ns = Y.shape
    if not (fs / n > 0 and np.isfinite(n / fs)):
        raise ValueError(f"fs must give a finite record length and line spacing for {n} "
                         f"samples, got {fs:g} Hz")
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    q = check_quantity(quantity, "quantity")
    sensors = check_labels(sensors, ns, "sensors", "s")
    if actuator is not None and not isinstance(actuator, str):
        raise TypeError(f"actuator must be a label (str) or None, got {type(actuator).__name__}")
    if force_window is not None:
        force_window = check_scalar(force_window, "force_window", positive=True, hi=1.0)
    if exponential is not None:
        exponential = check_scalar(exponential, "exponential", positive=True)
        if not exponential < 1:
            raise ValueError(f"exponential must lie in (0, 1) (the window's value at the "
                             f"record's end), got {exponential:g}")
    for k in range(nh):
        _check_hit(F[k], Y[k], k, sensors)
    F = F - np.median(F, axis=1, keepdims=True)          # load-cell offset
    if force_window is not None:
        F[:, max(int(np.ceil(force_window * n)), 1):] = 0.0
    tau = None
    if exponential is not None:
        tau = -((n - 1) / fs) / np.log(exponential)
        w = np.exp(-np.arange(n) / fs / tau)
        F, Y = F * w, Y * w[:, None]
    freq, H, coh, Gff = _estimate(F, Y, fs, estimator)
    if nh > 1:                                           # one hit: coherence says nothing
        _check_coherence(freq, H, coh, Gff > 1e-2 * Gff.max(), sensors)
    return FRF(freq, H[:, :, None], quantity=q, sensors=sensors,
               actuators=[actuator or "a0"], coherence=coh, exponential_tau=tau, averages=nh)


def _hit_records(hits) -> tuple[np.ndarray, np.ndarray]:
    """Forces ``(nh, n)`` and responses ``(nh, n, ns)`` of the hits, validated copies."""
    if isinstance(hits, np.ndarray) or not hasattr(hits, "__len__") or isinstance(hits, str):
        raise TypeError("hits must be a list of (force, responses) pairs, got "
                        f"{type(hits).__name__}")
    if len(hits) == 0:
        raise ValueError("hits must hold at least one (force, responses) pair, got none")
    forces, responses = [], []
    for k, hit in enumerate(hits):
        if not isinstance(hit, tuple | list) or len(hit) != 2:
            raise TypeError(f"hits[{k}] must be a (force, responses) pair")
        f = as_array(hit[0], f"hits[{k}] force", ndim=1)
        y = as_array(hit[1], f"hits[{k}] responses", ndim=(1, 2))
        y = y[:, None] if y.ndim == 1 else y
        if y.shape[0] != f.size or y.shape[1] == 0:
            raise ValueError(f"hits[{k}]: responses must have shape ({f.size},) or ({f.size}, ns)"
                             f" like the force, got {y.shape}")
        if forces and (f.size != forces[0].size or y.shape[1] != responses[0].shape[1]):
            raise ValueError(f"hits[{k}]: every hit must have {forces[0].size} samples and "
                             f"{responses[0].shape[1]} response channels like hit 0, got "
                             f"{f.size} and {y.shape[1]}")
        forces.append(f)
        responses.append(y)
    if forces[0].size < 8:
        raise ValueError(f"hits: records must hold at least 8 samples, got {forces[0].size}")
    return np.array(forces), np.array(responses)


def _check_hit(f: np.ndarray, y: np.ndarray, k: int, sensors) -> None:
    """Raise for a force without pulse; warn for a double hit or an overload."""
    x = np.abs(f - np.median(f))
    peak = float(x.max())
    if not peak > 0:
        raise ValueError(f"hits[{k}] force is constant: no hammer pulse in the record")
    noise = 1.4826 * float(np.median(x))                 # robust noise level of the load cell
    above = np.flatnonzero(x > max(PULSE_LEVEL * peak, 6 * noise))
    gaps = np.flatnonzero(np.diff(above) > 1)
    if gaps.size:
        main = np.argmax(x[above])
        starts = np.concatenate([[0], gaps + 1])
        ends = np.concatenate([gaps, [above.size - 1]])
        seg = np.searchsorted(starts, main, side="right") - 1
        width = above[ends[seg]] - above[starts[seg]] + 1
        sep = np.abs(above[starts] - above[starts[seg]])
        others = np.flatnonzero((np.arange(starts.size) != seg) & (sep > 2 * width))
        if others.size:
            j = others[0]
            warnings.warn(f"hits[{k}]: double hit -- a second force pulse at sample "
                          f"{above[starts[j]]} ({x[above[starts[j]]] / peak:.0%} of the main "
                          f"one at sample {above[starts[seg]]}); discard the hit",
                          ImpactWarning, stacklevel=3)
    channels = [("force", f)] + [(f"response {sensors[i]!r}", y[:, i]) for i in
                                 range(y.shape[1])]
    for name, sig in channels:
        if _clipped(sig):
            warnings.warn(f"hits[{k}]: overload on the {name} -- a clipped flat top at its "
                          "extreme value (saturated amplifier or converter); lower the gain or "
                          "hit softer, and discard the hit", ImpactWarning, stacklevel=3)


def _clipped(x: np.ndarray) -> bool:
    """A flat top: at least :data:`FLAT_SAMPLES` consecutive samples at the record's extreme
    (maximum or minimum) value, entered and left at a slope the plateau cuts off (the
    straight-line extrapolation of the two samples outside the plateau passes beyond it; a
    smooth, even finely quantised, peak flattens before its top and does not)."""
    scale = float(np.abs(x).max())
    if scale == 0:
        return False
    tol = 1e-9 * scale
    for sgn in (1.0, -1.0):
        z = sgn * x
        top = z.max()
        if top < 0.5 * scale:                       # not the record's extreme (a baseline)
            continue
        at = np.flatnonzero(z >= top - tol)
        runs = np.split(at, np.flatnonzero(np.diff(at) > 1) + 1)
        for r in runs:
            if r.size < FLAT_SAMPLES:
                continue
            sides = []
            if r[0] >= 2:
                sides.append(2 * z[r[0] - 1] - z[r[0] - 2])
            if r[-1] + 2 < z.size:
                sides.append(2 * z[r[-1] + 1] - z[r[-1] + 2])
            if sides and all(s > top + tol for s in sides):
                return True
    return False


def _estimate(F: np.ndarray, Y: np.ndarray, fs: float, estimator: str):
    """Summed spectra over the hits: ``(freq, H (nf, ns), coherence, G_ff (nf,))``."""
    n = F.shape[1]
    Fk = np.fft.rfft(F, axis=1)[:, 1:n // 2 + 1]               # (nh, nf)
    Yk = np.fft.rfft(Y, axis=1)[:, 1:n // 2 + 1]               # (nh, nf, ns)
    freq = np.arange(1, n // 2 + 1) * fs / n
    Gff = np.sum(np.abs(Fk) ** 2, axis=0)[:, None]             # (nf, 1)
    Gyf = np.einsum("hfs,hf->fs", Yk, Fk.conj())               # sum Y F^*
    Gyy = np.sum(np.abs(Yk) ** 2, axis=0)
    if not np.all(Gff > 0):
        raise ValueError(f"hits: the force has no energy at {np.count_nonzero(~(Gff > 0))} "
                         "lines (a pulse too long for the sampling, or a zeroed force); the "
                         "FRF is undefined there")
    with np.errstate(divide="ignore", invalid="ignore"):
        if estimator == "H1":
            H = Gyf / Gff
        elif estimator == "H2":
            H = Gyy / Gyf.conj()
        else:
            d = Gyy - Gff                          # two forms, each free of cancellation
            r = np.sqrt(d**2 + 4 * np.abs(Gyf) ** 2)
            H = np.where(d >= 0, (d + r) / (2 * Gyf.conj()), 2 * Gyf / (r - d))
        coh = np.where(Gyy > 0, np.abs(Gyf) ** 2 / (Gff * Gyy), 0.0)
    H = np.where(np.isfinite(H), H, 0.0)                       # a response with no energy
    return freq, H, np.clip(coh, 0.0, 1.0), Gff[:, 0]


def _check_coherence(freq, H, coh, excited, sensors) -> None:
    """Warn when the coherence is below :data:`POOR_COHERENCE` at the strong resonances:
    peaks of the mean normalised ``|H|`` standing a factor 2 above their surroundings, two
    lines wide at least, within 20 dB of the strongest peak (weaker peaks may be the noise
    floor itself), in the hammer's band (``excited``: force spectrum within 20 dB of its
    maximum; above it the hammer tip puts no energy and a poor coherence is expected)."""
    from scipy.signal import find_peaks

    if freq.size < 5:
        return
    size = np.abs(H).max(axis=0)
    m = np.mean(np.abs(H) / np.where(size > 0, size, 1.0), axis=1)
    peaks, _ = find_peaks(np.log(np.maximum(m, 1e-300)), prominence=np.log(2.0), width=2)
    peaks = peaks[excited[peaks]]
    peaks = peaks[m[peaks] >= 0.1 * m[peaks].max(initial=0.0)]
    if peaks.size == 0:
        return
    bad = [(p, s) for p in peaks for s in range(coh.shape[1]) if coh[p, s] < POOR_COHERENCE]
    if bad:
        where = sorted({float(freq[p]) for p, _ in bad})
        chans = sorted({sensors[s] for _, s in bad})
        warnings.warn(f"poor coherence (below {POOR_COHERENCE}) at {len(where)} of {peaks.size} "
                      f"resonance lines ({', '.join(f'{v:.4g}' for v in where[:5])}"
                      f"{', ...' if len(where) > 5 else ''} Hz; sensors {', '.join(chans[:5])}): "
                      "check for double hits, overloads, a loose sensor, or hits too few or "
                      "too different", ImpactWarning, stacklevel=3)
