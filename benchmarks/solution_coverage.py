"""Coverage of demcal's reported solution spans on problems with a known truth (issue 20).

For each problem and seed, a calibration runs in-process at the study's
defaults (strategy, objective form, budget, two workers in flight), then the
solution set and the verdicts are computed as the report computes them
(``demcal.analysis.solutions``: ``simulation_noise_sd``, ``sample_solutions``,
``identifiability``, called as ``demcal.analysis.solution_report.analyse``
calls them, with the same k, sample count and seed). Per parameter:

- coverage: whether the truth lies inside the reported span;
- end errors: |reported end - exact end| as a share of the box, lower and
  upper;
- width: the reported span's width against the exact set's.

The exact set is the set of parameter sets whose noise-free responses meet
every target within k band sd (``demcal.optimizer.membership.band_sd``: the
target's standard error and discrepancy; the true sd of a simulated
replicate-mean response at the truth only for a target without a spread),
with the model sd set to zero (``membership_probability`` with zero model sd). It
is found on a regular grid (d <= 3, see ``GRID``) or a scrambled Sobol
sample (d > 3, ``SOBOL_POINTS``) of the box. Its span is taken as the
report takes its own: the full extent (min to max) of the set's points per
parameter, as ``identifiability`` spans the likely set. (Before issue 20
the report spanned the central 95 % of the supported points; the run
labelled ``before`` compared that with the exact set's central 95 %.)
``--map-solutions n`` gives every calibration n evaluations that map the
solution set once its search has stopped.

Problems: the calibration benchmark's (benchmarks/calibration/problems.py:
p3r3, p5r2, p2r2rep, with their seeded noise) and the analytic cylinder
lift (demcal/scenes/cylinder_lift/analytic.py, the analytic engine's noise
of 1 %) at three truths (lift_a, lift_b, lift_c). ``--spread-scale s``
multiplies every target's measurement spread by s, for thinner sets.

Run from the repository root:

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice -n 10 \\
        python benchmarks/solution_coverage.py --label before

Writes benchmarks/results/solution_coverage_<label>.csv (one row per problem
and parameter), solution_coverage_<label>_runs.csv (one row per run and
parameter, with the diagnostics) and solution_coverage_<label>.txt (the
table, the command, the time and the versions).
"""

from __future__ import annotations

import argparse
import csv
import inspect
import math
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from scipy.stats import qmc

HERE = Path(__file__).resolve().parent
REPOSITORY = HERE.parent
sys.path.insert(0, str(REPOSITORY))
sys.path.insert(0, str(HERE / "calibration"))

from problems import PROBLEMS  # noqa: E402

from demcal.analysis.solution_report import analyse  # noqa: E402
from demcal.analysis.solutions import identifiability, sample_solutions, simulation_noise_sd  # noqa: E402
from demcal.engines.analytic import noisy_responses  # noqa: E402
from demcal.optimizer import Optimizer  # noqa: E402
from demcal.optimizer.membership import (  # noqa: E402
    LIKELY,
    SURE,
    membership_probability,
    tolerance_sd,
)
from demcal.optimizer.objective import DEFAULT_FORM, ResponseObjective, Target  # noqa: E402
from demcal.optimizer.responses import final_means, replicate_scatter  # noqa: E402
from demcal.optimizer.settings import OptimizerSettings  # noqa: E402
from demcal.scenes.cylinder_lift.analytic import analytic_model  # noqa: E402
from demcal.study.schema import default  # noqa: E402

#: The report's k, Sobol sample count and seed (the defaults of ``analyse``).
REPORT = {
    name: p.default
    for name, p in inspect.signature(analyse).parameters.items()
    if p.default is not inspect.Parameter.empty
}
#: Grid points per parameter of the exact set for d = 1, 2, 3 (spacing 0.001, 0.001, 0.005).
GRID = {1: 1001, 2: 1001, 3: 201}
#: Sobol points of the exact set for d > 3 (log2), and the batch size.
SOBOL_LOG2, BATCH = 22, 2**17
#: Quick run: fewer points for the exact set.
QUICK_GRID, QUICK_SOBOL_LOG2 = {1: 201, 2: 201, 3: 41}, 16
NOISE_ROOT = 20_260_420  # root of the analytic lift's noise streams

