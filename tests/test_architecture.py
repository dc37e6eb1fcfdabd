"""The import graph's layering, read from the source with ``ast`` (nothing is imported), and
the size of its modules.

Every import counts, at module level or inside a function (a lazy import is still a
dependency; it only hides it); an import under ``if TYPE_CHECKING:`` counts for the layers,
not for cycles (it never runs).  No rule has a declared exception.  The rules:

* ``evolve`` depends on ``sim2real``, never the reverse;
* the library layers of ``sim2real`` (controller, hardware, robot, simulation) never import
  its command line, ``sim2real.cli`` (flags belong to the CLI; what both need sits lower,
  e.g. :mod:`sim2real.arg_types`);
* ``sim2real.robot`` describes and checks robots and imports nothing of ``sim2real.simulation``,
  not lazily and not for type checking: what needs MuJoCo to make a robot lives in
  ``sim2real.simulation.model``, which hands the robot's spec what it measured;
* that model building, the floor of the simulation, imports none of its other jobs (standing
  checks, reality files, the simulated bus, transfer, identification, rendering), not even
  for type checking;
* ``sim2real.controller`` imports nothing of ``sim2real.hardware`` (a controller is checked
  against its robot's description, not the bus code);
* library modules of ``evolve`` import no command-line module (:func:`is_command_module`);
* the simulated bus imports none of the jobs that use it (dry runs, identification, rendering);
* no import cycle among the modules of ``sim2real`` and ``evolve``;
* no module of ``sim2real`` or ``evolve`` is over :data:`MAX_MODULE_LINES` lines.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("sim2real", "evolve")
LIBRARY_LAYERS = ("sim2real.controller", "sim2real.hardware", "sim2real.robot", "sim2real.simulation")
MAX_MODULE_LINES = 500  # a module on one concept fits in this (STYLE.md: files of 100-500 lines)


@dataclass(frozen=True)
class Import:
    source: str  # the importing module
    target: str  # the project module imported (the deepest that exists)
    line: int
    type_only: bool  # under ``if TYPE_CHECKING:``


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def _project_module(name: str, modules: dict[str, Path]) -> str | None:
    """The deepest project module that importing ``name`` names (``a.b.func`` -> ``a.b``)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def _imports_of(module: str, path: Path, modules: dict[str, Path]) -> list[Import]:
    found: list[Import] = []
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]

    def visit(node: ast.AST, type_only: bool) -> None:
        for child in ast.iter_child_nodes(node):
            guarded = type_only or (isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test))
            names: list[str] = []
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:  # relative: from the importing module's package
                    base = ".".join(package[:len(package) - child.level + 1] + ([base] if base else []))
                names = [f"{base}.{alias.name}" for alias in child.names]  # a submodule, or a name in base
            for name in names:
                target = _project_module(name, modules)
                if target is not None and target != module:
                    found.append(Import(module, target, child.lineno, guarded))
            visit(child, guarded)

    visit(ast.parse(path.read_text(encoding="utf-8"), str(path)), False)
    return found


@lru_cache(maxsize=1)
def import_graph() -> tuple[Import, ...]:
    modules = _modules()
    return tuple(i for module, path in modules.items() for i in _imports_of(module, path, modules))


