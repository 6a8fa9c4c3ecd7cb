"""Results of a diagnosis: :class:`Effect` and :class:`Diagnosis` with its markdown report."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sdctrl._lib.display import markdown_table

__all__ = ["EFFECT_KINDS", "Diagnosis", "Effect"]

#: the effect kinds (API.md, "Closing the loop with measured data")
EFFECT_KINDS = ("missing_mode", "nonproportional_damping", "residual_flexibility",
                "residual_mass", "added_damper", "mass_change", "stiffness_change", "delay")
_UNITS = {"c": "N s/m", "dk": "N/m", "dm": "kg", "tau": "s", "frequency": "Hz", "mass": "kg",
          "stiffness": "N/m", "damping": "", "relative": "", "scale": ""}


def _number(v, name):
    if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
        raise TypeError(f"{name} must be a number, got {type(v).__name__}")
    return float(v)


def _location(loc):
    if loc is None or isinstance(loc, str):
        return loc
    if isinstance(loc, int | float | np.floating) and not isinstance(loc, bool):
        return float(loc)
    if isinstance(loc, tuple | list) and all(isinstance(x, str) for x in loc):
        return tuple(loc)
    raise TypeError(f"location must be None, a label, a tuple of labels or a frequency, got "
                    f"{loc!r}")


def format_location(loc) -> str:
    """Readable location: a node pair ``N9-N14``, a label, a frequency or ``global``.

    Parameters
    ----------
    loc : object
        An effect's location.

    Returns
    -------
    str
    """
    if loc is None:
        return "global"
    if isinstance(loc, tuple):
        return "-".join(loc)
    if isinstance(loc, float):
        return f"{loc:.5g} Hz"
    return str(loc)


def format_parameters(params, std=None) -> str:
    """``name = value +- std unit`` of fitted sizes (arrays summarised by their norm).

    Parameters
    ----------
    params : dict
        Fitted sizes.
    std : dict, optional
        Their standard deviations (shown as ``+- s`` when finite).

    Returns
    -------
    str
    """
    out = []
    std = std or {}
    for k, v in params.items():
        s = std.get(k)
        pm = s is not None and np.ndim(s) == 0 and np.isfinite(s)
        if isinstance(v, np.ndarray):
            out.append(f"{k}: {v.shape[0]}x{v.shape[1] if v.ndim > 1 else 1} matrix "
                       f"(max {np.abs(v).max():.3g})")
        elif k == "relative":
            out.append(f"relative = {100 * v:+.3g}%" + (f" +- {100 * s:.2g}%" if pm else ""))
        else:
            unit = _UNITS.get(k, "rad/s" if k.startswith("Gamma_") else "")
            out.append(f"{k} = {v:.5g}" + (f" +- {s:.2g}" if pm else "")
                       + (f" {unit}" if unit else ""))
    return ", ".join(out)


@dataclass(frozen=True, eq=False)
class Effect:
    """An effect the model lacked, fitted to the data.

    Parameters
    ----------
    kind : str
        One of :data:`EFFECT_KINDS`.
    location : str, tuple of str, float or None
        What it applies to, in the FE model's own labels: a node pair (``("N9", "N14")``,
        an element or not) for ``added_damper``/``stiffness_change``, a node name for
        ``mass_change``, the DOF label a resonator is attached to (``"N33.z"``) or the
        frequency (Hz) of a free extra mode for ``missing_mode``, an actuator label for a
        per-actuator residual term; None when global (delay, damping matrix, all channels).
    parameters : dict
        Fitted sizes in SI units: ``c`` (N s/m), ``dk`` (N/m, along the element's axis;
        ``relative`` = ``dk / (EA/L)`` for an element), ``dm`` (kg), ``tau`` (s),
        ``frequency`` (Hz) and ``damping`` (ratio) for a missing mode, with a free mode's
        observability ``cphi`` at the data sensors and controllability ``phib`` at the data
        actuators (displacement per unit force, only ``cphi phib^T`` determined; ``mass`` kg and
        ``stiffness`` N/m for a resonator), ``E``/``F`` matrices for residual terms,
        ``Gamma_i_j`` (rad/s, modes numbered from 1) for non-proportional damping.
    error_before : float
        Complex logLS cost (3.12) of the model before the effect.
    error_after : float
        Same cost with the effect.
    std : dict, optional
        Like ``parameters``: one standard deviation of each fitted size, the larger of the
        noise's (Cramer-Rao bound of the fit) and the scatter the data show between sensors
        (leave-one-sensor-out, which also holds model error the noise does not:
        :mod:`sdctrl.diagnosis._effect_statistics`); empty when unknown.
    """

    kind: str
    location: object
    parameters: dict
    error_before: float
    error_after: float
    std: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.kind not in EFFECT_KINDS:
            raise ValueError(f"kind must be one of {EFFECT_KINDS}, got {self.kind!r}")
        if not isinstance(self.parameters, dict):
            raise TypeError("parameters must be a dict")
        sets = object.__setattr__
        sets(self, "location", _location(self.location))
        params = {}
        for k, v in self.parameters.items():
            if not isinstance(k, str):
                raise TypeError(f"parameters: names must be strings, got {k!r}")
            if isinstance(v, np.ndarray) and v.dtype.kind in "iuf":
                v = np.array(v, float)
                v.setflags(write=False)
            else:
                v = _number(v, f"parameters[{k!r}]")
            params[k] = v
        sets(self, "parameters", params)
        if not isinstance(self.std, dict) or not set(self.std) <= set(params):
            raise TypeError("std must be a dict of standard deviations of the parameters")
        sets(self, "std", {k: (np.array(v, float) if isinstance(v, np.ndarray)
                               else _number(v, f"std[{k!r}]")) for k, v in self.std.items()})
        for name in ("error_before", "error_after"):
            sets(self, name, _number(getattr(self, name), name))

    def __repr__(self) -> str:
        return (f"Effect({self.kind!r}, {format_location(self.location)}, "
                f"{format_parameters(self.parameters, self.std)}, "
                f"error {self.error_before:.3g} -> "
                f"{self.error_after:.3g})")

    @property
    def reduction(self) -> float:
        """Relative error reduction ``1 - error_after / error_before``."""
        return 1.0 - self.error_after / self.error_before if self.error_before > 0 else 0.0


def _sized(prop, model):
    """A non-proportional damping proposal cut (or padded) to the modes of ``model``."""
    if prop["action"] != "gamma":
        return prop
    from sdctrl.diagnosis._apply import DelayedModel

    inner = model.model if isinstance(model, DelayedModel) else model
    dG, n = np.asarray(prop["payload"]["dGamma"]), np.asarray(inner.Gamma).shape[0]
    if dG.shape[0] == n:
        return prop
    out = np.zeros((n, n))
    m = min(n, dG.shape[0])
    out[:m, :m] = dG[:m, :m]
    return dict(prop, payload=dict(prop["payload"], dGamma=out))


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`sdctrl.diagnose`.

    Parameters
    ----------
    model : model
        The corrected model (``.frf``, ``.to_statespace``): the input model with every
        effect of :attr:`effects` added (a :class:`~sdctrl.diagnosis.DelayedModel` when a
        delay was found).
    effects : list of Effect
        Effects added, in order (the most significant first).
    error_before : float
        Complex logLS cost (3.12) of the input model against the data.
    error_after : float
        Same cost for :attr:`model`.
    initial : model
        The input model.
    frf : FRF
        The data (band used).
    noise : float
        Noise level: expected cost of the measurement noise alone.
    steps : list of dict
        Per step: ``"accepted"`` (bool), ``"candidates"`` (the best fitted candidates:
        ``kind``, ``location``, ``parameters``, ``cost``, ``k`` parameters, ``m``
        hypotheses, ``score`` the extended-BIC gain, ``false_alarm`` the probability
        that noise alone explains its gain in the step's search), best first, and
        ``"rejected"`` (``kind``, ``location``, ``reason`` of the significant candidates
        passed over because their joint refit moved a free mode onto its region's edge),
        ``"dropped"`` (earlier effects, a free mode or a residual term, that the step's
        effect made redundant, as accepted) and, for a scan not run because no effect
        could pass the share test any more, ``"skipped"`` (why, with the figures).
    info : dict
        Counts of candidates, timings, options.
    built : str or None
        What :func:`sdctrl.diagnose` built to place the given model on the FE model (a
        hybrid model of a model without shapes), or why it could not; None when the model
        was used as given.
    applied : tuple of dict
        The fitted effects as :func:`sdctrl.diagnose` applies them (plain data, one per
        entry of :attr:`effects`, their sizes jointly refitted): what
        :meth:`with_effects` applies.
    """

    model: object
    effects: list
    error_before: float
    error_after: float
    initial: object = None
    frf: object = None
    noise: float = 0.0
    steps: list = field(default_factory=list)
    info: dict = field(default_factory=dict, repr=False)
    built: str | None = None
    applied: tuple = ()

    def __post_init__(self):
        if not all(isinstance(e, Effect) for e in self.effects):
            raise TypeError("effects must be a list of Effect")
        sets = object.__setattr__
        sets(self, "effects", list(self.effects))
        sets(self, "steps", list(self.steps))
        sets(self, "info", dict(self.info))
        for name in ("error_before", "error_after", "noise"):
            v = _number(getattr(self, name), name)
            if math.isnan(v) or v < 0:
                raise ValueError(f"{name} must be a non-negative cost, got {v}")
            sets(self, name, v)

    def __repr__(self) -> str:
        kinds = ", ".join(f"{e.kind} at {format_location(e.location)}" for e in self.effects)
        return (f"Diagnosis({len(self.effects)} effect(s){': ' + kinds if kinds else ''}; "
                f"error {self.error_before:.3g} -> {self.error_after:.3g})")

    def _repr_markdown_(self) -> str:
        return self.report()

    @property
    def scanned(self) -> dict[str, int]:
        """Physical candidate locations scanned, per kind of location: ``"pairs"`` (dampers,
        stiffness changes), ``"nodes"`` (masses), ``"dofs"`` (resonators) and, with beams,
        ``"members"``; empty when no physical candidate was scanned."""
        return dict(self.info.get("candidates", {}))

    def residual(self, after: bool = True):
        """Residual analysis of the corrected (or the input) model against the data.

        Parameters
        ----------
        after : bool
            The corrected model (default) or the input model.

        Returns
        -------
        ResidualMap
        """
        from sdctrl.diagnosis._placed_data import place
        from sdctrl.diagnosis._residual_map import residual_map

        model = self.model if after else self.initial
        placed = place(model, self.frf)
        return residual_map(placed.freq, placed.response(model), placed.Hd,
                            placed.sensors, placed.actuators, self.noise)

    def with_effects(self, which) -> object:
        """The input model with some of the effects only, at their fitted sizes.

        Parameters
        ----------
        which : iterable of int
            Indices into :attr:`effects` (applied in the order found).

        Returns
        -------
        model
            :attr:`initial` with those effects added (all of them: :attr:`model` up to
            round-off).  Non-proportional damping fitted on a model that an earlier effect
            extended (static correction modes of a load, an extra mode) keeps its terms
            between the modes of the model it is applied to.

        Raises
        ------
        ValueError
            An index out of range, or a diagnosis without its fitted effects.
        """
        from sdctrl.diagnosis._apply import DelayedModel, apply_effect
        from sdctrl.diagnosis._placed_data import place

        keep = sorted({int(k) for k in which})
        if any(k < 0 or k >= len(self.effects) for k in keep):
            raise ValueError(f"which must hold indices of effects (0 to "
                             f"{len(self.effects) - 1}), got {keep}")
        if len(self.applied) != len(self.effects) or self.initial is None:
            raise ValueError("with_effects: this diagnosis does not carry its fitted effects")
        model = self.initial
        inner = model.model if isinstance(model, DelayedModel) else model
        placed = place(inner, self.frf)
        for k in keep:
            model = apply_effect(model, _sized(self.applied[k], model), placed)
        return model

    def table(self) -> str:
        """Markdown table of the effects added.

        Returns
        -------
        str
        """
        rows = [(i + 1, e.kind, format_location(e.location), format_parameters(e.parameters, e.std),
                 f"{e.error_before:.4g}", f"{e.error_after:.4g}", f"{100 * e.reduction:.3g}%")
                for i, e in enumerate(self.effects)]
        return markdown_table(["#", "effect", "location", "fitted parameters",
                               "error before", "error after", "reduction"], rows)

    def report(self, figure: str | None = None) -> str:
        """Markdown report: effects, fitted parameters and locations, errors before and
        after, runner-up candidates with their costs, where the residual concentrates.

        Parameters
        ----------
        figure : str, optional
            Path of a figure (e.g. written by :func:`sdctrl.plot.diagnosis`) to reference.

        Returns
        -------
        str
        """
        lines = ["# Diagnosis", ""]
        lines.append(f"Complex logLS error (3.12): **{self.error_before:.4g}** before, "
                     f"**{self.error_after:.4g}** after "
                     f"({self.error_after / self.error_before:.3g} of it)."
                     if self.error_before > 0 else "The model reproduces the data exactly.")
        lines += ["", f"Noise level (second differences of the residual): {self.noise:.3g}.",
                  ""]
        if self.built:
            lines += [f"Model used: {self.built}.", ""]
        if self.scanned:
            how = ("the caller's list" if self.info.get("listed") else
                   "every element and node, and unconnected pairs within reach")
            lines += ["Physical locations scanned (" + how + "): " + ", ".join(
                f"{n} {k}" for k, n in self.scanned.items()) + ".", ""]
        if self.effects:
            lines += ["## Effects added", "", self.table(), ""]
        else:
            lines += [("No effect helps enough: the model matches the data within its noise "
                      "(or no candidate is significant)."), ""]
        if self.frf is not None and self.initial is not None:
            lines += ["## Where the residual was", ""]
            lines += [f"- {t}" for t in self.residual(after=False).findings()] + [""]
            if self.effects:
                lines += ["After the corrections:", ""]
                lines += [f"- {t}" for t in self.residual(after=True).findings()] + [""]
        for i, st in enumerate(self.steps):
            verdict = "added" if st.get("accepted") else "none added"
            lines += [f"## Step {i + 1}: candidates ({verdict})", ""]
            if st.get("skipped"):
                lines += [f"Candidates {st['skipped']}.", ""]
                continue
            rows = [(c["kind"], format_location(c["location"]),
                     format_parameters(c["parameters"]), f"{c['cost']:.4g}", c["k"], c["m"],
                     f"{c['score']:.4g}") for c in st.get("candidates", [])]
            lines += [markdown_table(["effect", "location", "fitted parameters", "error",
                                      "params k", "hypotheses m", "EBIC gain"], rows), ""]
            lines += [f"- passed over: {r['kind']} at {format_location(r['location'])} "
                      f"({r['reason']})" for r in st.get("rejected", [])]
            lines += [f"- dropped: {d['kind']} at {format_location(d['location'])} (no "
                      "longer significant given the others)" for d in st.get("dropped", [])]
            lines += [""] if st.get("rejected") or st.get("dropped") else []
        if figure:
            lines += [f"![before/after and residual map]({figure})", ""]
        return "\n".join(lines)
