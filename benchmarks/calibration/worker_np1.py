"""Run one GrainLearning or ACCES calibration of a benchmark problem; write JSON.

These two peers pin NumPy < 2, so they live in their own venv
(requirements-np1.txt) and run.py calls this script there, once per
(tool, problem, seed, budget):

    /work/bench-venv-np1/bin/python benchmarks/calibration/worker_np1.py \\
        --tool grainlearning --problem p3r3 --seed 0 --budget 20 --json out.json

Output JSON: tool, version, evaluations ([{x, objective}] in evaluation
order; objective = the noisy eq. 3.3 the tool saw), answer (the point the
tool reports), extra (tool-specific), tool_seconds (wall time minus time in
the simulations), or error (a message, when the tool could not run).
``--versions`` prints the peers' versions instead.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import tempfile
import textwrap
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from problems import PROBLEMS, Evaluator, Problem, mean_responses  # noqa: E402
from versions import installed_versions  # noqa: E402

GRAINLEARNING_SAMPLES = 10  # per iteration; iterations = budget // 10
ACCES_POPULATION = 5  # per epoch; epochs = budget // 5


def versions() -> dict[str, str]:
    return installed_versions(
        ("grainlearning", "coexist", "cma", "numpy", "scipy", "scikit-learn", "pandas")
    )


# ------------------------------------------------------------- GrainLearning
def run_grainlearning(problem: Problem, seed: int, budget: int) -> dict:
    """Iterative Bayesian filter (SMC + Gaussian-mixture resampling).

    ``budget // 10`` iterations of 10 samples, Halton start, ess_target 0.3,
    one mixture component (the package's tutorial settings), but sampling
    from the mixture as the package's default does (``slice_sampling``
    False): with the tutorials' slice sampling, the resampling here kept
    multiplying its number of draws by 10 and ran out of memory (up to
    73 GiB asked) in 4 of 5 trial runs (p3r3, p5r2; budgets 20 and 40). The
    simulation data of a sample is its replicate-mean responses (one "time step", one observable per
    response); the observations are the targets. GrainLearning's likelihood
    uses a diagonal covariance sigma * target^2, so its weights follow the
    same relative errors as eq. 3.3. Answer: ``get_most_prob_params()`` (the
    sample of the last iteration with the highest posterior weight); the
    posterior mean (``system.estimated_params``) is kept in ``extra``.
    """
    from grainlearning import BayesianCalibration

    evaluator = Evaluator(problem, seed)
    keys = problem.keys

    def callback(calibration):
        data = []
        for params in calibration.system.param_data:
            responses, _, _ = evaluator(params)
            means = mean_responses(responses)
            data.append(np.array([[means[k]] for k in keys]))  # (observables, steps)
        calibration.system.set_sim_data(data)

    targets = problem.targets
    calibration = BayesianCalibration.from_dict(
        {
            "num_iter": max(budget // GRAINLEARNING_SAMPLES, 1),
            "callback": callback,
            "system": {
                "param_names": list(problem.parameters),
                "param_min": list(problem.lower),
                "param_max": list(problem.upper),
                "num_samples": GRAINLEARNING_SAMPLES,
                "obs_names": keys,
                "obs_data": [[targets[k]] for k in keys],
                "sim_name": problem.name,
            },
            "inference": {
                "Bayes_filter": {"ess_target": 0.3},
                "sampling": {
                    "max_num_components": 1,
                    "n_init": 1,
                    "random_state": seed,
                    "slice_sampling": False,
                },
                "initial_sampling": "halton",
            },
            "save_fig": -1,
        }
    )
    start = time.perf_counter()
    calibration.run()
    total = time.perf_counter() - start
    answer = [float(v) for v in calibration.get_most_prob_params()]
    posterior_mean = [float(v) for v in calibration.system.estimated_params[-1]]
    return {
        "evaluations": evaluator.log,
        "answer": answer,
        "extra": {
            "posterior_mean": posterior_mean,
            "iterations": len(calibration.inference.sigma_list),
        },
        "tool_seconds": total - evaluator.seconds,
    }


# --------------------------------------------------------------------- ACCES
ACCES_SCRIPT = """\
# One simulation of benchmark problem {name} for ACCES (written by worker_np1.py).
# ACCESS PARAMETERS START
import pandas as pd

# the table coexist.create_parameters(variables, minimums, maximums) makes (start at
# the middle, sigma 40 % of the range), built with pandas so that each simulation
# process is spared importing coexist (1.2 s)
parameters = pd.DataFrame(
    {{"value": {values!r}, "min": {minimums!r}, "max": {maximums!r}, "sigma": {sigmas!r}}},
    index={variables!r},
)
access_id = 0
# ACCESS PARAMETERS END

import sys

