"""Layout rules: public functions are plain functions, never modules made callable."""

import ast
import importlib.util
import inspect
import pathlib
import pickle
import re

import pytest

import sdctrl as sd


@pytest.mark.parametrize("name", sorted(sd.__all__))
def test_no_module_is_named_like_a_public_name(name):
    assert importlib.util.find_spec(f"sdctrl.{name}") is None, (
        f"sdctrl.{name} is a module: sd.{name} would depend on import order")


@pytest.mark.parametrize("name", ["identify", "hybrid", "testbed", "normal_modes", "rms"])
def test_public_functions_are_plain_and_picklable(name):
    func = getattr(sd, name)
    assert inspect.isfunction(func)
    assert not inspect.ismodule(func)
    assert pickle.loads(pickle.dumps(func)) is func
    assert inspect.getdoc(func).strip()
    assert "Help on module" not in (func.__doc__ or "")


# ----------------------------------------------------------------------------------------
# one-way flow and no private names across modules (DESIGN.md, HELPERS.md "Layout")
# ----------------------------------------------------------------------------------------
ROOT = pathlib.Path(sd.__file__).resolve().parent

#: the flow between packages, left to right (DESIGN.md "Layout"): a module imports only modules of
#: its own package or of packages to its left.  ``sdctrl`` (the lazy export table) is not placed;
#: a bare ``import sdctrl`` is allowed only at the end of the flow (``LAST``).
ORDER = [
    "sdctrl.config", "sdctrl._lib", "sdctrl.data", "sdctrl.modal", "sdctrl.identification",
    "sdctrl.fe", "sdctrl.updating", "sdctrl.hybrids", "sdctrl.robust", "sdctrl.closedloop",
    "sdctrl.testbeds", "sdctrl.testing", "sdctrl.diagnosis", "sdctrl.storage", "sdctrl.plot",
    "sdctrl.report", "sdctrl.demo", "sdctrl.cli",
]
LAST = ("sdctrl.plot", "sdctrl.report", "sdctrl.demo", "sdctrl.cli")

#: thin methods of a model that call into a package to their right, in a function body (the
#: python-control way: ``StateSpace.feedback`` calls ``bdalg``); each is checked to close no cycle
#: (``test_no_import_cycle``).  (importing module, imported module): why.
DOORS = {
    ("sdctrl.modal._normal_model", "sdctrl.robust._uncertainty"):
        "NormalModeModel.uncertain (API.md) builds an UncertainModel (5.5)",
}


def _modules():
    out = []
    for path in sorted(ROOT.rglob("*.py")):
        parts = ("sdctrl",) + path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.append((".".join(parts), path))
    return out