def _in(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _where(imports: list[Import]) -> str:
    return "\n".join(dict.fromkeys(f"{i.source} (line {i.line}) imports {i.target}" for i in imports))


def test_the_graph_is_read():
    graph = import_graph()
    assert any(i.source == "evolve.run" and _in(i.target, "sim2real") for i in graph)
    assert any(i.source == "sim2real.controller.file" and i.target == "sim2real.controller.checks" for i in graph)


def test_sim2real_never_imports_evolve():
    wrong = [i for i in import_graph() if _in(i.source, "sim2real") and _in(i.target, "evolve")]
    assert not wrong, _where(wrong)


@pytest.mark.parametrize("layer", LIBRARY_LAYERS)
def test_library_layers_never_import_the_command_line(layer):
    wrong = [i for i in import_graph() if _in(i.source, layer) and _in(i.target, "sim2real.cli")]
    assert not wrong, _where(wrong)


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def test_cycles_are_found():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_robot_descriptions_never_import_the_simulation():
    """Not lazily, not for type checking: a robot's description and its checks need no MuJoCo."""
    wrong = [i for i in import_graph() if _in(i.source, "sim2real.robot") and _in(i.target, "sim2real.simulation")]
    assert not wrong, _where(wrong)


def test_model_building_imports_no_other_job_of_the_simulation():
    model = "sim2real.simulation.model"
    wrong = [i for i in import_graph() if _in(i.source, model) and _in(i.target, "sim2real.simulation")
             and not _in(i.target, model) and i.target != "sim2real.simulation"]
    assert not wrong, _where(wrong)


def test_the_simulated_bus_sits_below_what_uses_it():
    """The simulated bus is a device: dry runs, identification and rendering use it, never the
    reverse (the fault format it plays is its own, :mod:`sim2real.simulation.simbus.faults`)."""
    users = ("sim2real.simulation.transfer", "sim2real.simulation.identify", "sim2real.simulation.rendering")
    wrong = [i for i in import_graph() if _in(i.source, "sim2real.simulation.simbus")
             and any(_in(i.target, user) for user in users)]
    assert not wrong, _where(wrong)


def test_no_import_cycles_even_through_imports_inside_functions():
    edges: dict[str, set[str]] = {}
    counted = [i for i in import_graph() if not i.type_only]
    for i in counted:
        edges.setdefault(i.source, set()).add(i.target)
    cycles = _cycles(edges)
    shown = [[i for i in counted if i.source in c and i.target in c] for c in cycles]
    assert not cycles, "\n\n".join(_where(s) for s in shown)


def _long_modules() -> dict[str, int]:
    """Every module of ``sim2real`` and ``evolve`` over :data:`MAX_MODULE_LINES`: path -> lines."""
    lengths = {str(path.relative_to(ROOT)): len(path.read_text(encoding="utf-8").splitlines())
               for path in _modules().values()}
    return {path: n for path, n in sorted(lengths.items()) if n > MAX_MODULE_LINES}


def test_no_module_is_over_500_lines():
    offenders = _long_modules()
    assert not offenders, "\n".join(f"{path}: {n} lines (at most {MAX_MODULE_LINES}: split it by concept)"
                                    for path, n in offenders.items())


# -- the controller never reaches into the bus code ----------------------------------------------
def test_the_controller_imports_nothing_from_hardware():
    """A controller is checked against its robot's description (``sim2real.robot``: the bus
    plan, the Bus Watchdog start-up sets), never against the bus code that drives it."""
    wrong = [i for i in import_graph() if _in(i.source, "sim2real.controller") and _in(i.target, "sim2real.hardware")]
    assert not wrong, _where(wrong)


# -- evolve's library never imports a command line ----------------------------------------------
def is_command_module(module: str) -> bool:
    """A command-line module: ``sim2real.cli`` and its modules; in ``evolve``, a module named
    ``cli``, ``cli_*`` or ``*_cli`` (``evolve.cli``, ``evolve.cli_commands``, ``evolve.train_cli``)."""
    if _in(module, "sim2real.cli"):
        return True
    name = module.rpartition(".")[2]
    return _in(module, "evolve") and (name == "cli" or name.startswith("cli_") or name.endswith("_cli"))


def test_command_modules_are_told_apart_by_name():
    modules = _modules()
    commands = sorted(m for m in modules if _in(m, "evolve") and is_command_module(m))
    assert {"evolve.cli", "evolve.cli_commands", "evolve.train_cli", "evolve.quickstart_cli"} <= set(commands)
    assert not any(is_command_module(m) for m in ("evolve.run", "evolve.train", "evolve.config", "sim2real.arg_types"))


def test_evolve_library_modules_import_no_command_line():
    """Flags belong to the command line; what a library module of ``evolve`` needs from one
    (a converter, a config resolver) sits lower, e.g. in :mod:`sim2real.arg_types`."""
    wrong = [i for i in import_graph() if _in(i.source, "evolve") and not is_command_module(i.source)
             and is_command_module(i.target)]
    assert not wrong, _where(wrong)
