"""Truncated normal-mode models (thesis section 2.1, eq. 2.15) and their state-space form.

``(s^2 I + s Gamma + Omega) p = phib u``, ``y = cphi p + E u`` with mass-normalised
modes: ``Omega`` (rad/s)^2, ``Gamma`` rad/s (full when damping is non-proportional),
``cphi`` (ns, n) modal observability, ``phib`` (n, na) modal controllability and
``E`` (ns, na) the static correction of truncated high-frequency modes (2.17).
An optional ``F`` (ns, na) adds the low-frequency (residual mass) correction ``F/s^2`` of
truncated low-frequency modes (2.15), (2.23)-(2.24).  Static correction modes (2.21)-(2.22)
are carried as ordinary modes (appended columns of ``cphi``/``phib``, critically damped
entries of ``Gamma``), as :meth:`sdctrl.FEModel.normal_mode_model` builds them with
``static=True``.  All modal quantities describe the displacement/force system.

The model-space algebra behind :meth:`NormalModeModel.modified` (reduced-coordinate
changes, 4.17) and :meth:`NormalModeModel.with_feedback` (D-strut loops, 5.3-5.4) lives
in :mod:`sdctrl.modal._operations`; reanalysis of changes given on physical DOFs is chapter IV's
:mod:`sdctrl.updating._reanalysis`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from sdctrl._lib.frozen import FrozenState
from sdctrl.modal._normal_realisation import to_statespace
from sdctrl.modal._operations import modified, poles, with_feedback
from sdctrl.modal._residual_dynamics import ResidualDynamics
from sdctrl._lib.display import MAX_ROWS, hz_range, markdown_table, one_line
from sdctrl._lib.validate import (
    QUANTITY_POWER,
    as_array,
    check_finite_result,
    check_freq,
    check_info,
    check_labels,
    check_modal_std,
    check_quantity,
    check_scalar,
    check_square,
    readonly,
)
from sdctrl._lib.signals import signal_names

__all__ = ["NormalModeModel", "frf", "modified", "poles", "to_statespace", "with_feedback"]



@dataclass(frozen=True, eq=False)
class NormalModeModel(FrozenState):
    """Truncated normal-mode model (2.15): ``(s^2 I + s Gamma + Omega) p = phib u``,
    ``y = cphi p + E u``.

    With a low-frequency correction ``F`` the displacement output is
    ``y = cphi p + (E + F/s^2) u`` (2.15), (2.24); with ``residual`` dynamics it adds
    ``sum_j R_j/(s - lambda_j) + conj(R_j)/(s - conj(lambda_j))`` (3.7) at the tested I/O.

    Parameters
    ----------
    Omega : array_like, shape (n, n)
        Modal stiffness in (rad/s)^2, ``diag(omega_j^2)`` for normal modes
        (symmetric; a full matrix is accepted after modifications).
    Gamma : array_like, shape (n, n)
        Modal damping in rad/s, symmetric; ``2 zeta_j omega_j`` on the diagonal for
        proportional damping, full for non-proportional damping.
    cphi : array_like, shape (ns, n)
        Modal observability (displacement sensors).
    phib : array_like, shape (n, na)
        Modal controllability.
    E : array_like, shape (ns, na), optional
        Static (residual flexibility) term of the displacement response.
    sensors, actuators : sequence of str, optional
        Labels of outputs and inputs (StateSpace signal names follow them).
    shapes : array_like, shape (N, n), optional
        Mode shapes on physical DOFs (FE-derived and hybrid models).
    dofs : sequence of str, optional
        Labels of the N physical DOFs of ``shapes``.
    omega_c : float, optional
        Cut-off (rad/s) of the critically damped correction mode used to realise
        ``E`` for velocity/acceleration outputs; default ten times the highest
        modal frequency.
    F : array_like, shape (ns, na), optional
        Low-frequency (residual mass) correction of truncated low-frequency modes: the
        displacement response carries ``F/s^2`` (2.23); ``to_statespace`` realises it with
        one correction mode per actuator, critically damped a decade below the band by
        default (``omega_f``), rigid-body (2.24) with ``rigid_body=True``.
    properness : Properness, optional
        How :func:`sdctrl.normal_modes` built the model from complex modes (3.3): see
        :class:`~sdctrl.identification._proper.Properness`; None for other models.
    transformation : array_like, shape (n, n), optional
        ``T`` of the last :meth:`modified` / :meth:`with_feedback` (old modal coordinates =
        ``T`` new ones); None for a model never re-diagonalised.
    n_static : int
        Static correction modes (2.21)-(2.22) among the modes: those appended last by
        ``FEModel.normal_mode_model(..., static=True)``, kind ``"static"`` of a hybrid.
    std : dict, optional
        One standard deviation of each entry of ``"Omega"``, ``"Gamma"``, ``"cphi"``,
        ``"phib"`` (arrays of their shapes) for an identified model; None without statistics.
        It covers the normal modes only (the residual dynamics have none).
    residual : ResidualDynamics, optional
        Complex-mode terms kept as they are (3.7): identified poles that did not become
        normal modes (out of band, or properness not enforceable), with the reason of each
        (:attr:`ResidualDynamics.reasons`).  They live at the tested I/O (labels ``sensors``
        and ``actuators`` of the block) and have no FE shapes: :meth:`frf` and
        :meth:`to_statespace` add them where the model's labels match; :meth:`modified`,
        :meth:`with_feedback` and ``with_io`` act on the normal modes and keep the block as
        it is.  None for models without.
    omega_f : float, optional
        Corner (rad/s) of the critically damped low-frequency correction modes realising
        ``F`` (``F (s + 3 w_f) / (s + w_f)^3``); default a tenth of the lower band edge
        (``properness.band``), else of the lowest natural frequency.
    """

    Omega: np.ndarray
    Gamma: np.ndarray
    cphi: np.ndarray
    phib: np.ndarray
    E: np.ndarray | None = None
    sensors: tuple[str, ...] | None = None
    actuators: tuple[str, ...] | None = None
    shapes: np.ndarray | None = None
    dofs: tuple[str, ...] | None = None
    omega_c: float | None = None
    info: dict = field(default_factory=dict, compare=False, repr=False)
    F: np.ndarray | None = None
    properness: object = None
    transformation: np.ndarray | None = None
    n_static: int = 0
    std: dict | None = field(default=None, compare=False, repr=False)
    residual: ResidualDynamics | None = None
    omega_f: float | None = None

    def __post_init__(self):
        Omega = check_square(self.Omega, "Omega")
        n = Omega.shape[0]
        Gamma = check_square(self.Gamma, "Gamma", n)
        cphi = as_array(self.cphi, "cphi", ndim=2)
        phib = as_array(self.phib, "phib", ndim=2)
        if cphi.shape[1] != n:
            raise ValueError(f"cphi must have shape (ns, n={n}), got {cphi.shape}")
        if phib.shape[0] != n:
            raise ValueError(f"phib must have shape (n={n}, na), got {phib.shape}")
        ns, na = cphi.shape[0], phib.shape[1]
        for name, X in (("Omega", Omega), ("Gamma", Gamma)):
            scale = max(np.abs(X).max(), 1e-300)
            if np.abs(X - X.T).max() > 1e-8 * scale:
                raise ValueError(f"{name} must be symmetric")
        E = None if self.E is None else as_array(self.E, "E (ns x na of cphi, phib)",
                                                 shape=(ns, na))
        F = None if self.F is None else as_array(self.F, "F (ns x na of cphi, phib)",
                                                 shape=(ns, na))
        shapes = None
        if self.shapes is not None:
            shapes = as_array(self.shapes, "shapes", ndim=2)
            if shapes.shape[1] != n:
                raise ValueError(f"shapes must have shape (N, n={n}), got {shapes.shape}")
        dofs = None
        if self.dofs is not None:
            if shapes is None:
                raise ValueError("dofs given without shapes")
            dofs = check_labels(self.dofs, shapes.shape[0], "dofs", "q")
        omega_c = check_scalar(self.omega_c, "omega_c", positive=True, optional=True)
        sets = object.__setattr__
        sets(self, "Omega", readonly(Omega))
        sets(self, "Gamma", readonly(Gamma))
        sets(self, "cphi", readonly(cphi))
        sets(self, "phib", readonly(phib))
        sets(self, "E", readonly(E))
        sets(self, "F", readonly(F))
        sets(self, "shapes", readonly(shapes))
        sets(self, "dofs", dofs)
        sets(self, "omega_c", omega_c)
        sets(self, "sensors", check_labels(self.sensors, ns, "sensors", "s"))
        sets(self, "actuators", check_labels(self.actuators, na, "actuators", "a"))
        sets(self, "info", check_info(self.info))
        if self.transformation is not None:
            sets(self, "transformation", readonly(check_square(self.transformation,
                                                               "transformation")))
        if isinstance(self.n_static, bool) or not isinstance(self.n_static, int | np.integer) \
                or self.n_static < 0:
            raise ValueError(f"n_static must be a non-negative integer, got {self.n_static!r}")
        sets(self, "n_static", int(self.n_static))
        sets(self, "std", check_modal_std(self.std, n, ns, na))
        if self.residual is not None and not isinstance(self.residual, ResidualDynamics):
            raise TypeError(f"residual must be a ResidualDynamics, got "
                            f"{type(self.residual).__name__}")
        sets(self, "omega_f", check_scalar(self.omega_f, "omega_f", positive=True,
                                           optional=True))

    # --- display ------------------------------------------------------------------
    def __repr__(self) -> str:
        G = self.Gamma
        full = self.n > 1 and np.count_nonzero(G - np.diag(np.diag(G))) > 0
        return one_line(type(self).__name__, [
            f"n={self.n}", f"ns={self.ns}", f"na={self.na}", f"band={hz_range(self.frequency)}",
            "full Gamma" if full else "", "E" if self.E is not None else "",
            "F" if self.F is not None else "",
            "" if self.residual is None else f"residual={self.residual.m} poles",
            "" if self.shapes is None else f"shapes on {self.shapes.shape[0]} DOFs"])

    def _repr_markdown_(self) -> str:
        w = 2 * np.pi * self.frequency
        with np.errstate(divide="ignore", invalid="ignore"):
            zeta = np.where(w > 0, np.diag(self.Gamma) / (2 * w), np.nan)
        rows = [(j + 1, f"{self.frequency[j]:.4g}", f"{100 * zeta[j]:.3g}")
                for j in range(self.n)]
        return (f"`{self!r}`\n\n" + markdown_table(
            ["mode", "frequency (Hz)", "damping (%) Gamma_jj / 2 w_j"], rows, MAX_ROWS))

    # --- sizes and modal data -----------------------------------------------------
    @property
    def n(self) -> int:
        """Number of modes."""
        return self.Omega.shape[0]

    @property
    def ns(self) -> int:
        """Number of sensors (outputs)."""
        return self.cphi.shape[0]

    @property
    def na(self) -> int:
        """Number of actuators (inputs)."""
        return self.phib.shape[1]

    @property
    def frequency(self) -> np.ndarray:
        """Undamped natural frequencies ``sqrt(diag(Omega)) / 2 pi`` in Hz."""
        return np.sqrt(np.clip(np.diag(self.Omega), 0, None)) / (2 * np.pi)

    @property
    def expanded(self) -> np.ndarray | None:
        """Alias of :attr:`shapes` (expanded mode shapes of hybrid models)."""
        return self.shapes

    @property
    def poles(self) -> np.ndarray:
        """Complex poles (rad/s) of the second-order system, Im >= 0, sorted by modulus."""
        return poles(self)

    def replace(self, **changes) -> NormalModeModel:
        """Copy with some fields changed (validated again; ``std`` dropped with new parameters)."""
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        kw["std"] = None if changes.keys() & {"Omega", "Gamma", "cphi", "phib"} else self.std
        kw.update(changes)
        return NormalModeModel(**kw)

    # --- doors into the module functions ------------------------------------------
    def modified(self, dmu=None, dGamma=None, dOmega=None) -> NormalModeModel:
        """Model after reduced-coordinate mass, damping and stiffness changes (4.17).

        See :func:`sdctrl.modal._operations.modified`.  Changes given on physical DOFs
        (``dM, dC, dK``) are :meth:`sdctrl.HybridModel.with_modification` (5.2).

        Parameters
        ----------
        dmu : array_like, shape (n, n), optional
            Change of the modal mass ``phi^T dM phi`` (symmetric).
        dGamma : array_like, shape (n, n), optional
            Change of the modal damping ``phi^T dC phi`` (rad/s, symmetric).
        dOmega : array_like, shape (n, n), optional
            Change of the modal stiffness ``phi^T dK phi`` ((rad/s)^2, symmetric).

        Returns
        -------
        NormalModeModel
            The :attr:`residual` dynamics (no shapes, no modal coordinates) are kept as
            they are, at the tested I/O.
        """
        return modified(self, dmu, dGamma, dOmega)

    def with_feedback(self, b, c, kp=0.0, kv=0.0, modal: bool = False) -> NormalModeModel:
        """Closed loop with relative force feedback ``F = -kv y' - kp y`` (D-strut, 5.3-5.4).

        See :func:`sdctrl.modal._normal_model.with_feedback`.

        Parameters
        ----------
        b : array_like, shape (N, k) or (n, k)
            Force input shapes on the DOFs of :attr:`shapes`, or ``phi^T b`` if ``modal``.
        c : array_like, shape (k, N) or (k, n)
            Measured relative displacements on the DOFs of :attr:`shapes`, or ``c phi``.
        kp : float or array_like, shape (k,) or (k, k)
            Position (stiffness) gain, force per unit displacement.
        kv : float or array_like, shape (k,) or (k, k)
            Velocity (damping) gain, force per unit velocity.
        modal : bool
            True when ``b`` and ``c`` are already modal (``phi^T b`` and ``c phi``).

        Returns
        -------
        NormalModeModel
            The loop acts on the normal modes; the :attr:`residual` dynamics are kept as
            they are, at the tested I/O (they have no shapes the strut could act on).
        """
        return with_feedback(self, b, c, kp, kv, modal)

    def proportional(self) -> NormalModeModel:
        """Copy with ``Gamma`` forced diagonal (proportional damping), for comparisons.

        Returns
        -------
        NormalModeModel
        """
        return self.replace(Gamma=np.diag(np.diag(self.Gamma)),
                            info={**self.info, "proportional": True})

    def uncertain(self, dGamma=None, dOmega=None, db=None, dc=None, *, dpoles=None,
                  dresidues=None):
        """Structured uncertain model (5.5); see :func:`sdctrl.robust._uncertainty.uncertain`.

        Parameters
        ----------
        dGamma : array_like, shape (n, n), optional
            Bound of each entry of ``Gamma`` (0 = certain); a symmetric pair is one parameter.
        dOmega : array_like, shape (n, n), optional
            Bound of each entry of ``Omega`` (0 = certain); a symmetric pair is one parameter.
        db : array_like, shape (n, na), optional
            Bound of each entry of ``phib``.
        dc : array_like, shape (ns, n), optional
            Bound of each entry of ``cphi``.
        dpoles, dresidues : array_like, optional
            Bounds on the :attr:`residual` dynamics' poles (m,) and residues (m, ns, na),
            real and imaginary parts in a complex array (see
            :func:`~sdctrl.robust._uncertainty.uncertain`).

        Returns
        -------
        UncertainModel
            The normal modes (and ``E``) with their bounds; the :attr:`residual` dynamics
            follow in every realisation, certain unless ``dpoles``/``dresidues`` bound them.

        Warns
        -----
        RuntimeWarning
            The model has :attr:`residual` dynamics and no bound is given for them.
        """
        from sdctrl.robust._uncertainty import uncertain

        if self.residual is not None and dpoles is None and dresidues is None:
            import warnings

            warnings.warn(f"uncertain: the residual dynamics ({self.residual.m} complex "
                          "pole(s), nm.residual) are certain in the uncertain model; bound "
                          "them with dpoles=/dresidues=, or from the identification's "
                          "statistics with sd.uncertain_from_data(nm)", RuntimeWarning,
                          stacklevel=2)
        return uncertain(self, dGamma=dGamma, dOmega=dOmega, db=db, dc=dc, dpoles=dpoles,
                         dresidues=dresidues)

    def frf(self, freq, quantity: str = "displacement"):
        """FRF of the model, eq. (2.15); see :func:`sdctrl.modal._normal_model.frf`.

        Parameters
        ----------
        freq : array_like
            Frequencies in Hz, strictly increasing and positive.
        quantity : {"displacement", "velocity", "acceleration"}
            Measured quantity of the returned FRF (``(j w)^k`` times the displacement FRF).

        Returns
        -------
        FRF
        """
        return frf(self, freq, quantity)

    def to_statespace(self, quantity: str = "displacement", omega_c: float | None = None, *,
                      rigid_body: bool = False):
        """python-control StateSpace with named signals, states ``[p; p']`` (2.15)-(2.24).

        See :func:`sdctrl.modal._normal_realisation.to_statespace` (the state count is in
        its notes).

        Parameters
        ----------
        quantity : {"displacement", "velocity", "acceleration"}
            Output quantity.
        omega_c : float, optional
            Cut-off (rad/s) of the critically damped correction mode realising ``E`` for
            velocity/acceleration outputs; default ten times the highest modal frequency.
        rigid_body : bool
            Realise ``F`` by the exact rigid-body modes (2.24), poles at 0; default False,
            stable correction modes a decade below the band (``omega_f``).

        Returns
        -------
        control.StateSpace
            Outputs named after the sensors, inputs after the actuators followed by ``_u``:
            ``2 n`` modal states, plus those of :attr:`residual`, of the ``E`` correction
            (velocity/acceleration, ``2 na``) and of ``F`` (``3 na``, ``2 na`` rigid).

        Warnings
        --------
        ``control.feedback(G, K)`` drops the signal names (its outputs become ``y[0]``,
        ``y[1]``, ... and its inputs ``u[0]``, ...) and ``control.interconnect`` numbers
        them unless told otherwise: close loops with :func:`sdctrl.feedback`, which keeps
        the plant's names.
        """
        return to_statespace(self, quantity, omega_c, rigid_body=rigid_body)


def frf(model: NormalModeModel, freq, quantity: str = "displacement"):
    """FRF of a normal-mode model, eq. (2.15), vectorised over frequency.

    ``H_d(s) = cphi (s^2 I + s Gamma + Omega)^-1 phib + E + F/s^2`` (plus the residual
    dynamics, 3.7, at the model's labels that match the block's) and
    ``H_q = (j w)^k H_d`` with ``k = 0, 1, 2`` for displacement, velocity,
    acceleration.

    Parameters
    ----------
    model : NormalModeModel
    freq : array_like
        Frequencies in Hz.
    quantity : {"displacement", "velocity", "acceleration"}

    Returns
    -------
    FRF
    """
    from sdctrl.data._frf import FRF

    f = check_freq(freq, "freq")
    q = check_quantity(quantity, "quantity")
    with np.errstate(all="ignore"):
        H = _frf_array(model, 2 * np.pi * f)
        H = H * ((1j * 2 * np.pi * f) ** QUANTITY_POWER[q])[:, None, None]
    check_finite_result(H, "the FRF", "freq or the model's Omega, Gamma, cphi, phib, E, F")
    return FRF(f, H, quantity=q, sensors=model.sensors, actuators=model.actuators)


def _frf_array(model: NormalModeModel, omega: np.ndarray) -> np.ndarray:
    """Displacement FRF array (nw, ns, na) at ``omega`` rad/s."""
    n = model.n
    s = 1j * omega
    if np.count_nonzero(model.Gamma - np.diag(np.diag(model.Gamma))) == 0 and \
            np.count_nonzero(model.Omega - np.diag(np.diag(model.Omega))) == 0:
        d = s[:, None] ** 2 + s[:, None] * np.diag(model.Gamma) + np.diag(model.Omega)
        H = np.einsum("in,wn,nj->wij", model.cphi, 1.0 / d, model.phib, optimize=True)
    else:
        Z = s[:, None, None] ** 2 * np.eye(n) + s[:, None, None] * model.Gamma + model.Omega
        X = np.linalg.solve(Z, np.broadcast_to(model.phib.astype(complex),
                                               (s.size,) + model.phib.shape))
        H = model.cphi @ X
    if model.E is not None:
        H = H + model.E
    if model.F is not None:
        H = H + model.F / (s[:, None, None] ** 2)
    if model.residual is not None:
        H = H + model.residual.frf_array(s, model.sensors, model.actuators)
    return H
