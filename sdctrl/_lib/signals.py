"""Signal names of the StateSpace models sdctrl emits, and systems taken as arguments
(internal): outputs after sensors, inputs after actuators with the ``_u`` suffix (API.md), so that
python-control's ``interconnect`` never joins a collocated pair by name.
"""

from __future__ import annotations

import numpy as np

__all__ = ["INPUT_SUFFIX", "as_statespace", "signal_name", "signal_names"]

INPUT_SUFFIX = "_u"


def signal_name(label: str) -> str:
    """python-control signal name of a label.

    python-control 0.10 refuses ``.`` in a signal name (it separates system and signal in
    ``interconnect`` references), so each ``.`` becomes ``_``; a leading ``-`` (read as a
    negative gain in those references) becomes ``_`` too.  ``"N42.y"`` -> ``"N42_y"``.
    """
    name = str(label).replace(".", "_")
    return "_" + name[1:] if name.startswith("-") else name


def _unique(names: list[str], labels, what: str) -> None:
    seen: dict[str, object] = {}
    for name, lab in zip(names, labels):
        if name in seen:
            raise ValueError(f"{what}: labels {seen[name]!r} and {lab!r} both become the signal "
                             f"name {name!r} (python-control signal names replace '.' by '_'); "
                             "rename one of them")
        seen[name] = lab


def signal_names(sensors, actuators, *, sensors_name: str = "sensors",
                 actuators_name: str = "actuators", extra_inputs=(), extra_outputs=()
                 ) -> tuple[list[str], list[str]]:
    """Input and output signal names of a StateSpace sdctrl emits (API.md "Conventions").

    Outputs are the sensor labels, inputs the actuator labels followed by ``_u``, both
    through :func:`signal_name`.  Colliding labels raise instead of being renamed, so that
    every name stays predictable from its label: python-control's ``interconnect`` joins
    equal names silently, and a system that lost a name would be joined wrongly.

    Parameters
    ----------
    sensors, actuators : sequence of str
        Output and input labels.
    sensors_name, actuators_name : str
        Argument names used in error messages.
    extra_inputs, extra_outputs : sequence of str
        Signal names placed before the labelled ones (e.g. the Delta channels of an LFT),
        checked for collisions too.

    Returns
    -------
    inputs, outputs : list of str

    Raises
    ------
    ValueError
        Two labels of one side map to the same name (``"a.b"`` and ``"a_b"``), or an input
        and an output share a name (sensor ``"f_u"`` and actuator ``"f"``).
    """
    inputs = list(extra_inputs) + [signal_name(a) + INPUT_SUFFIX for a in actuators]
    outputs = list(extra_outputs) + [signal_name(s) for s in sensors]
    _unique(inputs, list(extra_inputs) + list(actuators), actuators_name)
    _unique(outputs, list(extra_outputs) + list(sensors), sensors_name)
    both = sorted(set(inputs) & set(outputs))
    if both:
        raise ValueError(f"{sensors_name}, {actuators_name}: signal name {both[0]!r} would be "
                         "both an input and an output (python-control's interconnect would "
                         "join them into a loop); rename the label")
    return inputs, outputs


def as_statespace(sys, name: str = "sys"):
    """A continuous-time ``control.StateSpace`` from a StateSpace, a transfer function or
    any sdctrl model with ``to_statespace()`` (displacement outputs).

    Parameters
    ----------
    sys : control.StateSpace, control.TransferFunction or model
        The system.
    name : str
        Argument name used in error messages.

    Returns
    -------
    control.StateSpace
    """
    import control

    if isinstance(sys, control.StateSpace):
        G = sys
    elif isinstance(sys, control.TransferFunction):
        G = control.ss(sys)
    elif hasattr(sys, "to_statespace"):
        G = sys.to_statespace()
    else:
        raise TypeError(f"{name} must be a control.StateSpace, a TransferFunction or a model "
                        f"with to_statespace(), got {type(sys).__name__}")
    if G.dt not in (0, None):
        raise ValueError(f"{name} must be a continuous-time system, got dt={G.dt}")
    for m in "ABCD":
        if not np.all(np.isfinite(np.asarray(getattr(G, m)))):
            raise ValueError(f"{name} must have finite state-space matrices: {m} holds "
                             "non-finite values (NaN/inf)")
    return G
