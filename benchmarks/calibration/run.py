"""Calibration benchmark: demcal's strategies against peers on DEM-like calibration problems.

Problems (problems.py): several responses matched to targets taken at a
hidden true point, with Gaussian simulation noise: p3r3 (3 parameters / 3
responses, identifiable), p5r2 (5 / 2, a manifold of solutions), p2r2rep
(2 / 2, two replicates per evaluation).

Tools: ``demcal:<strategy>`` for every strategy registered in
``demcal.optimizer.registry.STRATEGIES`` (in-process, ask/tell; append
``@precision`` for the precision-weighted objective form), Optuna
GPSampler and pySOT DYCORS (in-process, this venv), GrainLearning and ACCES
(NumPy < 2: run by worker_np1.py in the venv of requirements-np1.txt).

Measures per run: the true objective (eq. 3.3 of the noise-free responses)
at the answer the tool reports, whether it is at the noise level, the number
of simulations until the running answer first reaches the noise level, the
true objective of the best point evaluated, the worst miss of a response at
the answer in units of its target's measurement spread, and the tool's
seconds per proposal (wall time minus time in the simulations). For
demcal, also where its stopping rules would have ended the calibration
(``Optimizer.stop_reason``, as demcal's daemon asks it after each tell) and
the answer's quality there; the peers are scored at the same number of
simulations of the same seed (the stop table of RESULTS.md).

Run from the repository root in the benchmark venv (README.md here):

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice -n 10 \\
        /work/bench-venv/bin/python benchmarks/calibration/run.py

Writes results.csv (one row per run) and RESULTS.md to --out (default: this folder).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPOSITORY = HERE.parents[1]
sys.path.insert(0, str(REPOSITORY))
sys.path.insert(0, str(HERE))

from problems import PROBLEMS, Evaluator, Problem, mean_responses  # noqa: E402
from versions import installed_versions  # noqa: E402

NP1_PYTHON = Path("/work/bench-venv-np1/bin/python")
WORKER = HERE / "worker_np1.py"
WORKER_TIMEOUT = 3600  # seconds for one subprocess run
WORKER_MEMORY = (
    6 * 2**30
)  # address-space cap of a worker (a runaway allocation fails there, not on the machine)
PEERS = ("optuna_gp", "pysot_dycors", "grainlearning", "acces")
SUBPROCESS_PEERS = ("grainlearning", "acces")
FIELDS = [
    "tool",
    "problem",
    "budget",
    "seed",
    "status",
    "evaluations",
    "noise_level",
    "true_objective",
    "at_noise_level",
    "best_evaluated_true_objective",
    "evaluations_to_noise_level",
    "worst_miss_in_spreads",
    "stop_evaluations",
    "stop_reason",
    "true_objective_trace",
    "worst_miss_trace",
    "seconds_per_proposal",
    "wall_seconds",
    "answer",
    "extra",
]


def demcal_strategies() -> list[str]:
    from demcal.optimizer.registry import STRATEGIES

    return list(STRATEGIES)


# ------------------------------------------------------------ demcal adapter
# The two functions that stand between this benchmark and demcal's Optimizer.
def make_demcal_optimizer(
    problem: Problem,
    strategy: str,
    budget: int,
    seed: int,
    form: str = "relative",
    workers: int = 1,
):
    """A demcal optimizer for ``problem`` with strategy ``strategy``, ``budget`` evaluations,
    objective form and the number of asynchronous ``workers``."""
    from demcal.optimizer import Optimizer
    from demcal.optimizer.objective import ResponseObjective

    settings = {"strategy": strategy, "max_evaluations": budget}
    objective = ResponseObjective(tuple(demcal_targets(problem)), form)
    return Optimizer(
        list(problem.lower),
        list(problem.upper),
        settings,
        seed=seed,
        objective=objective,
        workers=workers,
    )


def tell_demcal(
    opt,
    proposal_id: int,
    responses: dict[str, list[float]],
    objective_value: float,
    replicate_objectives: list[float],
) -> None:
    """Report one finished evaluation to a demcal optimizer.

    ``responses``: this evaluation's replicate values per response, keyed
    ``scene.response`` (demcal's target keys), e.g.
    ``{"cylinder_lift.angle_of_repose": [31.2, 33.0], ...}``;
    ``objective_value``: eq. 3.3 of the replicate means
    (``demcal.optimizer.objective.objective_value``); ``replicate_objectives``: eq. 3.3
    of each replicate index alone (``demcal.optimizer.objective.replicate_objectives``,
    empty with one replicate).

    The optimizer is told the scalar objective, the per-replicate
    objectives (its noise estimate) and the responses, as demcal's daemon
    tells it.
    """
    opt.tell(
        proposal_id,
        value=objective_value,
        replicates=replicate_objectives or None,
        responses=responses,
    )


def demcal_targets(problem: Problem):
    from demcal.optimizer.objective import Target

    targets, spreads = problem.targets, problem.spreads
    return [
        Target(*key.split(".", 1), value=targets[key], spread=spreads[key]) for key in problem.keys
    ]


# --------------------------------------------------------------------- tools
def run_demcal(
    problem: Problem, evaluator: Evaluator, seed: int, budget: int, strategy: str
) -> dict:
    """demcal ask/tell, one simulation at a time; the running answer is ``opt.best()``
    after each tell.

    After each tell it also asks ``opt.stop_reason`` as demcal's daemon does, and keeps
    the first reason other than the evaluation budget: ``stop`` is (simulations told,
    reason), None if no rule ended the search before the budget. The run goes on to the
    full budget either way (with ``map_solutions`` 0 a stop leaves ``ask`` unchanged), so
    the same run gives the answer at the stop and at the budget.

    ``strategy``: a registered name, optionally ``@precision`` for that objective form.
    """
    from demcal.optimizer.objective import objective_value, replicate_objectives

    strategy, _, form = strategy.partition("@")
    targets = demcal_targets(problem)
    opt = make_demcal_optimizer(problem, strategy, budget, seed, form or "relative")
    running, stop, started = [], None, time.perf_counter()
    while True:
        proposals = opt.ask()
        if not proposals:
            break
        proposal = proposals[0]
        responses, value_here, _ = evaluator(proposal.x)
        value = objective_value(targets, mean_responses(responses))
        if not math.isclose(value, value_here, rel_tol=1e-9, abs_tol=1e-15):
            raise RuntimeError(
                f"demcal's eq. 3.3 {value} differs from the benchmark's {value_here}"
            )
        if form:  # the precision form: the optimizer computes its objective from the responses
            opt.tell(proposal.id, responses=responses)
        else:
            tell_demcal(
                opt, proposal.id, responses, value, replicate_objectives(targets, responses)
            )
        best = opt.best()
        running.append(None if best is None else best.x)
        reason = opt.stop_reason(time.perf_counter() - started) if stop is None else None
        if reason and not reason.startswith("evaluation budget reached"):
            stop = (len(running), reason)
    best = opt.best()
    extra = {"predicted": best.predicted, "chosen_by": best.chosen_by}
    return {"answer": best.x, "running": running, "extra": extra, "stop": stop}


def run_optuna_gp(problem: Problem, evaluator: Evaluator, seed: int, budget: int) -> dict:
    """Optuna GPSampler (defaults) on the noisy eq. 3.3; answer ``study.best_params``."""
    import optuna
    import torch

    torch.set_num_threads(1)
    optuna.logging.set_verbosity(optuna.logging.WARNING)

    def trial_objective(trial):
        x = [
            trial.suggest_float(n, lo, hi)
            for n, lo, hi in zip(problem.parameters, problem.lower, problem.upper)
        ]
        return evaluator(x)[1]

    study = optuna.create_study(sampler=optuna.samplers.GPSampler(seed=seed))
    study.optimize(trial_objective, n_trials=budget)
    return {"answer": [study.best_params[n] for n in problem.parameters]}


def run_pysot_dycors(problem: Problem, evaluator: Evaluator, seed: int, budget: int) -> dict:
    """pySOT DYCORS with a cubic RBF, as in benchmarks/optimizer; answer: its
    best evaluated point."""
    from poap.controller import SerialController
    from pySOT.experimental_design import SymmetricLatinHypercube
    from pySOT.optimization_problems import OptimizationProblem
    from pySOT.strategy import DYCORSStrategy
    from pySOT.surrogate import CubicKernel, LinearTail, RBFInterpolant

    class Wrapped(OptimizationProblem):
        def __init__(self):
            self.dim = problem.dimension
            self.lb = np.array(problem.lower)
            self.ub = np.array(problem.upper)
            self.int_var = np.array([], dtype=int)
            self.cont_var = np.arange(problem.dimension)

        def eval(self, x):
            return evaluator(x)[1]

    np.random.seed(seed)  # pySOT draws from NumPy's global generator
    wrapped = Wrapped()
    surrogate = RBFInterpolant(
        dim=wrapped.dim,
        lb=wrapped.lb,
        ub=wrapped.ub,
        kernel=CubicKernel(),
        tail=LinearTail(wrapped.dim),
    )
    controller = SerialController(objective=wrapped.eval)
    controller.strategy = DYCORSStrategy(
        max_evals=budget,
        opt_prob=wrapped,
        exp_design=SymmetricLatinHypercube(dim=wrapped.dim, num_pts=2 * (wrapped.dim + 1)),
        surrogate=surrogate,
        asynchronous=False,
        batch_size=1,
        num_cand=100 * wrapped.dim,
    )
    result = controller.run()
    return {"answer": [float(v) for v in result.params[0]]}


IN_PROCESS = {"optuna_gp": run_optuna_gp, "pysot_dycors": run_pysot_dycors}


def _cap_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (WORKER_MEMORY, WORKER_MEMORY))


def run_subprocess_peer(
    tool: str, problem: Problem, seed: int, budget: int, np1_python: Path
) -> dict:
    """Run worker_np1.py in the NumPy-1 venv; its JSON has evaluations, answer,
    extra, tool_seconds."""
    if not np1_python.exists():
        return {"error": f"not installed: no {np1_python} (see README.md: requirements-np1.txt)"}
    with tempfile.TemporaryDirectory(prefix="calibration_worker_") as folder:
        out = Path(folder) / "result.json"
        command = [
            str(np1_python),
            str(WORKER),
            "--tool",
            tool,
            "--problem",
            problem.name,
            "--seed",
            str(seed),
            "--budget",
            str(budget),
            "--json",
            str(out),
        ]
        completed = subprocess.run(
            command,
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=WORKER_TIMEOUT,
            preexec_fn=_cap_memory,
        )
        if not out.exists():
            tail = (completed.stderr or completed.stdout).strip().splitlines()[-3:]
            return {"error": f"worker exited {completed.returncode}: {' | '.join(tail)}"}
        return json.loads(out.read_text())


# ------------------------------------------------------------------ one run
def best_so_far(log: list[dict]) -> list[list[float]]:
    """The running answer of a peer: its evaluated point with the lowest noisy objective so far."""
    running, best = [], None
    for entry in log:
        if best is None or entry["objective"] < best["objective"]:
            best = entry
        running.append(best["x"])
    return running


def one_run(tool: str, problem: Problem, budget: int, seed: int, np1_python: Path) -> dict:
    row = {
        "tool": tool,
        "problem": problem.name,
        "budget": budget,
        "seed": seed,
        "noise_level": problem.noise_level,
    }
    start = time.perf_counter()
    try:
        if tool in SUBPROCESS_PEERS:
            result = run_subprocess_peer(tool, problem, seed, budget, np1_python)
            if "error" in result:
                raise RuntimeError(result["error"])
            log, tool_seconds = result["evaluations"], result["tool_seconds"]
        else:
            evaluator = Evaluator(problem, seed)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if tool.startswith("demcal:"):
                    result = run_demcal(problem, evaluator, seed, budget, tool.split(":", 1)[1])
                else:
                    result = IN_PROCESS[tool](problem, evaluator, seed, budget)
            log = evaluator.log
            tool_seconds = time.perf_counter() - start - evaluator.seconds
    except Exception as error:  # one tool's failure is a row of the table, not the end of the run
        traceback.print_exc()
        row.update(
            status=f"failed: {type(error).__name__}: {error}"[:300],
            wall_seconds=time.perf_counter() - start,
        )
        return row
    running = result.get("running") or best_so_far(log)
    noise_level = problem.noise_level
    objective_trace = [math.nan if x is None else problem.true_objective(x) for x in running]
    miss_trace = [math.nan if x is None else problem.worst_miss_in_spreads(x) for x in running]
    reached = [n for n, value in enumerate(objective_trace, 1) if value <= noise_level]
    stop = result.get("stop")
    true_objective = problem.true_objective(result["answer"])
    extra = dict(result.get("extra") or {})
    for key, value in list(
        extra.items()
    ):  # alternative answers (posterior mean, ...): their true objective
        if isinstance(value, list) and len(value) == problem.dimension:
            extra[f"{key}_true_objective"] = problem.true_objective(value)
    row.update(
        status="ok",
        evaluations=len(log),
        true_objective=true_objective,
        at_noise_level=true_objective <= noise_level,
        best_evaluated_true_objective=min(problem.true_objective(e["x"]) for e in log),
        evaluations_to_noise_level=reached[0] if reached else "",
        worst_miss_in_spreads=problem.worst_miss_in_spreads(result["answer"]),
        stop_evaluations="" if stop is None else stop[0],
        stop_reason="" if stop is None else stop[1],
        true_objective_trace=" ".join(f"{v:.4g}" for v in objective_trace),
        worst_miss_trace=" ".join(f"{v:.3g}" for v in miss_trace),
        seconds_per_proposal=tool_seconds / max(len(log), 1),
        wall_seconds=time.perf_counter() - start,
        answer=" ".join(f"{v:.6g}" for v in result["answer"]),
        extra=json.dumps(extra, default=float),
    )
    return row


# ------------------------------------------------------------------- report
def median_evaluations(values: list, budget: int) -> str:
    """Median over the runs of the evaluations to the noise level; a run that never got there
    counts as infinite."""
    counts = sorted(float(v) if v not in ("", None) else math.inf for v in values)
    median = float(np.median(counts)) if counts else math.inf
    return f"never (> {budget})" if math.isinf(median) else f"{median:g}"


def cells(rows: list[dict], tools: list[str]):
    """(problem, budget, tool, the runs of that cell) in table order, for cells with runs."""
    problems = [p for p in PROBLEMS if any(r["problem"] == p for r in rows)]
    budgets = sorted({int(r["budget"]) for r in rows})
    for problem in problems:
        for budget in budgets:
            for tool in tools:
                selected = [
                    r
                    for r in rows
                    if r["problem"] == problem and int(r["budget"]) == budget and r["tool"] == tool
                ]
                if selected:
                    yield problem, budget, tool, selected


def summarise(rows: list[dict], tools: list[str]) -> list[dict]:
    table = []
    for problem, budget, tool, selected in cells(rows, tools):
        ok = [r for r in selected if r["status"] == "ok"]
        entry = {
            "problem": problem,
            "budget": budget,
            "tool": tool,
            "runs": len(selected),
            "ok": len(ok),
            "failure": next((r["status"] for r in selected if r["status"] != "ok"), ""),
        }
        if ok:
            values = np.array([float(r["true_objective"]) for r in ok])
            entry.update(
                median=float(np.median(values)),
                worst=float(np.max(values)),
                at_noise=sum(str(r["at_noise_level"]) == "True" for r in ok),
                to_noise=median_evaluations([r["evaluations_to_noise_level"] for r in ok], budget),
                best_evaluated=float(
                    np.median([float(r["best_evaluated_true_objective"]) for r in ok])
                ),
                worst_miss=float(np.median([float(r["worst_miss_in_spreads"]) for r in ok])),
                seconds=float(np.median([float(r["seconds_per_proposal"]) for r in ok])),
            )
        table.append(entry)
    return table


def trace_at(row: dict, field: str, k: int) -> float:
    """A run's trace ``field`` (a measure of its running answer after each simulation) after
    ``k`` simulations, or at its last simulation if it made fewer."""
    values = row[field].split()
    return float(values[min(k, len(values)) - 1])


def summarise_stops(rows: list[dict], tools: list[str]) -> tuple[str, list[dict], Counter] | None:
    """Simulations spent against the answer's quality, at the stop of the first demcal tool.

    In each (problem, budget, seed) the reference tool's stop sets k (its budget
    if no rule stopped it); every tool's running answer after k simulations is
    scored beside its answer at the full budget. Returns the reference, one
    entry per cell and the reference's stop reasons; None without a demcal tool.
    """
    reference = next((t for t in tools if t.startswith("demcal:")), None)
    if reference is None:
        return None
    ok = [r for r in rows if r["status"] == "ok"]
    stops = {(r["problem"], int(r["budget"]), r["seed"]): r for r in ok if r["tool"] == reference}
    table = []
    for problem, budget, tool, selected in cells(ok, tools):
        selected = [r for r in selected if (problem, budget, r["seed"]) in stops]
        if not selected:
            continue
        at = [
            int(stops[(problem, budget, r["seed"])]["stop_evaluations"] or budget) for r in selected
        ]
        noise_level = PROBLEMS[problem].noise_level
        at_stop = [trace_at(r, "true_objective_trace", k) for r, k in zip(selected, at)]
        full = [float(r["true_objective"]) for r in selected]
        table.append(
            {
                "problem": problem,
                "budget": budget,
                "tool": tool,
                "runs": len(selected),
                "stopped": sum(r["stop_evaluations"] != "" for r in selected),
                "sims": float(np.median(at)),
                "sims_range": (min(at), max(at)),
                "stop_median": float(np.median(at_stop)),
                "stop_at_noise": sum(v <= noise_level for v in at_stop),
                "stop_miss": float(
                    np.median([trace_at(r, "worst_miss_trace", k) for r, k in zip(selected, at)])
                ),
                "full_median": float(np.median(full)),
                "full_at_noise": sum(v <= noise_level for v in full),
                "full_miss": float(
                    np.median([float(r["worst_miss_in_spreads"]) for r in selected])
                ),
            }
        )
    reasons = Counter(
        r["stop_reason"].split(":")[0] for r in stops.values() if r["stop_reason"] != ""
    )
    return reference, table, reasons


def package_versions() -> dict[str, str]:
    return {
        "python": platform.python_version(),
        **installed_versions(("numpy", "scipy", "smt", "optuna", "torch", "pySOT", "POAP")),
    }


def np1_versions(np1_python: Path) -> str:
    if not np1_python.exists():
        return f"no venv at {np1_python}"
    try:
        out = subprocess.run(
            [str(np1_python), str(WORKER), "--versions"],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        ).stdout
        python = subprocess.run(
            [str(np1_python), "-c", "import platform; print(platform.python_version())"],
            capture_output=True,
            text=True,
            timeout=60,
        ).stdout.strip()
        return f"python {python}, " + ", ".join(f"{k} {v}" for k, v in json.loads(out).items())
    except (subprocess.SubprocessError, json.JSONDecodeError, OSError) as error:
        return f"could not be queried ({error})"


def demcal_revision() -> str:
    def git(*args):
        return subprocess.run(
            ["git", "-C", str(REPOSITORY), *args], capture_output=True, text=True
        ).stdout.strip()

    head = git("rev-parse", "--short", "HEAD") or "unknown"
    changed = git("status", "--porcelain", "--", "demcal")
    return f"commit {head}" + (" with uncommitted changes under demcal/" if changed else "")


def problem_lines() -> list[str]:
    lines = [
        "| problem | parameters (bounds) | responses: target, simulation noise sd, measurement "
        "spread | replicates | noise level |",
        "|---|---|---|---|---|",
    ]
    for p in PROBLEMS.values():
        parameters = ", ".join(
            f"{n} [{lo:g}, {hi:g}]" for n, lo, hi in zip(p.parameters, p.lower, p.upper)
        )
        targets = p.targets
        responses = "; ".join(
            f"{r.key} {targets[r.key]:.4g} {r.unit}, {100 * r.sd_rel:g} %, {100 * r.spread_rel:g} %"
            for r in p.responses
        )
        lines.append(
            f"| {p.name} | {parameters} | {responses} | {p.replicates} | {p.noise_level:.4g} |"
        )
    return lines


def stop_lines(reference: str, table: list[dict], reasons: Counter) -> list[str]:
    """The section of RESULTS.md on simulations spent against the answer's quality."""
    told = "; ".join(f"{reason} ({count})" for reason, count in reasons.most_common()) or "none"
    lines = [
        "## Simulations spent against answer quality",
        "",
        f"The stop: in each run of {reference}, the first stopping rule other than the budget "
        "that `Optimizer.stop_reason` reports after a tell, as demcal's daemon asks it (the run "
        "itself goes on to the budget); a run without one counts at its budget. Every tool is "
        f"scored at {reference}'s stop in the same problem, budget and seed: its running "
        "answer after that many simulations (demcal: `opt.best()`; the peers, which have no "
        "such rule: the best point so far by the noisy objective), beside its answer at the "
        "full budget (as in the table above). Stopped: runs with a stop before the budget "
        f"(of {reference} only). Sims at stop: median (range) over the runs. At noise level: "
        "runs with the true objective at or below the noise level. Worst miss: median, in "
        f"measurement spreads. Stop reasons of {reference}: {told}.",
        "",
        "| problem | budget | tool | runs | stopped | sims at stop | median true objective at "
        "stop | at noise level at stop | median worst miss at stop | median true objective at "
        "budget | at noise level at budget | median worst miss at budget |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for e in table:
        low, high = e["sims_range"]
        stopped = f"{e['stopped']}/{e['runs']}" if e["tool"] == reference else "—"
        lines.append(
            f"| {e['problem']} | {e['budget']} | {e['tool']} | {e['runs']} | {stopped} | "
            f"{e['sims']:g} ({low}–{high}) | {e['stop_median']:.3g} | "
            f"{e['stop_at_noise']}/{e['runs']} | {e['stop_miss']:.2g} | {e['full_median']:.3g} "
            f"| {e['full_at_noise']}/{e['runs']} | {e['full_miss']:.2g} |"
        )
    return lines


def write_report(
    table: list[dict],
    stops: tuple[str, list[dict], Counter] | None,
    command: str,
    out: Path,
    elapsed: float,
    np1_python: Path,
    revision: str,
) -> None:
    versions = package_versions()
    main_venv = ", ".join(f"{k} {v}" for k, v in versions.items())
    lines = [
        "# Calibration benchmark",
        "",
        f"Command: `{command}`",
        "",
        f"Date: {datetime.now(UTC):%Y-%m-%d %H:%M} UTC; total {elapsed / 60:.1f} min. Machine: "
        f"{platform.machine()}, {os.cpu_count()} cores (shared with other work, so wall times and "
        f"seconds per proposal vary), {platform.system()} {platform.release()}. Written by run.py.",
        "",
        f"Versions: demcal at {revision} (when the run started); main venv: {main_venv}; "
        f"NumPy-1 venv (GrainLearning, ACCES): {np1_versions(np1_python)}.",
        "",
        "## Problems",
        "",
        *problem_lines(),
        "",
        "Targets are the noise-free responses at a hidden true point (true objective 0 there). "
        "Noise: Gaussian, sd = the given share of the target value. Noise level = expected eq. "
        "3.3 of the noise alone at the true point, sum of sd_rel^2 / replicates.",
        "",
        "## Results",
        "",
        "True objective: eq. 3.3 (sum of squared relative errors, unit weights) of the noise-free "
        "responses at the answer the tool reports. At noise level: runs whose answer has a true "
        "objective at or below the noise level. Sims to noise level: median over the runs of the "
        "number of simulations until the running answer first reaches the noise level (a run that "
        "never does counts as infinite); running answer = `opt.best()` after each tell for "
        "demcal, the best-so-far point by the noisy objective for the peers. Best evaluated: "
        "median true objective of the best point each run evaluated. s/proposal: tool wall time "
        "(minus simulations) per evaluation, median over the runs. Worst miss: the largest |y - "
        "r| / s over the responses at the answer (noise-free y, s the target's measurement "
        "spread), median over the runs: how many measurement sds the answer's worst response is "
        "off. `@precision`: demcal with the precision-weighted objective form.",
        "",
        "| problem | budget | tool | runs | median true objective | worst | at noise level | sims "
        "to noise level | median best evaluated | median worst miss [spreads] | s/proposal |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    failures = []
    for e in table:
        if not e["ok"]:
            lines.append(
                f"| {e['problem']} | {e['budget']} | {e['tool']} | {e['runs']} | failed | | | | | "
                "| |"
            )
            failures.append(
                f"- {e['tool']} on {e['problem']}, budget {e['budget']}: {e['failure']}"
            )
            continue
        runs = f"{e['ok']}" if e["ok"] == e["runs"] else f"{e['ok']} of {e['runs']} ok"
        lines.append(
            f"| {e['problem']} | {e['budget']} | {e['tool']} | {runs} | {e['median']:.3g} | "
            f"{e['worst']:.3g} | {e['at_noise']}/{e['ok']} | {e['to_noise']} | "
            f"{e['best_evaluated']:.3g} | {e['worst_miss']:.2g} | {e['seconds']:.3g} |"
        )
        if e["ok"] < e["runs"]:
            failures.append(
                f"- {e['tool']} on {e['problem']}, budget {e['budget']}: {e['failure']}"
            )
    if stops is not None:
        lines += ["", *stop_lines(*stops)]
    if failures:
        lines += ["", "## Runs that failed", "", *failures]
    lines += [
        "",
        "## Tool settings",
        "",
        "- demcal:<strategy>: `Optimizer(lower, upper, {strategy, max_evaluations: budget}, "
        "seed)`, other settings at their defaults; one simulation at a time; told the eq. 3.3 "
        "of the replicate means and the per-replicate values (run.py: `tell_demcal`); answer "
        '`opt.best()["x"]`. Its tool time includes the `opt.best()` and `opt.stop_reason` '
        "calls after each tell (for the running answer and the stop).",
        "- optuna_gp: `GPSampler(seed=seed)` defaults, objective = noisy eq. 3.3; answer "
        "`study.best_params`.",
        "- pysot_dycors: DYCORS, cubic RBF with linear tail, symmetric Latin hypercube of 2(d+1) "
        "points, 100 d candidates (as benchmarks/optimizer); answer: the best evaluated point "
        "(noisy value).",
        "- grainlearning: iterative Bayesian filter, budget/10 iterations of 10 samples, Halton "
        "start, ess_target 0.3, one Gaussian-mixture component (tutorial settings), sampling from "
        "the mixture as by default (the tutorials' slice sampling ran out of memory here, see "
        "worker_np1.py); data = replicate-mean responses vs targets; answer "
        "`get_most_prob_params()`; `posterior_mean_true_objective` in results.csv scores the "
        "posterior mean instead. Its tool time includes the resampling after the last iteration, "
        "which `run()` does too. It stops early if its sigma falls below sigma_tol.",
        "- acces: coexist.Access, population 5 (budget/5 epochs), errors ((y - r)/r)^2 per "
        "response combined by `coexist.combiners.Sum()` (= eq. 3.3), stopped once the budget is "
        "spent; answer: what `learn` returns (`AccessData.parameters`, the best evaluated "
        "combination). Its simulations are separate processes (ACCES's design); their wall time "
        "counts as simulation time.",
        "",
    ]
    (out / "RESULTS.md").write_text("\n".join(lines))


# --------------------------------------------------------------------- main
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--problems",
        default=",".join(PROBLEMS),
        help=f"comma-separated subset of {', '.join(PROBLEMS)}",
    )
    parser.add_argument("--budgets", default="20,40", help="comma-separated evaluation budgets")
    parser.add_argument(
        "--seeds", type=int, default=10, help="number of seeds (seeded noise and seeded tools)"
    )
    parser.add_argument(
        "--first-seed", type=int, default=0, help="seeds are first-seed .. first-seed + seeds - 1"
    )
    parser.add_argument(
        "--tools",
        help="comma-separated: demcal:<strategy> for any registered strategy, and/or "
        f"{', '.join(PEERS)}; default: every registered demcal strategy and every peer",
    )
    parser.add_argument(
        "--np1-python",
        type=Path,
        default=NP1_PYTHON,
        help="python of the NumPy-1 venv that runs grainlearning and acces",
    )
    parser.add_argument(
        "--out", type=Path, default=HERE, help="folder for results.csv and RESULTS.md"
    )
    args = parser.parse_args(argv)

    strategies = demcal_strategies()
    tools = [
        t
        for t in (args.tools or ",".join([f"demcal:{s}" for s in strategies] + list(PEERS))).split(
            ","
        )
        if t
    ]
    for tool in tools:
        if tool.startswith("demcal:"):
            strategy, _, form = tool.split(":", 1)[1].partition("@")
            if form not in ("", "precision"):
                parser.error(f"{tool}: the objective form after @ can only be precision")
            if strategy not in strategies:
                parser.error(
                    f"{tool}: demcal has no strategy {tool.split(':', 1)[1]!r}; registered: "
                    f"{', '.join(strategies)}"
                )
        elif tool not in PEERS:
            parser.error(
                f"unknown tool {tool!r}; choose demcal:<{'|'.join(strategies)}> or "
                f"{', '.join(PEERS)}"
            )
    problems = []
    for name in (p for p in args.problems.split(",") if p):
        if name not in PROBLEMS:
            parser.error(f"unknown problem {name!r}; choose from {', '.join(PROBLEMS)}")
        problems.append(PROBLEMS[name])
    budgets = [int(b) for b in args.budgets.split(",") if b]
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    args.out.mkdir(parents=True, exist_ok=True)
    command = "python benchmarks/calibration/run.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )

    started, revision = time.perf_counter(), demcal_revision()
    rows = []
    with open(args.out / "results.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=FIELDS)
        writer.writeheader()
        for problem in problems:
            for budget in budgets:
                for tool in tools:
                    for seed in seeds:
                        row = one_run(tool, problem, budget, seed, args.np1_python)
                        rows.append(row)
                        writer.writerow(row)
                        handle.flush()
                        if row["status"] == "ok":
                            print(
                                f"{problem.name} budget={budget} {tool} seed={seed}: true "
                                f"objective {row['true_objective']:.3g} (noise level "
                                f"{problem.noise_level:.3g}), {row['seconds_per_proposal']:.3g} "
                                "s/proposal",
                                flush=True,
                            )
                        else:
                            print(
                                f"{problem.name} budget={budget} {tool} seed={seed}: "
                                f"{row['status']}",
                                flush=True,
                            )
    rows = [{k: ("" if v is None else v) for k, v in r.items()} for r in rows]
    write_report(
        summarise(rows, tools),
        summarise_stops(rows, tools),
        command,
        args.out,
        time.perf_counter() - started,
        args.np1_python,
        revision,
    )


if __name__ == "__main__":
    main()