# The analytic cylinder lift, set up as the quickstart (config/config.yaml): two free
# frictions, the others fixed there; the targets' spreads are the quickstart's as shares
# of its targets (1.5 / 17.14 deg, 4.3 / 1407 kg/m^3); the analytic engine's default noise.
LIFT_FREE = ("sliding_friction_pp", "rolling_friction_pp")
LIFT_LOWER, LIFT_UPPER = (0.1, 0.02), (0.9, 0.3)
LIFT_FIXED = {
    "sliding_friction_pw": 0.5,
    "rolling_friction_pw": 0.1,
    "restitution_pp": 0.5,
    "particle_density": 2500.0,
}
LIFT_SPREAD_REL = {"angle_of_repose": 1.5 / 17.14, "bulk_density": 4.3 / 1407.0}
LIFT_NOISE_REL = 0.01
LIFT_TRUTHS = {"lift_a": (0.3, 0.06), "lift_b": (0.5, 0.15), "lift_c": (0.7, 0.25)}


@dataclass(frozen=True)
class Case:
    """A problem with a known truth, as the harness sees it."""

    name: str
    parameters: tuple[str, ...]
    units: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    truth: np.ndarray
    targets: tuple[Target, ...]
    #: sd of a simulated response (the mean of the replicates) at the truth, per target key
    noise_sd: dict[str, float]
    replicates: int
    #: noise-free responses at the rows of x (real units): {key: array}
    clean: Callable[[np.ndarray], dict[str, np.ndarray]]
    #: replicate values of each response of evaluation k of run ``seed`` at x (real units)
    noisy: Callable[[list[float], int, int], dict[str, list[float]]]

    @property
    def dimension(self) -> int:
        return len(self.parameters)


def calibration_case(name: str) -> Case:
    problem = PROBLEMS[name]
    targets, spreads, noise = problem.targets, problem.spreads, problem.noise_sd

    def clean(x: np.ndarray) -> dict[str, np.ndarray]:
        rows = np.array([problem.model(tuple(row)) for row in x.tolist()], float)
        return {key: rows[:, j] for j, key in enumerate(problem.keys)}

    return Case(
        name,
        problem.parameters,
        tuple("" for _ in problem.parameters),
        np.array(problem.lower),
        np.array(problem.upper),
        np.array(problem.truth),
        tuple(Target(*k.split(".", 1), value=targets[k], spread=spreads[k]) for k in problem.keys),
        {k: noise[k] / math.sqrt(problem.replicates) for k in problem.keys},
        problem.replicates,
        clean,
        lambda x, seed, k: problem.noisy_responses(x, seed, k),
    )


def lift_case(name: str) -> Case:
    truth = np.array(LIFT_TRUTHS[name])

    def parameters(row) -> dict:
        return {**LIFT_FIXED, **dict(zip(LIFT_FREE, row))}

    def clean(x: np.ndarray) -> dict[str, np.ndarray]:
        rows = [analytic_model(parameters(row), {}) for row in x.tolist()]
        return {f"cylinder_lift.{r}": np.array([row[r] for row in rows]) for r in LIFT_SPREAD_REL}

    def noisy(x, seed: int, k: int) -> dict[str, list[float]]:
        stream = np.random.SeedSequence([NOISE_ROOT, int(truth[0] * 1e4), seed, k])
        values = noisy_responses(
            analytic_model,
            parameters(x),
            {},
            {"noise": LIFT_NOISE_REL},
            int(stream.generate_state(1)[0]),
        )
        return {f"cylinder_lift.{r}": [values[r]] for r in LIFT_SPREAD_REL}

    at_truth = {key: float(v[0]) for key, v in clean(truth[None, :]).items()}
    return Case(
        name,
        LIFT_FREE,
        ("", ""),
        np.array(LIFT_LOWER),
        np.array(LIFT_UPPER),
        truth,
        tuple(
            Target("cylinder_lift", r, value=at_truth[f"cylinder_lift.{r}"], spread=share * v)
            for (r, share), v in zip(LIFT_SPREAD_REL.items(), at_truth.values())
        ),
        {key: LIFT_NOISE_REL * v for key, v in at_truth.items()},
        1,
        clean,
        noisy,
    )


