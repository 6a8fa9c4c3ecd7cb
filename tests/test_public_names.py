"""Examples, notebooks, the README's python blocks and the benchmarks use only public names.

A public name is ``sd.X`` with ``X`` in ``sdctrl.__all__`` (or a public package such as
``sd.plot``), or ``sd.<package>.X`` with ``X`` in that package's ``__all__``; no module path nor
attribute has a private (``_``) part.  ``sd.closedloop.signal_name`` or ``sdctrl.data._frf`` in
an example teach users names that may change without notice.
"""

import ast
import importlib
import importlib.util
import json
import pathlib
import pkgutil
import re
from collections import defaultdict

import pytest

import sdctrl as sd

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def _public_module(path: str) -> str | None:
    """Why module ``path`` (dotted, ``sdctrl...``) is not a public module, or None."""
    if any(_private(p) for p in path.split(".")):
        return f"module {path} has a private part"
    try:
        importlib.import_module(path)
    except ImportError:
        return f"no module {path}"
    return None


def _resolve(module: str, attrs: list[str]) -> str | None:
    """Why ``module.attrs[0].attrs[1]...`` is not a public path, or None.

    Walks the chain while it names modules: each step must be a public submodule or a name in
    the module's ``__all__``; past the first non-module object (a class, a function) only
    private parts are refused (methods and attributes of models are the user's to call).
    """
    mod = importlib.import_module(module)
    for i, name in enumerate(attrs):
        path = ".".join([module] + attrs[:i + 1])
        if _private(name):
            return f"{path}: private name"
        if mod is None:
            continue
        sub = f"{mod.__name__}.{name}"
        if importlib.util.find_spec(sub) if _is_package(mod) else False:
            mod = importlib.import_module(sub)
            continue
        if name not in getattr(mod, "__all__", ()):
            return f"{path}: {name!r} is not in {mod.__name__}.__all__"
        mod = None                                  # an object: only '_' parts are checked
    return None


def _is_package(mod) -> bool:
    return hasattr(mod, "__path__")


def violations(code: str) -> list[str]:
    """Every import or attribute path of ``code`` that is not public (see module docstring)."""
    tree = ast.parse(code)
    for parent in ast.walk(tree):
        for child in ast.iter_child_nodes(parent):
            child.parent = parent
    aliases: dict[str, str] = {}                    # local name -> sdctrl module it binds
    out: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] != "sdctrl":
                    continue
                if (why := _public_module(a.name)) is not None:
                    out.append(f"line {node.lineno}: import {a.name}: {why}")
                elif a.asname:
                    aliases[a.asname] = a.name
                else:
                    aliases["sdctrl"] = "sdctrl"
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "sdctrl":
            if (why := _public_module(node.module)) is not None:
                out.append(f"line {node.lineno}: from {node.module}: {why}")
                continue
            for a in node.names:
                if (why := _resolve(node.module, [a.name])) is not None:
                    out.append(f"line {node.lineno}: from {node.module} import {a.name}: {why}")
                elif _is_package(importlib.import_module(node.module)) and importlib.util.find_spec(
                        f"{node.module}.{a.name}"):
                    aliases[a.asname or a.name] = f"{node.module}.{a.name}"
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and not isinstance(getattr(node, "parent", None),
                                                              ast.Attribute):
            chain, base = [], node
            while isinstance(base, ast.Attribute):
                chain.append(base.attr)
                base = base.value
            chain.reverse()
            if isinstance(base, ast.Name) and base.id in aliases:
                why = _resolve(aliases[base.id], chain)
            else:
                bad = [c for c in chain if _private(c)]
                why = f"private attribute {bad[0]}" if bad else None
            if why is not None:
                out.append(f"line {node.lineno}: {ast.unparse(node)}: {why}")
    return sorted(set(out))


def _notebook_code(path: pathlib.Path) -> str:
    cells = json.loads(path.read_text())["cells"]
    lines = []
    for cell in cells:
        if cell["cell_type"] != "code":
            continue
        src = "".join(cell["source"])
        lines += [ln for ln in src.splitlines() if not ln.lstrip().startswith(("%", "!"))]
        lines.append("")
    return "\n".join(lines)


def _readme_code() -> str:
    text = (ROOT / "README.md").read_text()
    return "\n".join(re.findall(r"^```python\n(.*?)^```", text, re.DOTALL | re.MULTILINE))


SOURCES = ([(p.relative_to(ROOT).as_posix(), p.read_text)
            for p in sorted((ROOT / "examples").glob("*.py"))]
           + [(p.relative_to(ROOT).as_posix(), lambda p=p: _notebook_code(p))
              for p in sorted((ROOT / "notebooks").glob("*.ipynb"))]
           + [("README.md", _readme_code)]
           + [(p.relative_to(ROOT).as_posix(), p.read_text)
              for p in sorted((ROOT / "benchmarks").glob("*.py"))])


