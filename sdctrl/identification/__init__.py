"""Chapter III of the thesis: complex-mode identification and normal modes from complex modes.

Public names are resolved lazily from the submodules:
``initial_poles`` (poles.py), ``identify`` and ``IdentificationWarning`` (fit.py),
``ComplexModeModel`` (complex_modes.py, with the fit's records in fit_records.py),
``normal_modes`` (proper.py: properness 3.40-3.54 in properness.py, the transformation 3.44
in reduced_matrices.py).  The pole search
of ``identify`` is cut along the thesis: data compression (compression.py), the pole
update (3.18)-(3.19) (search.py), the noise field and significance test (noise.py), the
missed-mode scan (scan.py) and the automatic pole selection (selection.py).

The package is named ``identification`` (not ``identify``) so that ``sd.identify`` is a plain
function: picklable, documented by ``help()``, and never shadowed by a module.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "initial_poles": "sdctrl.identification._peaks",
    "identify": "sdctrl.identification._complex_fit",
    "IdentificationWarning": "sdctrl.identification._complex_fit",
    "ComplexModeModel": "sdctrl.identification._complex_modes",
    "normal_modes": "sdctrl.identification._proper",
}

__all__ = ["ComplexModeModel", "IdentificationWarning", "identify", "initial_poles",
           "normal_modes"]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl.identification' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