CASES = {
    **{name: (lambda n=name: calibration_case(n)) for name in PROBLEMS},
    **{name: (lambda n=name: lift_case(n)) for name in LIFT_TRUTHS},
}


# ------------------------------------------------------------------ exact set
@dataclass(frozen=True)
class ExactSet:
    low: np.ndarray  # central 95 % per parameter, unit box
    high: np.ndarray
    minimum: np.ndarray  # full extent, unit box
    maximum: np.ndarray
    accepted: int
    sampled: int
    method: str


def exact_set(case: Case, k: float, quick: bool) -> ExactSet:
    """The noise-free set: every target met within k band sd (no model sd)."""
    d = case.dimension
    if d <= 3:
        n = (QUICK_GRID if quick else GRID)[d]
        axis = np.linspace(0.0, 1.0, n)
        points = np.stack(np.meshgrid(*[axis] * d, indexing="ij"), -1).reshape(-1, d)
        method = f"grid {n}^{d}"
    else:
        log2 = QUICK_SOBOL_LOG2 if quick else SOBOL_LOG2
        points = qmc.Sobol(d, scramble=True, seed=12345).random_base2(log2)
        method = f"scrambled Sobol 2^{log2}"
    kept = []
    for start in range(0, len(points), BATCH):
        unit = points[start : start + BATCH]
        means = case.clean(case.lower + unit * (case.upper - case.lower))
        zero = {key: np.zeros(len(unit)) for key in means}
        inside = membership_probability(case.targets, means, zero, case.noise_sd, k) > 0.5
        kept.append(unit[inside])
    accepted = np.vstack(kept)
    low, high = np.percentile(accepted, [2.5, 97.5], axis=0)
    return ExactSet(low, high, accepted.min(0), accepted.max(0), len(accepted), len(points), method)


# ---------------------------------------------------------------- calibration
def study_form(targets: tuple[Target, ...]) -> str:
    """The objective form a study gets by default (demcal.study.config.load_study)."""
    form = default("objective")
    if form == "auto":
        form = DEFAULT_FORM if any(not t.spread for t in targets) else "precision"
    return form


def calibrate(
    case: Case, seed: int, budget: int | None, workers: int, map_solutions: int
) -> tuple[Optimizer, str]:
    """A calibration at the study's defaults, ``workers`` equal-length simulations in flight
    (each finishes in the order started), told as the daemon tells them."""
    objective = ResponseObjective(case.targets, study_form(case.targets))
    settings = {"strategy": default("optimizer", "strategy"), "map_solutions": map_solutions}
    if budget is not None:
        settings["max_evaluations"] = budget
    opt = Optimizer(
        list(case.lower),
        list(case.upper),
        OptimizerSettings.from_dict(settings),
        seed=seed,
        workers=workers,
        objective=objective,
    )
    start, pending, told, reason = time.monotonic(), [], 0, None
    while True:
        reason = reason or opt.stop_reason(time.monotonic() - start)
        if reason is None:
            pending += opt.ask(workers - len(pending))
        if not pending:
            reason = reason or opt.stop_reason(time.monotonic() - start) or "no more points"
            break
        proposal = pending.pop(0)
        responses = case.noisy(proposal.x, seed, told)
        told += 1
        opt.tell(
            proposal.id,
            value=objective.of_replicates(responses),
            replicates=objective.per_replicate(responses) or None,
            responses=responses,
        )
    return opt, reason