sys.path.insert(0, {here!r})
from problems import PROBLEMS, mean_responses

problem = PROBLEMS[{name!r}]
x = [float(parameters.at[name, "value"]) for name in problem.parameters]
responses = problem.noisy_responses(x, {seed!r}, access_id)
error = problem.squared_errors(mean_responses(responses))  # one per response; Sum() makes eq. 3.3
extra = responses
"""


def run_acces(problem: Problem, seed: int, budget: int) -> dict:
    """ACCES (coexist.Access): CMA-ES over populations of simulation scripts run as processes.

    The simulation script returns one error per response, ((y - r) / r)^2,
    combined by ``coexist.combiners.Sum()`` into eq. 3.3. Population 5, so
    the budget is ``budget // 5`` epochs; ACCES has no evaluation budget of
    its own, so ``finished`` is extended to stop once it is spent (and
    target_sigma is 0, so ACCES does not stop on its own criterion first).
    Answer: ``AccessData.parameters["value"]`` (what ``learn`` returns: the
    evaluated combination with the lowest error). Simulations are the
    processes started in ``evaluate_solutions``; their wall time counts as
    simulation time, not tool time.
    """
    import coexist
    from coexist.combiners import Sum

    class BudgetedAccess(coexist.Access):
        simulation_seconds = 0.0

        def finished(self, es):
            return super().finished(es) or es.result.evaluations >= budget

        def evaluate_solutions(self, solutions, epoch):
            start = time.perf_counter()
            try:
                return super().evaluate_solutions(solutions, epoch)
            finally:
                self.simulation_seconds += time.perf_counter() - start

    with tempfile.TemporaryDirectory(prefix="acces_") as folder:
        previous = os.getcwd()
        os.chdir(folder)
        try:
            script = Path(folder) / "simulation.py"
            standard = coexist.create_parameters(
                list(problem.parameters), list(problem.lower), list(problem.upper)
            )
            script.write_text(
                ACCES_SCRIPT.format(
                    name=problem.name,
                    variables=list(standard.index),
                    values=standard["value"].tolist(),
                    minimums=standard["min"].tolist(),
                    maximums=standard["max"].tolist(),
                    sigmas=standard["sigma"].tolist(),
                    here=str(HERE),
                    seed=seed,
                )
            )
            start = time.perf_counter()
            access = BudgetedAccess(str(script))
            data = access.learn(
                num_solutions=ACCES_POPULATION,
                target_sigma=0.0,
                random_seed=seed,
                multi_objective=Sum(),
                verbose=0,
            )
            total = time.perf_counter() - start
            results = data.results
            evaluations = [
                {
                    "x": [float(results.at[i, n]) for n in problem.parameters],
                    "objective": float(results.at[i, "error"]),
                }
                for i in range(len(results))
            ]
            answer = [float(data.parameters.at[n, "value"]) for n in problem.parameters]
            epochs = data.epochs
            last_mean = [float(epochs.iloc[-1][f"{n}_mean"]) for n in problem.parameters]
        finally:
            os.chdir(previous)
    return {
        "evaluations": evaluations,
        "answer": answer,
        "extra": {"epochs": int(data.num_epochs), "last_epoch_mean": last_mean},
        "tool_seconds": total - access.simulation_seconds,
    }


RUNNERS = {"grainlearning": run_grainlearning, "acces": run_acces}
VERSION_OF = {"grainlearning": "grainlearning", "acces": "coexist"}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--tool", choices=sorted(RUNNERS))
    parser.add_argument("--problem", choices=sorted(PROBLEMS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--budget", type=int, default=20)
    parser.add_argument("--json", type=Path, help="write the result here (default: stdout)")
    parser.add_argument(
        "--versions", action="store_true", help="print the peers' versions as JSON and exit"
    )
    args = parser.parse_args()
    if args.versions:
        print(json.dumps(versions()))
        return
    if not args.tool or not args.problem:
        parser.error("--tool and --problem are needed")
    result = {
        "tool": args.tool,
        "problem": args.problem,
        "seed": args.seed,
        "budget": args.budget,
        "version": versions()[VERSION_OF[args.tool]],
    }
    try:
        # the tools print progress; keep stdout for the JSON
        with contextlib.redirect_stdout(sys.stderr):
            np.random.seed(args.seed)  # for anything drawing from NumPy's global generator
            result.update(RUNNERS[args.tool](PROBLEMS[args.problem], args.seed, args.budget))
    except Exception as error:  # reported to the harness, which carries on with the other tools
        traceback.print_exc()
        result["error"] = f"{type(error).__name__}: {textwrap.shorten(str(error), 300)}"
    text = json.dumps(result)
    if args.json:
        args.json.write_text(text)
    else:
        print(text)


if __name__ == "__main__":
    main()
