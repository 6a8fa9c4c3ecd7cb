"""A D-strut closed through python-control, for tests that check ``with_feedback`` (5.3-5.4).

sdctrl has one route to a D-strut, :meth:`sdctrl.NormalModeModel.with_feedback`; these helpers
build the same loop the long way (a strut channel on the plant, a static controller, the
name-keeping :func:`sdctrl.feedback`), an independent path for the tests to compare with.
"""

from dataclasses import fields

import control
import numpy as np

from sdctrl._lib.signals import signal_name, signal_names


def rate_outputs(sys, outputs=None):
    """Append the time derivative of outputs, ``y' = C A x + C B u`` (named ``<y>_dot``)."""
    A, B, C, D = (np.asarray(X, float) for X in (sys.A, sys.B, sys.C, sys.D))
    names = list(sys.output_labels)
    sel = list(range(len(names))) if outputs is None else [names.index(o) for o in outputs]
    assert not np.any(D[sel]), "a differentiated output has a feedthrough"
    Cs = C[sel]
    return control.ss(A, B, np.vstack([C, Cs @ A]), np.vstack([D, Cs @ B]),
                      inputs=list(sys.input_labels),
                      outputs=names + [f"{names[i]}_dot" for i in sel],
                      states=list(sys.state_labels))


def strut_plant(model, b, name: str = "strut"):
    """StateSpace of ``model`` plus a strut channel: input ``name_u`` (axial force ``b``),
    outputs ``name`` (extension ``b^T q``) and ``name_dot``; a hybrid model that carries its
    FE model gets the strut's static correction first, as in its ``with_feedback``."""
    bb = np.asarray(b, float).reshape(-1, 1)
    if getattr(model, "static_ready", False):
        model = model.with_static(bb)
    changes = {"phib": np.hstack([model.phib, model.shapes.T @ bb]),
               "cphi": np.vstack([model.cphi, bb.T @ model.shapes]),
               "actuators": tuple(model.actuators) + (name,),
               "sensors": tuple(model.sensors) + (name,)}
    for f in fields(model):
        if f.name in ("E", "F") and getattr(model, f.name) is not None:
            changes[f.name] = np.pad(getattr(model, f.name), ((0, 1), (0, 1)))
    G = model.replace(**changes).to_statespace("displacement")
    return rate_outputs(G, [signal_name(name)])


def strut_controller(kp=0.0, kv=0.0, name: str = "strut"):
    """Static D-strut controller ``F = kp y + kv y'``, closed with negative feedback (5.3)."""
    (force,), (extension,) = signal_names([name], [name])
    return control.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[kp, kv]],
                      inputs=[extension, f"{extension}_dot"], outputs=[force], name="dstrut")