def report_spans(opt: Optimizer, case: Case):
    """The solution set and verdicts as ``solution_report.analyse`` computes them (without the
    Sobol indices, which change the verdicts' sentences, not their spans)."""
    predictor = opt.response_predictor(ResponseObjective(case.targets, study_form(case.targets)))
    if predictor is None:
        return None, None, None
    d = opt.bounds.dimension
    observed = {key: final_means(opt.records, key, d) for key in predictor.models}
    scatter = {key: replicate_scatter(opt.records, key) for key in predictor.models}
    noise = simulation_noise_sd(predictor, observed, scatter)
    solutions = sample_solutions(
        predictor, d, noise, REPORT["k"], REPORT["samples"], REPORT["seed"]
    )
    verdicts = identifiability(
        solutions, list(case.parameters), list(case.units), opt.bounds.lower, opt.bounds.upper
    )
    return predictor, solutions, verdicts


def run_one(
    case: Case, exact: ExactSet, seed: int, budget: int | None, workers: int, map_solutions: int
) -> list[dict]:
    """One calibration and its report: a row per parameter."""
    start = time.monotonic()
    opt, reason = calibrate(case, seed, budget, workers, map_solutions)
    predictor, solutions, verdicts = report_spans(opt, case)
    seconds = time.monotonic() - start
    box = case.upper - case.lower
    truth_u = (case.truth - case.lower) / box
    xs = np.array([r.x for r in opt.records if r.finished])
    nearest = float(np.min(np.linalg.norm(xs - truth_u, axis=1))) if len(xs) else math.nan
    best = opt.best()
    common = {
        "problem": case.name,
        "seed": seed,
        "evaluations": opt.completed_evaluations(),
        "stop_reason": reason,
        "seconds": round(seconds, 2),
        "nearest_evaluation_to_truth": nearest,
        "answer_distance_to_truth": (
            float(np.linalg.norm((np.array(best.x) - case.lower) / box - truth_u))
            if best
            else math.nan
        ),
    }
    if solutions is None:
        diagnostics = {"possible": 0, "likely": 0}
    else:
        mean, std = predictor.predict(truth_u[None, :])
        noise = solutions.noise_sd
        p_truth = float(membership_probability(case.targets, mean, std, noise, solutions.k)[0])
        tolerance = {
            t.key: float(tolerance_sd(t, noise[t.key], std[t.key][0])) for t in case.targets
        }
        diagnostics = {
            "possible": len(solutions.points_unit),
            "likely": int(np.sum(solutions.likely)),
            "undecided_share": solutions.unsure_share,
            "mapping_evaluations": sum(r.maps_solutions for r in opt.records),
            "truth_membership": p_truth,
            "truth_likely": p_truth >= LIKELY,
            "truth_decided": p_truth >= SURE,
            # per response: estimated noise sd / true, model sd at the truth / true noise sd,
            # predicted miss at the truth in units of the report's tolerance there
            "noise_ratio": ";".join(
                f"{noise[t.key] / case.noise_sd[t.key]:.2f}" for t in case.targets
            ),
            "model_sd_at_truth": ";".join(
                f"{std[t.key][0] / case.noise_sd[t.key]:.2f}" for t in case.targets
            ),
            "miss_at_truth": ";".join(
                f"{abs(mean[t.key][0] - t.value) / tolerance[t.key]:.2f}" for t in case.targets
            ),
        }
    rows = []
    for i, name in enumerate(case.parameters):
        v = verdicts[i] if verdicts else None
        if v is None or math.isnan(v.low):
            low = high = math.nan
            all_low = all_high = math.nan
        else:
            low, high = (v.low - case.lower[i]) / box[i], (v.high - case.lower[i]) / box[i]
            all_low = (v.possible_low - case.lower[i]) / box[i]
            all_high = (v.possible_high - case.lower[i]) / box[i]
        rows.append(
            {
                **common,
                "parameter": name,
                "truth": case.truth[i],
                "verdict": v.verdict if v else "no models",
                "low": low,
                "high": high,
                "covered": bool(low <= truth_u[i] <= high),
                "error_low": abs(low - exact.minimum[i]),
                "error_high": abs(high - exact.maximum[i]),
                "width": high - low,
                "all_low": all_low,
                "all_high": all_high,
                "covered_all": bool(all_low <= truth_u[i] <= all_high),
                **diagnostics,
            }
        )
    return rows