def _unit(module: str) -> str | None:
    """The entry of ORDER a module belongs to (itself or its package)."""
    best = None
    for u in ORDER:
        if (module == u or module.startswith(u + ".")) and (best is None or len(u) > len(best)):
            best = u
    return best


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def _imports(module: str, path: pathlib.Path):
    """(lineno, imported module, imported name or None) of every sdctrl import, lazy ones too."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(block.test)
                   for stmt in block.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in typing_only:             # never executed: no dependency
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "sdctrl":
                    yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "sdctrl":
                continue
            for alias in node.names:
                if _is_module(f"{target}.{alias.name}"):
                    yield node.lineno, f"{target}.{alias.name}", None
                elif target == "sdctrl" and alias.name in sd._EXPORTS:
                    yield node.lineno, sd._EXPORTS[alias.name], alias.name
                else:
                    yield node.lineno, target, alias.name
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "import_module" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)
              and node.args[0].value.startswith("sdctrl")):
            yield node.lineno, node.args[0].value, None


def _violations():
    private, backward, unplaced = [], [], []
    for module, path in _modules():
        if module == "sdctrl":                        # the lazy export table
            continue
        unit = _unit(module)
        if unit is None:
            unplaced.append(module)
            continue
        for line, target, name in _imports(module, path):
            where = f"{path.relative_to(ROOT.parent)}:{line}"
            if (name is not None and name.startswith("_") and not name.startswith("__")
                    and target != module):
                private.append(f"{where} imports private {target}.{name}")
            if target == "sdctrl":
                if name is None and unit not in LAST:
                    backward.append(f"{where} imports the whole package (only {LAST} may)")
                continue
            tunit = _unit(target)
            if tunit is None:
                unplaced.append(target)
            elif (tunit != unit and ORDER.index(tunit) > ORDER.index(unit)
                  and (module, target) not in DOORS):
                backward.append(f"{where} ({unit}) imports {target}, which sits to its right")
    return private, backward, unplaced


def test_no_private_name_imported_from_another_module():
    private, _, _ = _violations()
    assert not private, "\n".join(private)


def test_flow_is_one_way():
    _, backward, unplaced = _violations()
    assert not unplaced, f"modules missing from ORDER (place them in the flow): {unplaced}"
    assert not backward, "\n".join(backward)


def test_the_checker_sees_violations(tmp_path):
    """The parser finds lazy imports, relative imports and private names."""
    src = ("def f():\n    from sdctrl.closedloop._loops import _psd\n    from .robust import x\n"
           "    import sdctrl\n")
    p = tmp_path / "modal.py"
    p.write_text(src)
    found = list(_imports("sdctrl.modal._normal_model", p))
    assert (2, "sdctrl.closedloop._loops", "_psd") in found
    assert (3, "sdctrl.modal.robust", "x") in found
    assert (4, "sdctrl", None) in found
    assert _unit("sdctrl.identification._complex_fit") == "sdctrl.identification"
    assert ORDER.index("sdctrl.modal") < ORDER.index("sdctrl.robust")


# ----------------------------------------------------------------------------------------
# no import cycle, module by module (function-body imports included)
# ----------------------------------------------------------------------------------------
def _package_of(module: str, path: pathlib.Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _graph() -> dict[str, set[str]]:
    """module -> the sdctrl modules it imports (at module level or in a function body).

    Importing ``sdctrl.q._m`` from outside package ``sdctrl.q`` also runs ``sdctrl.q``'s
    ``__init__``: that edge is added too.  Within a package the parent is already importing.
    """
    modules = dict(_modules())
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        if module == "sdctrl":
            continue
        own = _package_of(module, path)
        for _, target, _ in _imports(module, path):
            while target not in modules and "." in target:     # a name, not a module
                target = target.rpartition(".")[0]
            if target == "sdctrl" or target == module:
                continue
            graph[module].add(target)
            parent = target.rpartition(".")[0]
            while parent not in ("sdctrl", "") and not (own + ".").startswith(parent + "."):
                if parent in modules and parent != module:
                    graph[module].add(parent)
                parent = parent.rpartition(".")[0]
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    cycles = _cycles(_graph())
    assert not cycles, "import cycles between modules:\n" + "\n".join(map(str, cycles))


def test_the_cycle_finder_sees_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


# ----------------------------------------------------------------------------------------
# the layout of DESIGN.md: packages per chapter, small modules and functions
# ----------------------------------------------------------------------------------------
TOP_LEVEL = {"__init__.py", "config.py", "cli.py", "testing.py"}


def test_only_entry_modules_directly_under_sdctrl():
    flat = sorted(p.name for p in ROOT.glob("*.py") if p.name not in TOP_LEVEL)
    assert not flat, f"modules directly under sdctrl/ (place them in a package): {flat}"


def test_no_two_modules_share_a_file_name():
    seen: dict[str, list[str]] = {}
    for module, path in _modules():
        if path.name != "__init__.py":
            seen.setdefault(path.stem.lstrip("_"), []).append(module)
    twice = {k: v for k, v in seen.items() if len(v) > 1}
    assert not twice, twice


def test_no_module_over_500_lines():
    big = {m: n for m, p in _modules() if (n := len(p.read_text().splitlines())) > 500}
    assert not big, big


#: the checkout's other Python directories, next to this file's
REPO = pathlib.Path(__file__).resolve().parents[1]
#: pyproject's ``line-length`` (read, not repeated: tomllib is 3.11+, the project 3.10+)
LINE_LENGTH = int(re.search(r"^line-length\s*=\s*(\d+)", (REPO / "pyproject.toml").read_text(),
                            re.MULTILINE).group(1))


def test_no_line_over_100_columns():
    files = [(pathlib.Path(ROOT.name) / p.relative_to(ROOT), p) for _, p in _modules()]
    files += [(p.relative_to(REPO), p) for d in ("tests", "examples", "benchmarks")
              for p in sorted((REPO / d).rglob("*.py"))]
    long = [f"{name}:{i} ({len(line)})" for name, p in files
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if len(line) > LINE_LENGTH]
    assert not long, f"{len(long)} lines over {LINE_LENGTH} columns: {long}"


def _code_lines(lines: list[str]) -> int:
    return sum(1 for s in lines if s.strip() and not s.strip().startswith("#"))


def test_no_function_body_over_60_lines():
    long = []
    for module, path in _modules():
        text = path.read_text().splitlines()
        for node in ast.walk(ast.parse("\n".join(text))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                body = node.body
                if (isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                        and isinstance(body[0].value.value, str)):
                    body = body[1:]
                if body and (n := _code_lines(text[body[0].lineno - 1:node.end_lineno])) > 60:
                    long.append(f"{module}.{node.name}: {n} lines")
    assert not long, long


def _public_names() -> set[str]:
    names = set()
    for module, _ in _modules():
        if any(part.startswith("_") for part in module.split(".")):
            continue
        names |= set(getattr(importlib.import_module(module), "__all__", ()))
    return names


def test_public_surface_is_small_and_resolves():
    names = _public_names()
    assert len(names) < 200, len(names)
    for module, _ in _modules():
        if not any(part.startswith("_") for part in module.split(".")):
            mod = importlib.import_module(module)
            for name in getattr(mod, "__all__", ()):
                assert getattr(mod, name, None) is not None or name in vars(mod), (module, name)


def test_no_test_reads_info_keys():
    here = pathlib.Path(__file__).resolve().parent
    readers = [f"{p.name}:{i}" for p in sorted(here.glob("*.py")) if p.name != pathlib.Path(
        __file__).name for i, line in enumerate(p.read_text().splitlines(), 1) if ".info[" in line]
    assert not readers, readers


def test_dataclasses_never_compare_arrays():
    """Models and results use eq=False (identity) or their own __eq__: ``a == b`` never raises
    "truth value of an array is ambiguous"."""
    import dataclasses

    seen = []
    for module, _ in _modules():
        mod = importlib.import_module(module)
        for obj in vars(mod).values():
            if (inspect.isclass(obj) and dataclasses.is_dataclass(obj)
                    and obj.__module__ == module):
                seen.append(obj)
                generated = obj.__dataclass_params__.eq
                assert not generated, f"{module}.{obj.__name__} compares fields (eq=True)"
    assert len(seen) >= 6


def test_equal_models_compare_without_raising():
    nm = sd.NormalModeModel([[4.0, 0.0], [0.0, 9.0]], [[0.1, 0.01], [0.01, 0.2]],
                            [[1.0, 0.5]], [[1.0], [0.3]])
    u1, u2 = nm.uncertain(dGamma=0.1 * abs(nm.Gamma)), nm.uncertain(dGamma=0.1 * abs(nm.Gamma))
    same = u1
    assert (u1 == u2) is False and (u1 == same) is True and u1 != u2
    assert (nm == nm.replace()) is False
