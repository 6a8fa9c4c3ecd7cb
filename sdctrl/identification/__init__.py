"""Chapter III of the thesis: complex-mode identification and normal modes from complex modes.

Public names are resolved lazily from the submodules:
``initial_poles`` (poles.py), ``identify`` (optimize.py), ``ComplexModeModel``
(complex_modes.py), ``normal_modes`` (proper.py).

The package is named ``identification`` (not ``identify``) so that ``sd.identify`` is a plain
function: picklable, documented by ``help()``, and never shadowed by a module.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "initial_poles": "sdctrl.identification.poles",
    "identify": "sdctrl.identification.optimize",
    "ComplexModeModel": "sdctrl.identification.complex_modes",
    "normal_modes": "sdctrl.identification.proper",
}

__all__ = ["ComplexModeModel", "identify", "initial_poles", "normal_modes"]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl.identification' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


