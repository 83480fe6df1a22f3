"""Counts of how the code is laid out, for the architecture issue's before and after.

    python benchmarks/architecture.py            # this checkout
    python benchmarks/architecture.py --root DIR # another checkout

Counted on the package (``demcal/``), the workflow and its job scripts:
- the places each status word of an evaluation is spelled as a string literal;
- the places each result file's name is spelled as a string literal;
- the places a Snakemake command line is put together (a literal "snakemake"
  next to "-s" or "--snakefile");
- the places outside ``study/objective.py`` that compute the objective or the
  Rayleigh cost themselves (calls of the objective's functions and of
  ``timestep_cost``; calls of ``ResponseObjective``'s methods do not count);
- the modules at the top of ``demcal/``, the largest module and the largest
  function (lines).
The pairs of repeated code come from the library's ``duplicates`` tool.
"""

from __future__ import annotations

import argparse
import ast
import collections
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
)


def python_sources(root: Path) -> list[Path]:
    scripts = root / "workflow" / "scripts"  # top-level scripts/ before the second step
    if not scripts.is_dir():
        scripts = root / "scripts"
    return sorted([*root.joinpath("demcal").rglob("*.py"), *scripts.glob("*.py")])


def literals(tree: ast.AST) -> list[str]:
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str)
    ]


def snakemake_commands(tree: ast.AST) -> int:
    """Lists or tuples that hold both "snakemake" and "-s"/"--snakefile": hand-built commands."""
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, (ast.List, ast.Tuple)):
            words = {e.value for e in node.elts if isinstance(e, ast.Constant)}
            count += "snakemake" in words and bool({"-s", "--snakefile"} & words)
    return count


#: The objective's functions (demcal/study/objective.py) and the Rayleigh cost term.
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
            for file in RESULT_FILES:
                if file in value:
                    files[file] += 1
                    file_modules[file].add(name)
        commands += snakemake_commands(tree)
        if not name.endswith(("study/objective.py", "demcal/objective.py")):
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
    print("result file names as literals (Python; +workflow files):")
    for file in RESULT_FILES:
        print(
            f"  {file:22s} {files[file]:3d} places, {len(file_modules[file]):2d} modules; "
            f"workflow {workflow_text.count(file)}"
        )
    print(f"Snakemake command lines built by hand: {commands}")
    computing = {name: n for name, n in objective_places.items() if n}
    print(
        f"objective or Rayleigh cost computed outside the objective module: "
        f"{sum(computing.values())} calls in {len(computing)} modules"
    )
    for name, n in sorted(computing.items()):
        print(f"  {name}: {n}")
    print(f"top-level modules of demcal/: {len(top)}")
    print(f"largest module: {max(sizes)[1]} ({max(sizes)[0]} lines)")
    print(f"largest function: {max(functions)[1]} ({max(functions)[0]} lines)")


if __name__ == "__main__":
    main()