@pytest.mark.parametrize("name,read", SOURCES, ids=[s[0] for s in SOURCES])
def test_only_public_names(name, read):
    bad = violations(read())
    assert not bad, f"{name} uses names that are not public:\n" + "\n".join(bad)


def test_sources_found():
    names = [s[0] for s in SOURCES]
    assert sum(n.startswith("examples/") for n in names) >= 5
    assert sum(n.startswith("notebooks/") for n in names) >= 7
    assert "README.md" in names and "sd.placement_study" in _readme_code()


@pytest.mark.parametrize("code", [
    "import sdctrl as sd\nsd.closedloop.signal_name('a')",
    "import sdctrl as sd\nsd.closedloop._loops.feedback",
    "import sdctrl as sd\nsd.plot.not_a_plot(1)",
    "import sdctrl as sd\nsd.not_a_name",
    "import sdctrl as sd\nm = sd.testbed()\nm._cache",
    "import sdctrl as sd\nsd.NormalModeModel._realise",
    "from sdctrl.data._frf import ss_frf",
    "from sdctrl.testbeds import _truss as tb",
    "from sdctrl.closedloop import strut_plant",
    "import sdctrl.robust._uncertainty",
    "import sdctrl.robust.mu as mu\nmu.Factored",
    "from sdctrl import plot as p\np.stabilization",
])
def test_checker_refuses_private_or_unlisted(code):
    assert len(violations(code)) == 1, violations(code)


def test_checker_accepts_public_paths():
    code = ("import numpy as np\nimport sdctrl as sd\nfrom sdctrl import plot\n"
            "from sdctrl.robust.mu import dg_upper\nfrom sdctrl.testing import record_rms\n"
            "m = sd.testbed()\nsd.plot.bode(m.frf(np.linspace(1, 2, 3)))\n"
            "sd.NormalModeModel.modified\n"
            "sd.robust.mu.BlockStructure\nplot.mac\nsd.closedloop.feedback\nnp.__version__\n")
    assert violations(code) == []


# ----------------------------------------------------------------------------------------
# one way to do each thing: one home per public object, one meaning per public name
# ----------------------------------------------------------------------------------------
def _exports():
    """(package, name, object) of every name in a public package's ``__all__``."""
    out = []
    for info in pkgutil.walk_packages(sd.__path__, "sdctrl."):
        if any(_private(p) for p in info.name.split(".")):
            continue
        mod = importlib.import_module(info.name)
        out += [(info.name, n, getattr(mod, n)) for n in getattr(mod, "__all__", ())]
    return out


def test_one_home_per_public_class_and_function():
    """``sd.X`` re-exports a package's ``X``; no second package exports it as well (e.g.
    ``Parameter`` lives in ``sdctrl.fe``, not also in ``sdctrl.updating``)."""
    homes = defaultdict(list)
    for pkg, name, obj in _exports():
        if callable(obj):
            homes[id(obj)].append(f"{pkg}.{name}")
    twice = [v for v in homes.values() if len(v) > 1]
    assert not twice, twice
    assert sd.Parameter is sd.fe.Parameter and "Parameter" not in sd.updating.__all__


def test_each_public_name_means_one_thing():
    """A name exported by two packages would be two things (as ``KINDS`` was: the effect kinds
    of a diagnosis and the block kinds of a mu structure).  ``sdctrl.plot`` is exempt by its
    convention: ``sd.plot.X`` draws the figure of X (``sd.plot.mac`` draws the MAC matrix that
    ``sd.updating.mac`` computes)."""
    where = defaultdict(set)
    for pkg, name, _ in _exports():
        if pkg != "sdctrl.plot":
            where[name].add(pkg)
    assert not {k: v for k, v in where.items() if len(v) > 1}
    assert "EFFECT_KINDS" in sd.diagnosis.__all__


def test_aliases_and_second_routes_are_gone():
    """One name per operation (API.md's names kept): no American alias, one perturbation, one
    public route to a D-strut, one name for physical-DOF modifications."""
    assert hasattr(sd.plot, "stabilisation") and not hasattr(sd.plot, "stabilization")
    assert hasattr(sd.UncertainModel, "perturbed")
    assert not {"perturbed_model", "perturbed_matrices"} & set(dir(sd.UncertainModel))
    assert not {"strut_plant", "strut_controller", "rate_outputs"} & set(dir(sd.closedloop))
    assert hasattr(sd.NormalModeModel, "with_feedback") and hasattr(sd.HybridModel, "with_io")
    assert hasattr(sd.HybridModel, "with_modification") and not hasattr(sd.HybridModel, "modify")
