"""Modules that share their name with their main function (internal).

``sdctrl.identify``, ``sdctrl.testbed`` and ``sdctrl.hybrid`` name both a (sub)module and
the public function it provides (API.md: ``sd.identify(frf)``, ``sd.testbed()``,
``sd.hybrid(fe, nm, c)``).  Importing a submodule binds the *module* to the package
attribute, so such a module is made callable: the call goes to its function of the same
name, and ``help``/``inspect.signature`` show that function's documentation (followed by
the module's notes) and signature.  The function is looked up at call time, so a package
that resolves it lazily (``sdctrl.identify``) imports nothing up front.
"""

from __future__ import annotations

import inspect
import sys
import types


class CallableModule(types.ModuleType):
    """A module whose call is its function of the same name."""

    def _function(self):
        return getattr(self, self.__name__.rsplit(".", 1)[-1])

    def __call__(self, *args, **kwargs):
        return self._function()(*args, **kwargs)

    @property
    def __doc__(self):
        notes = vars(self).get("_module_doc") or ""
        doc = inspect.getdoc(self._function()) or ""
        if not notes:
            return doc
        return doc + "\n\nModule notes\n------------\n" + inspect.cleandoc(notes)

    @property
    def __signature__(self):
        return inspect.signature(self._function())


def make_callable(module_name: str) -> None:
    """Make the module ``module_name`` callable as its function of the same name."""
    mod = sys.modules[module_name]
    mod._module_doc = vars(mod).get("__doc__")
    mod.__class__ = CallableModule