# -------------------------------------------------------------------- summary
def summarise(case: Case, exact: ExactSet, rows: list[dict]) -> list[dict]:
    truth_u = (case.truth - case.lower) / (case.upper - case.lower)
    out = []
    for i, name in enumerate(case.parameters):
        mine = [r for r in rows if r["parameter"] == name]
        spans = [r for r in mine if not math.isnan(r["low"])]
        out.append(
            {
                "problem": case.name,
                "parameter": name,
                "runs": len(mine),
                "with_span": len(spans),
                "coverage_pct": 100.0 * np.mean([r["covered"] for r in mine]),
                "coverage_all_set_pct": 100.0 * np.mean([r["covered_all"] for r in mine]),
                "error_low": _mean([r["error_low"] for r in spans]),
                "error_high": _mean([r["error_high"] for r in spans]),
                "width": _mean([r["width"] for r in spans]),
                "exact_low": exact.low[i],
                "exact_high": exact.high[i],
                "exact_width": exact.high[i] - exact.low[i],
                "exact_min": exact.minimum[i],
                "exact_max": exact.maximum[i],
                "truth_unit": truth_u[i],
                "truth_in_exact_span": bool(exact.low[i] <= truth_u[i] <= exact.high[i]),
                "exact_method": exact.method,
                "exact_accepted": exact.accepted,
                "exact_sampled": exact.sampled,
            }
        )
    return out


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else math.nan


def overall(summary: list[dict], rows: list[dict]) -> dict:
    spans = [r for r in rows if not math.isnan(r["low"])]
    ends = [r["error_low"] for r in spans] + [r["error_high"] for r in spans]
    return {
        "coverage_pct": 100.0 * np.mean([r["covered"] for r in rows]),
        "coverage_all_set_pct": 100.0 * np.mean([r["covered_all"] for r in rows]),
        "mean_end_error": _mean(ends),
        "ends_within_0.1_pct": 100.0 * np.mean(np.array(ends) <= 0.1) if ends else math.nan,
        "parameters_meeting_coverage": sum(s["coverage_pct"] >= 90.0 for s in summary),
        "parameters_meeting_end_error": sum(
            max(s["error_low"], s["error_high"]) <= 0.1 for s in summary
        ),
        "parameters": len(summary),
        "runs_without_span": len({(r["problem"], r["seed"]) for r in rows})
        - len({(r["problem"], r["seed"]) for r in spans}),
    }


def table(summary: list[dict]) -> str:
    lines = [
        "| problem | parameter | coverage % | (whole set) % | end error low | end error high "
        "| mean width | exact span (width) | truth | runs with a span |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in summary:
        lines.append(
            f"| {s['problem']} | {s['parameter']} | {s['coverage_pct']:.0f} | "
            f"{s['coverage_all_set_pct']:.0f} | {s['error_low']:.3f} | {s['error_high']:.3f} | "
            f"{s['width']:.3f} | {s['exact_min']:.3f}–{s['exact_max']:.3f} "
            f"({s['exact_max'] - s['exact_min']:.3f}) | {s['truth_unit']:.3f} | "
            f"{s['with_span']}/{s['runs']} |"
        )
    return "\n".join(lines)


def write_csv(path: Path, rows: list[dict]) -> None:
    fields = list(dict.fromkeys(key for row in rows for key in row))
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fields)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: f"{v:.4g}" if isinstance(v, float) else v for k, v in row.items()})


