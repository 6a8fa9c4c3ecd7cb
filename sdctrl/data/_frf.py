"""Frequency response functions: container, quantity conversion, H1 estimation.

Convention (API.md): ``H[f, sensor, actuator]`` of shape ``(n_freq, n_sensors,
n_actuators)``, frequencies in Hz, strictly increasing and positive.  The
measured quantity (displacement, velocity or acceleration per unit force)
is recorded; a displacement FRF ``H_d`` relates to the others by
``H_v = (j w) H_d`` and ``H_a = (j w)^2 H_d``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.statespace import ss_frf
from sdctrl._lib.validate import (
    QUANTITY_POWER,
    as_array,
    check_band,
    check_collocated,
    check_finite_result,
    check_freq,
    check_int,
    check_labels,
    check_quantity,
    check_scalar,
    readonly,
)
from sdctrl._lib.signals import INPUT_SUFFIX, as_statespace

__all__ = ["FRF", "estimate_frf"]


class FRF(FrozenState):
    """Measured or computed frequency response functions of a MIMO structure.

    Parameters
    ----------
    freq : array_like, shape (nf,)
        Frequencies in Hz, finite, strictly positive and strictly increasing.
    H : array_like, shape (nf, ns, na)
        Complex responses ``H[f, sensor, actuator]``.  A 1-D array is taken as
        a single sensor/actuator pair, a 2-D array as ``(nf, ns)`` with one actuator.
    quantity : str
        Measured response quantity per unit force: ``"displacement"``, ``"velocity"`` or
        ``"acceleration"``, or the standard FRF names ``"receptance"`` (displacement),
        ``"mobility"`` (velocity), ``"accelerance"`` or ``"inertance"`` (acceleration),
        stored as the canonical name.  Abbreviations are refused.
    sensors, actuators : sequence of str, optional
        Unique labels; FE DOF labels such as ``"N42.y"`` tie the test to an
        :class:`~sdctrl.FEModel`.  Defaults ``s0, s1, ...`` and ``a0, a1, ...``.
    collocated : (int or str, int or str) or sequence of them, optional
        ``(sensor, actuator)`` pairs where sensor ``s`` is dual to actuator ``a``
        (``c_s = b_a^T``), as indices or labels; one pair or a sequence of pairs.
        Default (None): every sensor and actuator of the same label form a pair (a
        driving point); ``collocated=()`` declares none.
    coherence : array_like, optional
        Coherence in ``[0, 1]``, shape ``(nf, ns, na)`` or ``(nf, ns)`` (multiple
        coherence per sensor, shared by all actuators).
    units : str, optional
        Free text units of ``H`` (e.g. ``"m/s^2/N"``), kept by UFF I/O.
    exponential_tau : float, optional
        Time constant ``tau`` (s) of an exponential window ``exp(-t/tau)`` applied to the
        response records (impact tests, :func:`~sdctrl.impact_frf`); None without one.
        The window adds ``1/tau`` (rad/s) to the decay rate of every pole, which
        :func:`~sdctrl.identify` removes.
    averages : int, optional
        Number ``n_d`` of independent records averaged in the estimate (hammer hits,
        :func:`~sdctrl.impact_frf`), when known.  A coherence estimated from the same ``n_d``
        records makes the point variance (3.59) ``n_d - 1`` times too large (exact for two);
        :func:`~sdctrl.identify`'s statistics divide it by ``n_d - 1``.  None: not known
        (the statistics stay conservative).

    Examples
    --------
    >>> import numpy as np, sdctrl as sd
    >>> f = np.linspace(1, 10, 5)
    >>> frf = sd.FRF(f, 1 / (1 - (f / 5) ** 2 + 0.02j * f / 5),
    ...              sensors=["N1.x"], actuators=["N1.x"])
    >>> frf.H.shape
    (5, 1, 1)
    """

    __slots__ = (
        "H",
        "actuators",
        "averages",
        "coherence",
        "collocated",
        "exponential_tau",
        "freq",
        "quantity",
        "sensors",
        "units",
    )

    def __init__(self, freq, H, quantity: str = "displacement",
                 sensors: Sequence[str] | None = None, actuators: Sequence[str] | None = None,
                 collocated=None, coherence=None, units: str | None = None,
                 exponential_tau: float | None = None, averages: int | None = None):
        f = check_freq(freq, "freq")
        h = as_array(H, "H", ndim=(1, 2, 3), dtype=complex)
        if h.ndim == 1:
            h = h[:, None, None]
        elif h.ndim == 2:
            h = h[:, :, None]
        if h.shape[0] != f.size:
            raise ValueError(f"H must have shape (n_freq={f.size}, n_sensors, n_actuators), "
                             f"got {h.shape}")
        if h.shape[1] == 0 or h.shape[2] == 0:
            raise ValueError(f"H must have at least one sensor and one actuator, got {h.shape}")
        q = check_quantity(quantity, "quantity")
        nf, ns, na = h.shape
        s = check_labels(sensors, ns, "sensors", "s")
        a = check_labels(actuators, na, "actuators", "a")
        if collocated is None:                  # a driving point: same label both sides
            collocated = [(x, x) for x in s if x in a]
        col = check_collocated(collocated, ns, na, "collocated", s, a)
        coh = None
        if coherence is not None:
            coh = as_array(coherence, "coherence", ndim=(2, 3), dtype=float)
            if coh.ndim == 2:
                if coh.shape != (nf, ns):
                    raise ValueError(f"coherence must have shape {(nf, ns, na)} or {(nf, ns)}, "
                                     f"got {coh.shape}")
                coh = np.repeat(coh[:, :, None], na, axis=2)
            if coh.shape != (nf, ns, na):
                raise ValueError(f"coherence must have shape {(nf, ns, na)} or {(nf, ns)}, "
                                 f"got {coh.shape}")
            if np.any(coh < 0) or np.any(coh > 1):
                raise ValueError("coherence must lie in [0, 1]")
        if units is not None and not isinstance(units, str):
            raise TypeError(f"units must be a string or None, got {type(units).__name__}")
        if exponential_tau is not None:
            exponential_tau = check_scalar(exponential_tau, "exponential_tau", positive=True)
        if averages is not None:
            averages = check_int(averages, "averages", minimum=1)
        object.__setattr__(self, "freq", readonly(f))
        object.__setattr__(self, "H", readonly(h))
        object.__setattr__(self, "quantity", q)
        object.__setattr__(self, "sensors", s)
        object.__setattr__(self, "actuators", a)
        object.__setattr__(self, "collocated", col)
        object.__setattr__(self, "coherence", readonly(coh))
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "exponential_tau", exponential_tau)
        object.__setattr__(self, "averages", averages)

    def __setattr__(self, name, value):
        raise AttributeError("FRF is immutable; build a new one instead")

    # --- convenience -------------------------------------------------------------
    @property
    def omega(self) -> np.ndarray:
        """Frequencies in rad/s."""
        return 2 * np.pi * self.freq

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(n_freq, n_sensors, n_actuators)``."""
        return self.H.shape

    def __repr__(self) -> str:
        nf, ns, na = self.H.shape
        return (f"FRF({self.quantity}, {nf} lines {self.freq[0]:g}-{self.freq[-1]:g} Hz, "
                f"{ns} sensors x {na} actuators)")

    def _replace(self, **changes) -> FRF:
        kw = {"freq": self.freq, "H": self.H, "quantity": self.quantity, "sensors": self.sensors,
              "actuators": self.actuators, "collocated": self.collocated,
              "coherence": self.coherence, "units": self.units,
              "exponential_tau": self.exponential_tau, "averages": self.averages}
        kw.update(changes)
        return FRF(**kw)

    # --- operations ----------------------------------------------------------------
    def band(self, fmin: float, fmax: float) -> FRF:
        """Restrict to ``fmin <= freq <= fmax`` (Hz).

        Parameters
        ----------
        fmin, fmax : float
            Band limits in Hz, ``fmin < fmax``.

        Returns
        -------
        FRF
            A new FRF with the lines inside the band.
        """
        fmin, fmax = check_band((fmin, fmax), "band")
        keep = (self.freq >= fmin) & (self.freq <= fmax)
        if not np.any(keep):
            raise ValueError(f"band ({fmin:g}, {fmax:g}) Hz contains no frequency line "
                             f"(data covers {self.freq[0]:g}-{self.freq[-1]:g} Hz)")
        coh = None if self.coherence is None else self.coherence[keep]
        return self._replace(freq=self.freq[keep], H=self.H[keep], coherence=coh)

    def to(self, quantity: str) -> FRF:
        """Convert to another response quantity by powers of ``j*omega``.

        Parameters
        ----------
        quantity : str
            Target quantity, a name :class:`FRF` accepts (``"acceleration"``,
            ``"accelerance"``, ...).

        Returns
        -------
        FRF
            ``H * (j w)^(p_target - p_self)`` with the same labels and coherence.
        """
        q = check_quantity(quantity, "quantity")
        k = QUANTITY_POWER[q] - QUANTITY_POWER[self.quantity]
        if k == 0:
            return self._replace()
        with np.errstate(over="ignore", invalid="ignore"):
            H = self.H * ((1j * self.omega) ** k)[:, None, None]
        check_finite_result(H, f"converting H to {q}", "H or freq")
        units = self.units if self.units is None else None
        return self._replace(H=H, quantity=q, units=units)

    def select(self, sensors=None, actuators=None) -> FRF:
        """Subset of sensors and/or actuators, by index or label.

        Parameters
        ----------
        sensors, actuators : sequence of int or str, optional
            What to keep (all when None).

        Returns
        -------
        FRF
            The selected channels; collocated pairs that survive are kept.
        """
        si = _indices(sensors, self.sensors, "sensors")
        ai = _indices(actuators, self.actuators, "actuators")
        col = [(si.index(s), ai.index(a)) for s, a in self.collocated if s in si and a in ai]
        coh = None if self.coherence is None else self.coherence[:, si][:, :, ai]
        return self._replace(H=self.H[:, si][:, :, ai],
                             sensors=[self.sensors[i] for i in si],
                             actuators=[self.actuators[i] for i in ai],
                             collocated=col, coherence=coh)

    def transpose(self) -> FRF:
        """The reciprocal test: sensors and actuators exchanged, ``H[f, a, s]``.

        Reciprocity (``H_sa = H_as`` for a structure with symmetric mass, damping and
        stiffness, measured with dual sensors and actuators) makes a roving-hammer survey
        (few fixed accelerometers, many hit points) a test with many outputs and few
        inputs, the form the identification of the thesis (3.2, 3.46-3.47) prefers.

        Returns
        -------
        FRF
            ``H`` of shape ``(nf, na, ns)``, sensors and actuators swapped, collocated pairs
            kept (each ``(s, a)`` becomes ``(a, s)``), coherence transposed; quantity, units,
            ``exponential_tau`` and ``averages`` unchanged.  ``frf.transpose().transpose()`` equals
            ``frf``.
        """
        coh = None if self.coherence is None else np.swapaxes(self.coherence, 1, 2)
        return self._replace(H=np.swapaxes(self.H, 1, 2), sensors=self.actuators,
                             actuators=self.sensors, coherence=coh,
                             collocated=[(a, s) for s, a in self.collocated])

    @classmethod
    def from_system(cls, sys, freq, quantity: str = "displacement") -> FRF:
        """Evaluate a model on a frequency grid (vectorised).

        Parameters
        ----------
        sys : control.StateSpace or control.TransferFunction or sdctrl model
            A python-control LTI system (its outputs are taken to be ``quantity``
            per unit input) or any sdctrl model with a ``frf(freq, quantity)`` method
            (complex-mode, normal-mode, hybrid), which is asked for ``quantity``.
        freq : array_like
            Frequencies in Hz.
        quantity : {"displacement", "velocity", "acceleration"}
            Quantity of the returned FRF.

        Returns
        -------
        FRF
            Sensors are the system's output names; actuators its input names without the
            ``_u`` suffix sdctrl gives inputs (kept when some input lacks it).
        """
        f = check_freq(freq, "freq")
        q = check_quantity(quantity, "quantity")
        if hasattr(sys, "frf") and callable(sys.frf):
            out = sys.frf(f, quantity=q)
            if not isinstance(out, FRF):
                out = FRF(f, out, quantity=q)
            return out
        import control

        if not isinstance(sys, control.StateSpace | control.TransferFunction):
            raise TypeError("sys must be a python-control StateSpace/TransferFunction or an "
                            f"sdctrl model with a frf method, got {type(sys).__name__}")
        sys = as_statespace(sys, "sys")
        with np.errstate(all="ignore"):
            H = ss_frf(sys.A, sys.B, sys.C, sys.D, 2 * np.pi * f)
        check_finite_result(H, "sys evaluated at freq", "sys or freq (or a pole on the grid)")
        return cls(f, H, quantity=q, sensors=list(sys.output_labels),
                   actuators=_actuator_labels(sys.input_labels))


