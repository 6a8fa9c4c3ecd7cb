"""sdctrl: control-ready state-space models of lightly damped structures.

Implements E. Balmes, *Experimental/analytical predictive models of damped
structural dynamics*, MIT PhD thesis, 1993: complex-mode identification from
FRFs (chapter III), normal modes with non-proportional damping (3.3), FE
models and update (chapter IV), hybrid models, D-struts and structured
uncertainty (chapter V).  Every model converts to a python-control
``StateSpace``.

The public names (``../API.md``) are imported lazily so that ``import sdctrl``
computes nothing and stays fast.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

# public name -> module that defines it
_EXPORTS = {
    # data
    "FRF": "sdctrl.frf",
    "estimate_frf": "sdctrl.frf",
    "read_uff": "sdctrl.io",
    "write_uff": "sdctrl.io",
    "save_npz": "sdctrl.io",
    "load_npz": "sdctrl.io",
    # identification (chapter III)
    "ComplexModeModel": "sdctrl.identification",
    "initial_poles": "sdctrl.identification",
    "identify": "sdctrl.identification",
    "normal_modes": "sdctrl.identification",
    # modal models
    "NormalModeModel": "sdctrl.modal",
    # finite elements
    "FEModel": "sdctrl.fe",
    "testbed": "sdctrl.testbeds",
    "testbed_frf": "sdctrl.testbeds",
    "hybrid": "sdctrl.hybridmodel",
    # FE model update (chapter IV)
    "Parameter": "sdctrl.fe.parameters",
    "update": "sdctrl.updating",
    "UpdateResult": "sdctrl.updating",
    "identifiability": "sdctrl.updating",
    "Identifiability": "sdctrl.updating",
    # uncertainty and closed loop
    "UncertainModel": "sdctrl.uncertainty",
    "robust_stability": "sdctrl.robust",
    "rms": "sdctrl.closedloop",
    "RobustResult": "sdctrl.robust",
    "worst_case_gain": "sdctrl.robust",
    # closing the loop with measured data
    "diagnose": "sdctrl.diagnosis",
    "Diagnosis": "sdctrl.diagnosis",
    "Effect": "sdctrl.diagnosis",
    # saving models and results
    "save": "sdctrl.storage",
    "load": "sdctrl.storage",
}

__all__ = sorted(_EXPORTS)  # noqa: PLE0605 -- the export table is the single source


# submodules reachable as attributes (``sd.plot.bode``) without importing them up front
_SUBMODULES = ("config", "frf", "io", "modal", "identification", "fe", "testbeds", "hybridmodel",
               "uncertainty", "robust", "closedloop", "testing", "plot", "report", "updating",
               "storage", "diagnosis")


def __getattr__(name: str):
    if name in _SUBMODULES:
        return importlib.import_module(f"sdctrl.{name}")
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
