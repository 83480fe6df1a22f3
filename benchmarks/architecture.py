"""Counts of how the code is laid out, for the architecture issue's before and after.

    python benchmarks/architecture.py            # this checkout
    python benchmarks/architecture.py --root DIR # another checkout

Counted on the package (``demcal/``), the workflow and its job scripts:
- the places each status word of an evaluation is spelled as a string literal;
- the places outside ``results/layout.py`` where a result file's name is spelled as a
  string literal, as a name or in a path or glob pattern (docstrings and messages, which
  hold spaces, are not counted);
- the places a Snakemake command line is put together (a literal "snakemake"
  next to "-s" or "--snakefile");
- the places outside ``optimizer/objective.py`` that compute the objective or the
  Rayleigh cost themselves (calls of the objective's functions and of
  ``timestep_cost``; calls of ``ResponseObjective``'s methods do not count);
- the modules at the top of ``demcal/``, the largest module and the largest
  function (lines);
- the import graph of ``demcal/`` (every ``import`` and ``from`` statement, in functions
  too, but not those under ``if TYPE_CHECKING:``): cycles between packages (the
  subpackages and top-level modules of ``demcal``), cycles between modules, and the imports
  that go up the declared order of the packages (the layers of ``.importlinter``; the
  order of this checkout's file is used for another ``--root`` that has none).
The pairs of repeated code come from the library's ``duplicates`` tool.
"""

from __future__ import annotations

import argparse
import ast
import collections
import configparser
import re
from pathlib import Path

STATUS_WORDS = ("ok", "failed", "terminated", "pending", "running")
RESULT_FILES = (
    "study.json",
    "optimizer.json",
    "evaluations.csv",
    "best.json",
    "finished.json",
    "params.json",
    "simulation.json",
    "responses.json",
    "objective.json",
    "partial.csv",
    "early_termination.csv",
    "daemon.log",
    "daemon.lock",
    "launch.json",
    "reused.json",
    "rescored.json",
    "STOP",
    "archived",
    "campaign.json",
    "calibration.json",
    "solutions.csv",
)
#: A quoted string in the workflow's files that holds a file name (no whitespace in it).
QUOTED = r"[\"'][^\"'\s]*{}[^\"'\s]*[\"']"
#: The one module allowed to spell a result file's name.
LAYOUT = "demcal/results/layout.py"


def python_sources(root: Path) -> list[Path]:
    scripts = root / "scripts"  # workflow/scripts/ from the second step to the third
    if not scripts.is_dir():
        scripts = root / "workflow" / "scripts"
    return sorted([*root.joinpath("demcal").rglob("*.py"), *scripts.glob("*.py")])


def literals(tree: ast.AST) -> list[str]:
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str)
    ]


def docstrings(tree: ast.AST) -> set[int]:
    """The ids of the docstring nodes of the module, its classes and functions."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                found.add(id(body[0].value))
    return found


def file_spellings(tree: ast.AST) -> list[str]:
    """String literals that spell a file name as a name or a path (no whitespace: the name, or
    a path or glob pattern that holds it); docstrings and messages are not counted."""
    skipped = docstrings(tree)
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and id(node) not in skipped
        and not any(c.isspace() for c in node.value)
    ]


def snakemake_commands(tree: ast.AST) -> int:
    """Lists or tuples that hold both "snakemake" and "-s"/"--snakefile": hand-built commands."""
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, (ast.List, ast.Tuple)):
            words = {e.value for e in node.elts if isinstance(e, ast.Constant)}
            count += "snakemake" in words and bool({"-s", "--snakefile"} & words)
    return count


#: The objective's functions (demcal/optimizer/objective.py) and the Rayleigh cost term.
OBJECTIVE_FUNCTIONS = frozenset(
    {
        "objective_value",
        "objective_values",
        "replicate_objectives",
        "estimated_objective",
        "timestep_cost",
    }
)


def objective_computations(tree: ast.AST) -> int:
    """Calls of the objective's functions (by name or attribute)."""
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", None)
            count += name in OBJECTIVE_FUNCTIONS
    return count