def _actuator_labels(inputs) -> list[str]:
    """Actuator labels of StateSpace inputs: sdctrl's ``_u`` suffix (API.md) is dropped when
    every input carries it and the labels stay unique, else the names are kept."""
    names = [str(n) for n in inputs]
    if names and all(n.endswith(INPUT_SUFFIX) and len(n) > len(INPUT_SUFFIX) for n in names):
        stripped = [n[:-len(INPUT_SUFFIX)] for n in names]
        if len(set(stripped)) == len(stripped):
            return stripped
    return names


def _indices(sel, labels, name) -> list[int]:
    if sel is None:
        return list(range(len(labels)))
    if isinstance(sel, str | int | np.integer):
        sel = [sel]
    if not isinstance(sel, Sequence | np.ndarray) or isinstance(sel, bytes):
        raise TypeError(f"{name} must be a label, an index or a sequence of them, got "
                        f"{type(sel).__name__}")
    out = []
    for item in sel:
        if isinstance(item, str):
            if item not in labels:
                raise ValueError(f"{name}: unknown label {item!r}")
            out.append(labels.index(item))
        elif isinstance(item, int | np.integer) and not isinstance(item, bool):
            if not -len(labels) <= item < len(labels):
                raise ValueError(f"{name}: index {item} out of range for {len(labels)} channels")
            out.append(int(item) % len(labels))
        else:
            raise TypeError(f"{name} must hold labels or integer indices, got {item!r}")
    if not out:
        raise ValueError(f"{name} selects no channel")
    return out


