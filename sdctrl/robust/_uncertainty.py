"""Structured parametric uncertainty of normal mode models (thesis section 5.2).

The uncertain model (5.5) is ``p'' + (Gamma + dGamma) p' + (Omega + dOmega) p = (phib + db) u``,
``y = (cphi + dc) p + E u``.  Every uncertain entry is one real parameter; a symmetric off-diagonal
pair of ``Gamma`` or ``Omega`` is one repeated real scalar (a rank-two channel).  The perturbation
enters affinely, so the linear fractional transformation built by :meth:`UncertainModel.lft` is
exact.  The model's residual dynamics (identified poles kept as complex modes, ``model.residual``)
are part of the plant, certain: their 2x2 blocks (3.26)-(3.33) follow the modal states in
every realisation (nominal, perturbed, LFT), so that the uncertain model responds as its
nominal model does (without them the plate's uncertain model from a survey missed half of
its FRF in the band).  So are ``E`` and the correction modes of ``F``, last
(:mod:`._fixed_parts`): the nominal StateSpace is the model's own ``to_statespace()``.

Place in the flow: this module sits *before* :mod:`sdctrl.modal._normal_model`
(``frf -> io -> uncertainty -> modal``), so that :meth:`NormalModeModel.uncertain` builds an
:class:`UncertainModel` without a cycle.  It never imports :mod:`sdctrl.modal._normal_model`: it
reads the nominal model through its fields (``Omega``, ``Gamma``, ``cphi``, ``phib``, ``E``, ``F``,
``sensors``, ``actuators``, ``frequency``) and copies it with ``model.replace``, which every
normal-mode model (identified, FE-derived, hybrid) has.  The robustness analysis that uses it
(:mod:`sdctrl.robust._stability`) sits after the closed-loop modules.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl._lib.statespace import modal_states, second_order, ss_frf
from sdctrl._lib.display import MAX_ROWS, markdown_table, one_line
from sdctrl._lib.validate import (
    as_array,
    check_executor,
    check_freq,
    check_int,
    check_seed,
    readonly,
)
from sdctrl._lib.signals import signal_names
from sdctrl.robust._fixed_parts import append_block, mass_block
from sdctrl.robust._multitest import MultiTestResult, multi_test_statistics
from sdctrl.robust._physical_bounds import default_bounds, modal_density_bound, psd_gamma_bound
from sdctrl.robust._residual_uncertainty import (
    KINDS,
    residual_channels,
    residual_matrices,
    residual_params,
    residual_perturbed,
    residual_states,
)
from sdctrl.robust._response_bounds import box_draws, envelope_of_draws

__all__ = [
    "CompactLFT",
    "MultiTestResult",
    "UncertainModel",
    "default_bounds",
    "modal_density_bound",
    "multi_test_statistics",
    "psd_gamma_bound",
    "uncertain",
]


#: largest normalised parameter accepted: a million times the bounds is a scaling mistake
DELTA_MAX = 1e6
#: most random samples/vertices one call draws
MAX_DRAWS = 10**6


def _bound(arr, shape, name, symmetric):
    if arr is None:
        return np.zeros(shape)
    a = as_array(arr, name, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape} (the shape of the perturbed parameter), "
                         f"got {a.shape}")
    if np.any(a < 0):
        raise ValueError(f"{name} must hold non-negative bounds")
    if symmetric:
        a = np.maximum(a, a.T)  # one parameter per symmetric pair
    return a


@dataclass(frozen=True, eq=False)
class CompactLFT:
    """Delta channels of an :class:`UncertainModel` through the signals they read and drive.

    Parameters
    ----------
    A, B, C, D : ndarray
        Nominal plant (displacement outputs), ``x = [p; p']``.
    Bv, Dyv : ndarray (nx, m), (ns, m)
        Where the ``m`` driven signals ``v`` enter the states and the outputs.
    Cv, Dvu : ndarray (p, nx), (p, na)
        The ``p`` read signals ``q = Cv x + Dvu u``.
    L, R : ndarray (N, p), (m, N)
        Channel ``k`` reads ``z_k = L[k] q``; the channels drive ``v = R w``.
    reps : tuple of int
        Repetition of each real scalar block (channel order).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    Bv: np.ndarray
    Dyv: np.ndarray
    Cv: np.ndarray
    Dvu: np.ndarray
    L: np.ndarray
    R: np.ndarray
    reps: tuple


@dataclass(frozen=True, eq=False)
class UncertainModel(FrozenState):
    """Normal mode model with bounded real parametric uncertainty, eq. (5.5).

    Parameters
    ----------
    model : NormalModeModel
        Nominal model.
    dGamma, dOmega : ndarray (n, n)
        Bounds on the entries of ``Gamma`` and ``Omega`` (symmetric pairs are one parameter).
    db : ndarray (n, na)
        Bounds on the entries of ``phib``.
    dc : ndarray (ns, n)
        Bounds on the entries of ``cphi``.
    params : list
        Internal list of ``(name, (kind, i, j), repetition, bound)`` built by :func:`uncertain`.
    source : str
        Where the bounds come from (e.g. identification statistics, several tests); empty
        when they were given by hand.
    dpoles : ndarray (m,), complex, optional
        Bounds on the real (``.real``) and imaginary (``.imag``) parts of the poles of the
        model's residual dynamics (rad/s); None: the residual dynamics are certain.
    dresidues : ndarray (m, ns, na), complex, optional
        Bounds on the real and imaginary parts of their residues at the model's I/O
        (:mod:`._residual_uncertainty`).
    """

    model: object
    dGamma: np.ndarray
    dOmega: np.ndarray
    db: np.ndarray
    dc: np.ndarray
    params: list = field(default_factory=list)
    source: str = ""
    dpoles: np.ndarray | None = None
    dresidues: np.ndarray | None = None

    def __repr__(self) -> str:
        kinds = {}
        for _, (kind, _i, _j), _r, _b in self.params:
            kinds[kind] = kinds.get(kind, 0) + 1
        what = ", ".join(f"{k} {v}" for k, v in kinds.items())
        m = self.model
        return one_line("UncertainModel", [
            f"n={m.n}", f"ns={m.ns}", f"na={m.na}",
            f"{len(self.params)} uncertain parameters" + (f" ({what})" if what else ""),
            f"{sum(p[2] for p in self.params)} Delta channels",
            f"bounds from {self.source}" if self.source else ""])

    def _repr_markdown_(self) -> str:
        rows = [(name, rep, f"{beta:.3g}") for name, _, rep, beta in self.params]
        return f"`{self!r}`\n\n" + markdown_table(["block", "repetition", "bound"], rows,
                                                     MAX_ROWS)

    # ------------------------------------------------------------------ structure
    @property
    def blocks(self) -> list:
        """``(name, repetition)`` of each real scalar uncertainty, in channel order."""
        return [(p[0], p[2]) for p in self.params]

    @property
    def nominal(self):
        """Nominal model as a python-control StateSpace (displacement outputs)."""
        return self.perturbed(np.zeros(len(self.params)))

    def _residual(self):
        """Nominal ``(poles, residues)`` of uncertain residual dynamics, or None (certain)."""
        if self.dresidues is None:
            return None
        res = self.model.residual
        return res.poles, res.placed(self.model.sensors, self.model.actuators)

    def _matrices(self, Omega=None, Gamma=None, phib=None, cphi=None, residual=None):
        """Displacement realisation (2.15) of the nominal model, or of perturbed matrices
        (``residual``: the residual dynamics' perturbed poles and residues)."""
        m = self.model
        A, B, C, D = second_order(m.Omega if Omega is None else Omega,
                                  m.Gamma if Gamma is None else Gamma,
                                  m.phib if phib is None else phib,
                                  m.cphi if cphi is None else cphi)
        res = getattr(m, "residual", None)
        if res is not None:
            if self.dresidues is not None:           # uncertain: complex modal coordinates
                Ar, Br, Cr = residual_matrices(*(residual or self._residual()))
            else:                                    # certain: (3.26)-(3.33)
                Ar, Br, Cr, _ = res.realisation(m.sensors, m.actuators)
            A, B, C = append_block(A, B, C, (Ar, Br, Cr))
        if self._mass_block is not None:             # F: certain correction modes, last
            A, B, C = append_block(A, B, C, self._mass_block)
        return A, B, C, D if m.E is None else D + m.E

    @property
    def _mass_block(self):
        """The model's correction modes of ``F``, certain (:func:`._fixed_parts.mass_block`)."""
        return mass_block(self.model)

    def _states(self) -> list:
        """State names: the modal ``p``, ``dp``, the residual dynamics', then ``F``'s."""
        m = self.model
        res = getattr(m, "residual", None)
        states = modal_states(m.n)
        if res is not None:
            states += (residual_states(res.m, m.na) if self.dresidues is not None
                       else list(res.realisation(m.sensors, m.actuators)[3]))
        return states + ([] if self._mass_block is None else list(self._mass_block[3]))

    def compact_lft(self) -> CompactLFT:
        """The Delta channels through the few signals they read and drive (exact, affine).

        Channel ``k`` reads ``z_k = L[k] q`` from the read signals ``q = Cv x + Dvu u``
        (modal displacements ``p_j``, velocities ``p'_j``, actuator inputs) and the channel
        outputs enter as ``v = R w`` in the driven signals (modal force rows, sensor outputs):
        ``x' = A x + B u + Bv v``, ``y = C x + D u + Dyv v``.  A symmetric pair of ``Gamma`` or
        ``Omega`` is two channels (``-beta d (e_i e_j^T + e_j e_i^T)``) sharing one scalar.
        The channel-to-channel response ``L Mc(s) R`` then has the rank of the small core
        ``Mc`` whatever the number of parameters.

        Returns
        -------
        CompactLFT
        """
        m = self.model
        n = m.n
        A, B, C, D = self._matrices()
        reads, drives, chans = {}, {}, []
        for _name, (kind, i, j), rep, beta in self.params:
            if kind in ("Omega", "Gamma"):
                off = 0 if kind == "Omega" else n
                pairs = [(("f", i), -beta, ("x", off + j))]
                if rep == 2:
                    pairs.append((("f", j), -beta, ("x", off + i)))
            elif kind == "b":
                pairs = [(("f", i), beta, ("u", j))]
            elif kind in KINDS:
                pairs = residual_channels(kind, i, j, beta, 2 * n, m.na)
            else:
                pairs = [(("y", i), beta, ("x", j))]
            for drv, coef, rd in pairs:
                drives.setdefault(drv, len(drives))
                reads.setdefault(rd, len(reads))
                chans.append((drives[drv], coef, reads[rd]))
        nx, N = A.shape[0], len(chans)
        Bv, Dyv = np.zeros((nx, len(drives))), np.zeros((m.ns, len(drives)))
        for (kind, i), c in drives.items():
            if kind == "y":
                Dyv[i, c] = 1.0
            else:                                    # a modal force row, or any state's
                Bv[n + i if kind == "f" else i, c] = 1.0
        Cv, Dvu = np.zeros((len(reads), nx)), np.zeros((len(reads), m.na))
        for (kind, i), r in reads.items():
            (Cv if kind == "x" else Dvu)[r, i] = 1.0
        L, R = np.zeros((N, len(reads))), np.zeros((len(drives), N))
        for k, (c, coef, r) in enumerate(chans):
            L[k, r] = 1.0
            R[c, k] = coef
        return CompactLFT(*(readonly(a) for a in (A, B, C, D, Bv, Dyv, Cv, Dvu, L, R)),
                          reps=tuple(p[2] for p in self.params))

    def lft(self):
        """Linear fractional transformation ``(P, blocks)`` of the uncertain model.

        Returns
        -------
        P : control.StateSpace
            Inputs ``[delta channels w; actuators]``, outputs ``[delta channels z; sensors]``;
            closing ``w = diag(delta_i I_ri) z`` with ``|delta_i| <= 1`` gives a model whose
            parameters lie within the bounds (5.5).
        blocks : list of (str, int)
            Name and repetition of each real scalar block, in channel order.
        """
        import control

        c = self.compact_lft()
        A, B, C, D = c.A, c.B, c.C, c.D
        Bw, Dyw, Cz, Dzu = c.Bv @ c.R, c.Dyv @ c.R, c.L @ c.Cv, c.L @ c.Dvu
        r = Bw.shape[1]
        m = self.model
        chans = []
        for name, _, rep, _ in self.params:
            chans += [name] if rep == 1 else [f"{name}_{q}" for q in range(rep)]
        inputs, outputs = signal_names(m.sensors, m.actuators,
                                       extra_inputs=[f"{c}_w" for c in chans],
                                       extra_outputs=[f"{c}_z" for c in chans])
        P = control.ss(A, np.hstack([Bw, B]), np.vstack([Cz, C]),
                       np.block([[np.zeros((r, r)), Dzu], [Dyw, D]]),
                       inputs=inputs, outputs=outputs, states=self._states())
        return P, self.blocks

    def _perturbed_matrices(self, deltas):
        """``(Omega, Gamma, phib, cphi, residual)`` for normalised parameters ``deltas`` (5.5)
        (``residual``: perturbed poles and residues of uncertain residual dynamics, or None).

        Parameters
        ----------
        deltas : array_like (nblocks,)
            Normalised parameter values (``|delta_i| <= 1`` spans the bounds).

        Returns
        -------
        tuple of ndarray
        """
        d = as_array(deltas, "deltas", dtype=float)
        if d.shape != (len(self.params),):
            raise ValueError(f"deltas must be a 1-D array of {len(self.params)} entries (one "
                             f"per block), got shape {d.shape}")
        if np.any(np.abs(d) > DELTA_MAX):
            raise ValueError(f"deltas are normalised (|delta| <= 1 spans the bounds): got "
                             f"max |delta| = {np.abs(d).max():g} > {DELTA_MAX:g}")
        m = self.model
        mats = {"Omega": np.array(m.Omega, float), "Gamma": np.array(m.Gamma, float),
                "b": np.array(m.phib, float), "c": np.array(m.cphi, float)}
        for (name, (kind, i, j), rep, beta), dk in zip(self.params, d):
            if kind in KINDS:
                continue
            mats[kind][i, j] += beta * dk
            if rep == 2:
                mats[kind][j, i] += beta * dk
        res = self._residual()
        if res is not None:
            res = residual_perturbed(*res, self.params, d)
        return mats["Omega"], mats["Gamma"], mats["b"], mats["c"], res

    def perturbed(self, deltas):
        """StateSpace of the model perturbed by normalised ``deltas`` (built directly, not by LFT).

        Parameters
        ----------
        deltas : array_like (nblocks,)
            Normalised parameter values (``|delta_i| <= 1`` spans the bounds).

        Returns
        -------
        control.StateSpace
        """
        import control

        mats = self._perturbed_matrices(deltas)
        m = self.model
        inputs, outputs = signal_names(m.sensors, m.actuators)
        return control.ss(*self._matrices(*mats), inputs=inputs, outputs=outputs,
                          states=self._states())

    def sample_deltas(self, n: int, seed=None) -> np.ndarray:
        """Uniform random normalised parameters, shape ``(n, nblocks)``.

        Parameters
        ----------
        n : int
            Number of samples.
        seed : int or Generator, optional
            Random seed (deterministic results).

        Returns
        -------
        ndarray
        """
        nb = len(self.params)
        n = check_int(n, "n", minimum=1, maximum=MAX_DRAWS)
        return np.random.default_rng(check_seed(seed)).uniform(-1.0, 1.0, size=(n, nb))

    def sample(self, n: int, seed=None) -> list:
        """``n`` random perturbed StateSpace models (uniform in the normalised box).

        Parameters
        ----------
        n : int
            Number of samples.
        seed : int or Generator, optional
            Random seed.

        Returns
        -------
        list of control.StateSpace
        """
        return [self.perturbed(d) for d in self.sample_deltas(n, seed)]

    def frf_envelope(self, freq, n_samples: int = 200, seed=0, max_vertices: int = 256,
                     executor=None):
        """Min/max magnitude and phase of the FRF over random samples and box vertices.

        Parameters
        ----------
        freq : array_like
            Frequencies (Hz).
        n_samples : int
            Number of random interior samples (besides the vertices; 0 allowed).
        seed : int, optional
            Random seed.
        max_vertices : int
            All ``2**nblocks`` vertices are used when not more than this, else that many random
            ones (0: none).
        executor : concurrent.futures.Executor, optional
            Evaluates the draws in chunks (threads, processes, a Dask client's
            ``get_executor()``: the model is then scattered once); the envelope is
            identical to the serial run's.

        Returns
        -------
        dict
            ``freq``, ``nominal`` (complex), ``mag_min``, ``mag_max``, ``phase_min``, ``phase_max``
            (degrees, unwrapped around the nominal phase), each ``(nf, ns, na)``.
        """
        f = check_freq(freq, "freq")
        n_samples = check_int(n_samples, "n_samples", minimum=0, maximum=MAX_DRAWS)
        max_vertices = check_int(max_vertices, "max_vertices", minimum=0, maximum=MAX_DRAWS)
        executor = check_executor(executor)
        rng = np.random.default_rng(check_seed(seed))
        ds = box_draws(len(self.params), n_samples, max_vertices, rng)
        return envelope_of_draws(self, f, ds, executor)


def uncertain(model, dGamma=None, dOmega=None, db=None, dc=None, *, dpoles=None,
              dresidues=None) -> UncertainModel:
    """Build the structured uncertain model (5.5) of a normal mode model.

    Parameters
    ----------
    model : NormalModeModel
        Nominal model (``Omega``, ``Gamma``, ``phib``, ``cphi``; ``E``, ``F``, residual
        dynamics: certain parts, ``nominal`` is ``model.to_statespace()``).
    dGamma : array_like (n, n), optional
        Bound of each entry of ``Gamma`` (0 = certain). A symmetric pair is one parameter.
    dOmega : array_like (n, n), optional
        Bound of each entry of ``Omega`` (0 = certain). A symmetric pair is one parameter.
    db : array_like (n, na), optional
        Bound of each entry of ``phib``.
    dc : array_like (ns, n), optional
        Bound of each entry of ``cphi``.
    dpoles : array_like (m,), complex, optional
        Bounds on the real (``.real``) and imaginary (``.imag``) parts of the poles of the
        model's residual dynamics (``model.residual``, ``m`` poles), rad/s.
    dresidues : array_like (m, ns, na), complex, optional
        Bounds on the real and imaginary parts of their residues at the model's I/O.  With
        either, the residual dynamics are uncertain (:mod:`._residual_uncertainty`).

    Returns
    -------
    UncertainModel
    """
    n, ns, na = model.n, model.ns, model.na
    dG = _bound(dGamma, (n, n), "dGamma", True)
    dO = _bound(dOmega, (n, n), "dOmega", True)
    dB = _bound(db, (n, na), "db", False)
    dC = _bound(dc, (ns, n), "dc", False)
    params = []
    for kind, a in (("Omega", dO), ("Gamma", dG)):
        for i in range(n):
            for j in range(i, n):
                if a[i, j] > 0:
                    params.append((f"delta_{kind}_{i}_{j}", (kind, i, j), 1 if i == j else 2,
                                   float(a[i, j])))
    for i, j in zip(*np.nonzero(dB)):
        params.append((f"delta_b_{i}_{j}", ("b", int(i), int(j)), 1, float(dB[i, j])))
    for i, j in zip(*np.nonzero(dC)):
        params.append((f"delta_c_{i}_{j}", ("c", int(i), int(j)), 1, float(dC[i, j])))
    dP, dR = _residual_bounds(model, dpoles, dresidues)
    if dR is not None:
        params += residual_params(dP, dR)
    return UncertainModel(model, readonly(dG), readonly(dO), readonly(dB), readonly(dC), params,
                          dpoles=dP, dresidues=dR)


def _residual_bounds(model, dpoles, dresidues):
    """Checked bounds of the residual dynamics (complex, non-negative parts) or (None, None)."""
    if dpoles is None and dresidues is None:
        return None, None
    res = getattr(model, "residual", None)
    if res is None:
        raise ValueError("dpoles/dresidues bound residual dynamics, but the model has none "
                         "(model.residual is None)")
    out = []
    for arg, name, shape in ((dpoles, "dpoles", (res.m,)),
                             (dresidues, "dresidues", (res.m, model.ns, model.na))):
        a = np.zeros(shape, complex) if arg is None else as_array(arg, name, dtype=complex)
        if a.shape != shape or np.any(a.real < 0) or np.any(a.imag < 0):
            raise ValueError(f"{name} must hold non-negative bounds (real and imaginary parts) "
                             f"of shape {shape}, got shape {a.shape}")
        out.append(readonly(a))
    return tuple(out)