def commit() -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(REPOSITORY), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--label", default="run", help="names the output files")
    parser.add_argument("--seeds", type=int, default=10, help="seeds per problem (0, 1, ...)")
    parser.add_argument(
        "--problems", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}"
    )
    parser.add_argument(
        "--budget", type=int, default=None, help="evaluations (default: the study's default)"
    )
    parser.add_argument("--workers", type=int, default=2, help="simulations in flight")
    parser.add_argument(
        "--map-solutions",
        type=int,
        default=0,
        help="evaluations that map the solution set after the search (default 0)",
    )
    parser.add_argument(
        "--spread-scale",
        type=float,
        default=1.0,
        help="multiply every target's measurement spread (thinner sets below 1)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smoke run: one seed of p2r2rep and lift_a, budget 15, a coarse exact set",
    )
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    if args.quick:
        args.seeds, args.problems, args.budget = 1, "p2r2rep,lift_a", args.budget or 15
    names = [n.strip() for n in args.problems.split(",") if n.strip()]
    unknown = [n for n in names if n not in CASES]
    if unknown:
        parser.error(f"--problems: unknown {', '.join(unknown)}; known: {', '.join(CASES)}")
    if args.seeds < 1:
        parser.error("--seeds: give at least 1")
    if not args.spread_scale > 0.0:
        parser.error("--spread-scale: give a number > 0")
    budget = args.budget or OptimizerSettings().max_evaluations
    started, wall = datetime.now(UTC), time.monotonic()
    rows, summary, total = [], [], len(names) * args.seeds
    done = 0
    for name in names:
        case = CASES[name]()
        case = replace(
            case,
            targets=tuple(replace(t, spread=t.spread * args.spread_scale) for t in case.targets),
        )
        t = time.monotonic()
        exact = exact_set(case, REPORT["k"], args.quick)
        print(
            f"{name}: exact set {exact.accepted} of {exact.sampled} points ({exact.method}), "
            f"{time.monotonic() - t:.0f} s",
            file=sys.stderr,
        )
        mine = []
        for seed in range(args.seeds):
            mine += run_one(case, exact, seed, args.budget, args.workers, args.map_solutions)
            done += 1
            elapsed = time.monotonic() - wall
            last = mine[-case.dimension :]
            print(
                f"[{done}/{total}] {name} seed {seed}: {last[0]['evaluations']} evaluations, "
                f"{last[0]['seconds']:.0f} s, covered "
                f"{sum(r['covered'] for r in last)}/{case.dimension}; "
                f"{elapsed / 60:.1f} min, about {elapsed / done * (total - done) / 60:.0f} min "
                "left",
                file=sys.stderr,
                flush=True,
            )
        rows += mine
        summary += summarise(case, exact, mine)
    minutes = (time.monotonic() - wall) / 60
    figures = overall(summary, rows)
    args.out.mkdir(parents=True, exist_ok=True)
    stem = f"solution_coverage_{args.label}"  # a label may hold dots: no with_suffix
    write_csv(args.out / f"{stem}.csv", summary + [{"problem": "overall", **figures}])
    write_csv(args.out / f"{stem}_runs.csv", rows)
    command = "python benchmarks/solution_coverage.py " + " ".join(argv or sys.argv[1:])
    import demcal

    text = "\n".join(
        [
            f"Solution coverage ({args.label})",
            "",
            f"Command: {command}",
            f"Date: {started:%Y-%m-%d %H:%M} UTC; total {minutes:.1f} min. demcal at {commit()} "
            f"({demcal.__file__}); Python {platform.python_version()}, numpy {np.__version__}; "
            f"{platform.machine()}, shared 2-core machine.",
            f"Calibrations: strategy {default('optimizer', 'strategy')}, objective form "
            f"by the study default ({default('objective')}), budget {budget}, "
            f"{args.workers} in flight, seeds 0-{args.seeds - 1}, target spreads x "
            f"{args.spread_scale:g}. Report: k {REPORT['k']}, "
            f"{REPORT['samples']} Sobol samples, seed {REPORT['seed']}.",
            f"Mapping evaluations after the search: {args.map_solutions}. Spans: the full "
            "extent of the likely set (reported) and of the exact set, in units of the box "
            "(0-1). End error: mean |reported end - exact end| over the runs with a span. "
            "Coverage: share of all runs (a run without a span counts as a miss); "
            "'(whole set)': the span of every set the models cannot rule out.",
            "",
            table(summary),
            "",
            "Overall: "
            + ", ".join(
                f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in figures.items()
            ),
            "",
        ]
    )
    (args.out / f"{stem}.txt").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