def estimate_frf(u, y, fs: float, nperseg: int | None = None, *, sensors=None, actuators=None,
                 quantity: str = "displacement", window: str = "hann") -> FRF:
    """H1 estimate of the FRF from simultaneous input/output records, with coherence.

    Welch averages of the cross-spectra give ``H = G_yu G_uu^-1`` at every line
    (several simultaneous, uncorrelated inputs are handled by the matrix inverse).
    The coherence is the ordinary coherence for one input and the *multiple*
    coherence ``(G_yu G_uu^-1 G_uy)_ss / G_yy,ss`` of each sensor for several.

    Parameters
    ----------
    u : array_like, shape (nt,) or (nt, na)
        Input (force) records.
    y : array_like, shape (nt,) or (nt, ns)
        Output records, sampled with ``u``.
    fs : float
        Sampling frequency in Hz.
    nperseg : int, optional
        Samples per Welch segment (default: ``nt // 8`` rounded down to a power
        of two, at least 64 when possible), 50% overlap.
    sensors, actuators : sequence of str, optional
        Labels of the output and input channels.
    quantity : str
        Quantity measured by ``y``.
    window : str
        Window of the Welch segments (scipy name).

    Returns
    -------
    FRF
        Lines from ``fs/nperseg`` to the Nyquist frequency (the 0 Hz line is dropped).

    Notes
    -----
    The random error of ``|H|`` from ``n_d`` independent averages is
    ``sqrt((1 - g^2) / (2 g^2 n_d))`` (Bendat & Piersol); with 50% overlap a Hann
    window gives about ``n_d ~ 0.9 * n_segments`` effective averages.
    """
    from scipy import signal

    fs = check_scalar(fs, "fs", positive=True)
    U, Y = _records(u, y)
    nt, na = U.shape
    sensors = check_labels(sensors, Y.shape[1], "sensors", "s")
    actuators = check_labels(actuators, na, "actuators", "a")
    if nperseg is None:
        nperseg = max(min(nt, 64), 2 ** int(np.floor(np.log2(max(nt // 8, 1)))))
    nperseg = check_int(nperseg, "nperseg")
    if not 8 <= nperseg <= nt:
        raise ValueError(f"nperseg must lie in [8, {nt}] (number of samples), got {nperseg}")
    if not fs / nperseg > 0:
        raise ValueError(f"fs is too small ({fs:g} Hz): the line spacing fs/nperseg underflows")
    if nt < 2 * nperseg and na > 1:
        raise ValueError("u, y: too few samples for a MIMO estimate; need several segments")
    _check_window(window, nperseg)
    _check_excitation(U, actuators)
    # scale invariance: spectra of unit-size records, H rescaled at the end (no overflow)
    su, sy = np.abs(U).max(), np.abs(Y).max() or 1.0
    U, Y = U / su, Y / sy
    kw = {"fs": fs, "nperseg": int(nperseg), "window": window, "axis": 0, "detrend": "constant"}
    # G_uu[a, b] = E[U_a U_b^*]; scipy's csd(x, y) = E[X^* Y]
    f, Guu = signal.csd(U[:, None, :], U[:, :, None], **kw)   # (nf, na, na) after moveaxis
    _, Gyu = signal.csd(U[:, None, :], Y[:, :, None], **kw)   # E[U_a^* Y_s] -> (nf, ns, na)
    _, Gyy = signal.csd(Y, Y, **kw)                            # (nf, ns)
    keep = f > 0
    f = f[keep]
    Guu = Guu[keep]
    Gyu = Gyu[keep]
    Gyy = np.real(Gyy[keep])
    _check_cross_spectrum(Guu, f)
    with np.errstate(all="ignore"):
        if na == 1:
            H = Gyu / Guu
            num = np.abs(Gyu[:, :, 0]) ** 2 / np.real(Guu[:, :, 0])
        else:
            # H Guu = Gyu  ->  Guu^T H^T = Gyu^T ; Guu is Hermitian
            H = np.linalg.solve(np.swapaxes(Guu, 1, 2), np.swapaxes(Gyu, 1, 2))
            H = np.swapaxes(H, 1, 2)
            num = np.real(np.einsum("fsa,fsa->fs", H, Gyu.conj()))
        coh = np.where(Gyy > 0, num / Gyy, 0.0)
        H = H * (sy / su)
    check_finite_result(H, "the H1 estimate", "y / u (their ratio)")
    coh = np.clip(np.nan_to_num(coh), 0.0, 1.0)
    return FRF(f, H, quantity=quantity, sensors=sensors, actuators=actuators, coherence=coh)


def _records(u, y) -> tuple[np.ndarray, np.ndarray]:
    """Input and output records as (nt, na) and (nt, ns) float arrays."""
    U = as_array(u, "u", ndim=(1, 2), dtype=float)
    Y = as_array(y, "y", ndim=(1, 2), dtype=float)
    U = U[:, None] if U.ndim == 1 else U
    Y = Y[:, None] if Y.ndim == 1 else Y
    if U.shape[1] == 0 or Y.shape[1] == 0:
        raise ValueError(f"u and y must hold at least one channel, got shapes {U.shape}, "
                         f"{Y.shape}")
    if Y.shape[0] != U.shape[0]:
        raise ValueError(f"u and y must have the same number of samples, got {U.shape[0]} and "
                         f"{Y.shape[0]}")
    return U, Y


def _check_window(window, nperseg: int) -> None:
    """A scipy window name (or ``(name, parameter)`` tuple) or ``nperseg`` weights."""
    from scipy import signal

    if isinstance(window, str | tuple):
        try:
            signal.get_window(window, nperseg)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"window must be a scipy window name, got {window!r} "
                             f"({exc})") from None
        return
    w = as_array(window, "window", ndim=1)
    if w.size != nperseg or not np.any(w != 0):
        raise ValueError(f"window must be a window name or {nperseg} (nperseg) non-zero weights, "
                         f"got {w.size} values")


def _check_excitation(U: np.ndarray, actuators) -> None:
    """Every input channel excites something, and no two channels are the same signal."""
    def name(a):
        return f"{a} ({actuators[a]!r})"
    Z = U - U.mean(axis=0)
    size = np.abs(U).max(axis=0)
    for a in np.flatnonzero(~(np.abs(Z).max(axis=0) > 1e-12 * size)):
        raise ValueError(f"u: input channel {name(a)} is constant (all zero once its mean is "
                         "removed): it excites nothing, the FRF of that actuator is undefined")
    if U.shape[1] > 1:
        Z = Z / np.abs(Z).max(axis=0)                # unit size: no under/overflow below
        Z = Z / np.sqrt(np.sum(Z * Z, axis=0))
        rho = np.abs(Z.T @ Z)
        i, j = np.triu_indices(U.shape[1], 1)
        dup = np.flatnonzero(rho[i, j] > 1 - 1e-10)
        if dup.size:
            a, b = i[dup[0]], j[dup[0]]
            raise ValueError(f"u: input channels {name(a)} and {name(b)} are the same signal "
                             "(up to a factor): the input cross-spectrum is singular and the "
                             "two actuators cannot be told apart; use independent excitations")


def _check_cross_spectrum(Guu: np.ndarray, f: np.ndarray) -> None:
    """Refuse lines where the input cross-spectrum cannot be inverted."""
    sv = np.linalg.svd(Guu, compute_uv=False)            # (nf, na)
    bad = ~(sv[:, -1] > 1e-12 * sv[:, 0])
    if np.any(bad):
        lines = f[bad]
        raise ValueError(f"u: the input cross-spectrum is singular at {lines.size} of {f.size} "
                         f"lines ({lines[0]:g} Hz{', ...' if lines.size > 1 else ''}): the "
                         "inputs do not excite these lines independently (a channel without "
                         "energy there, or channels that are linear combinations of others)")
