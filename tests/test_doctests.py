"""The ``Examples`` sections of every sdctrl module run in the suite (they are the first code a
reader copies; a broken one is a bug).  Each module's examples see that module's namespace,
as ``python -m doctest`` would."""

import doctest
import importlib
import pathlib

import numpy as np
import pytest

import sdctrl as sd

ROOT = pathlib.Path(sd.__file__).resolve().parent


def _modules():
    out = []
    for path in sorted(ROOT.rglob("*.py")):
        if ">>>" not in path.read_text():
            continue
        parts = ("sdctrl",) + path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append(".".join(parts))
    return out


@pytest.mark.parametrize("module", _modules())
def test_examples_run(module, monkeypatch):
    monkeypatch.setattr(sd.config, "progress", False)      # no bars in the expected output
    mod = importlib.import_module(module)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(mod, module) if t.examples]
    assert tests, f"{module} has '>>>' but no doctest was found"
    with np.printoptions(legacy=False):
        for t in tests:
            runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {module}"