def largest_function(tree: ast.AST) -> tuple[int, str]:
    return max(
        (
            (node.end_lineno - node.lineno + 1, node.name)
            for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        ),
        default=(0, ""),
    )


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def type_checking_blocks(tree: ast.AST) -> set[int]:
    """Line numbers of the statements under ``if TYPE_CHECKING:``."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                lines.update(range(child.lineno, (child.end_lineno or child.lineno) + 1))
    return lines


def imports_of(root: Path) -> dict[str, set[str]]:
    """Each module of demcal and the demcal modules it imports (run-time imports only)."""
    modules = {module_name(root, p): p for p in root.joinpath("demcal").rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        skipped = type_checking_blocks(tree)
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets: set[str] = set()
        for node in ast.walk(tree):
            if getattr(node, "lineno", None) in skipped:
                continue
            if isinstance(node, ast.Import):
                targets.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(anchor + ([base] if base else []))
                targets.add(base)
                targets.update(f"{base}.{a.name}" for a in node.names)
        graph[name] = {t for t in targets if t in modules and t != name}
    return graph


def package_of(module: str) -> str:
    """demcal.study.model -> study; demcal.api -> api."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for child in sorted(graph.get(node, ())):
            if child not in index:
                visit(child)
                low[node] = min(low[node], low[child])
            elif child in on_stack:
                low[node] = min(low[node], index[child])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def declared_layers(root: Path) -> list[set[str]]:
    """The layers of ``.importlinter`` from the top down, each a set of package names."""
    config = root / ".importlinter"
    if not config.is_file():
        config = Path(__file__).resolve().parents[1] / ".importlinter"
    parser = configparser.ConfigParser()
    parser.read(config)
    text = parser["importlinter:contract:layers"]["layers"]
    return [{p.strip() for p in line.split("|")} for line in text.split("\n") if line.strip()]


def upward_imports(graph: dict[str, set[str]], layers: list[set[str]]) -> list[str]:
    """Imports from a package to one in a higher layer (or to one the order does not place)."""
    rank = {package: i for i, layer in enumerate(layers) for package in layer}
    found = []
    for module, targets in sorted(graph.items()):
        here = rank.get(package_of(module))
        for target in sorted(targets):
            there = rank.get(package_of(target))
            if package_of(target) == package_of(module) or module == "demcal":
                continue
            if here is None or there is None or there < here:
                found.append(f"{module} -> {target}")
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1])
    root = parser.parse_args().root.resolve()
    status, files = collections.Counter(), collections.Counter()
    status_modules, file_modules = collections.defaultdict(set), collections.defaultdict(set)
    commands, sizes, functions = 0, [], []
    objective_places: collections.Counter = collections.Counter()
    for path in python_sources(root):
        text = path.read_text()
        tree = ast.parse(text)
        name = str(path.relative_to(root))
        for value in literals(tree):
            if value in STATUS_WORDS:
                status[value] += 1
                status_modules[value].add(name)
        for value in file_spellings(tree):
            for file in RESULT_FILES:
                if file in value and name != LAYOUT:
                    files[file] += 1
                    file_modules[file].add(name)
        commands += snakemake_commands(tree)
        if not name.endswith(("study/objective.py", "optimizer/objective.py")):
            objective_places[name] += objective_computations(tree)
        sizes.append((len(text.splitlines()), name))
        length, function = largest_function(tree)
        functions.append((length, f"{name}:{function}"))
    workflow_text = "\n".join(
        p.read_text()
        for p in sorted(root.joinpath("workflow").rglob("*"))
        if p.is_file() and p.suffix in ("", ".smk")
    )
    top = sorted(p.name for p in root.joinpath("demcal").glob("*.py"))
    print(f"code of {root}")
    print(
        f"status words as literals: {sum(status.values())} places in "
        f"{len(set().union(*status_modules.values()))} modules"
    )
    for word in STATUS_WORDS:
        print(f"  {word!r:14s} {status[word]:3d} places, {len(status_modules[word]):2d} modules")
    print(f"result file names as literals outside {LAYOUT} (Python; +workflow files):")
    for file in RESULT_FILES:
        print(
            f"  {file:22s} {files[file]:3d} places, {len(file_modules[file]):2d} modules; "
            f"workflow {len(re.findall(QUOTED.format(re.escape(file)), workflow_text))}"
        )
    print(f"Snakemake command lines built by hand: {commands}")
    computing = {name: n for name, n in objective_places.items() if n}
    print(
        f"objective or Rayleigh cost computed outside the objective module: "
        f"{sum(computing.values())} calls in {len(computing)} modules"
    )
    for name, n in sorted(computing.items()):
        print(f"  {name}: {n}")
    graph = imports_of(root)
    packages: dict[str, set[str]] = collections.defaultdict(set)
    for module, targets in graph.items():
        packages[package_of(module)].update(package_of(t) for t in targets)
    for package, targets in packages.items():
        targets.discard(package)
    package_cycles, module_cycles = cycles(packages), cycles(graph)
    print(f"package cycles: {len(package_cycles)}")
    for cycle in package_cycles:
        print(f"  {' <-> '.join(cycle)}")
    print(f"module cycles: {len(module_cycles)}")
    for cycle in module_cycles:
        print(f"  {' <-> '.join(cycle)}")
    upward = upward_imports(graph, declared_layers(root))
    print(f"imports up the declared order (.importlinter): {len(upward)}")
    for line in upward:
        print(f"  {line}")
    print(f"top-level modules of demcal/: {len(top)}")
    print(f"largest module: {max(sizes)[1]} ({max(sizes)[0]} lines)")
    print(f"largest function: {max(functions)[1]} ({max(functions)[0]} lines)")


if __name__ == "__main__":
    main()
