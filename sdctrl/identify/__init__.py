"""Chapter III of the thesis: complex-mode identification and normal modes from complex modes.

Public names are resolved lazily from the submodules:
``initial_poles`` (poles.py), ``identify`` (optimize.py), ``ComplexModeModel``
(complex_modes.py), ``normal_modes`` (proper.py).

``sdctrl.identify`` is both this package and the public function of the same name
(API.md: ``sd.identify(frf, poles=None, band=None)``): calling the package calls
:func:`sdctrl.identify.optimize.identify`, so ``sd.identify(frf)`` works whichever of the
two the attribute resolves to.
"""

from __future__ import annotations

import importlib

from sdctrl._callable import make_callable

_EXPORTS = {
    "initial_poles": "sdctrl.identify.poles",
    "identify": "sdctrl.identify.optimize",
    "ComplexModeModel": "sdctrl.identify.complex_modes",
    "normal_modes": "sdctrl.identify.proper",
}

__all__ = ["ComplexModeModel", "identify", "initial_poles", "normal_modes"]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sdctrl.identify' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


make_callable(__name__)
