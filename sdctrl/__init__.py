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

__version__ = "0.2.0"

# public name -> module that defines it
_EXPORTS = {
    # measured data
    "FRF": "sdctrl.data",
    "estimate_frf": "sdctrl.data",
    "impact_frf": "sdctrl.data",
    "ImpactWarning": "sdctrl.data",
    "read_uff": "sdctrl.data",
    "write_uff": "sdctrl.data",
    # identification (chapter III)
    "ComplexModeModel": "sdctrl.identification",
    "initial_poles": "sdctrl.identification",
    "identify": "sdctrl.identification",
    "normal_modes": "sdctrl.identification",
    # normal-mode models (2.15)
    "NormalModeModel": "sdctrl.modal",
    # finite elements and the built-in structures
    "FEModel": "sdctrl.fe",
    "Parameter": "sdctrl.fe",
    "testbed": "sdctrl.testbeds",
    "testbed_frf": "sdctrl.testbeds",
    # FE model update (chapter IV)
    "update": "sdctrl.updating",
    "UpdateResult": "sdctrl.updating",
    "identifiability": "sdctrl.updating",
    "Identifiability": "sdctrl.updating",
    # hybrid models (5.1)
    "hybrid": "sdctrl.hybrids",
    "HybridModel": "sdctrl.hybrids",
    # uncertainty and robustness (5.2, 5.5)
    "UncertainModel": "sdctrl.robust",
    "robust_stability": "sdctrl.robust",
    "RobustResult": "sdctrl.robust",
    "uncertain_from_data": "sdctrl.robust",
    "worst_case_gain": "sdctrl.robust",
    # closed loops
    "feedback": "sdctrl.closedloop",
    "rms": "sdctrl.closedloop",
    "placement_study": "sdctrl.closedloop",
    "PlacementStudy": "sdctrl.closedloop",
    # closing the loop with measured data
    "diagnose": "sdctrl.diagnosis",
    "Diagnosis": "sdctrl.diagnosis",
    "Effect": "sdctrl.diagnosis",
    # saving models and results
    "save": "sdctrl.storage",
    "load": "sdctrl.storage",
}

__all__ = sorted(_EXPORTS)  # noqa: PLE0605 -- the export table is the single source


# packages reachable as attributes (``sd.plot.bode``) without importing them up front
_SUBMODULES = ("config", "data", "identification", "modal", "fe", "updating", "hybrids", "robust",
               "closedloop", "testbeds", "diagnosis", "storage", "plot", "report", "testing",
               "demo")


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
