"""``demcal advise STUDY.yaml [--tests SCENE ...] [--points K]``: which lab test to measure next.

On a finished calibration: K sets that span its likely solution set (greedy maximin, preferring
those the study simulated; the study's own tests are run at the others, under
``<study>-advice``), each candidate test simulated there (a campaign per test, into the
archive, under ``<study>-advice-<scene>``), the expected shrink of each free parameter's
likely span if a candidate response were measured (``demcal.analysis.advice``), the ranking
in words with each test's CPU, a figure, and a joint study file per test that reuses those
runs (docs/advise.md).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from demcal.analysis.advice import (
    PlaneFit,
    Shrink,
    fit_plane,
    rank,
    spanning_sets,
    spans_after,
)
from demcal.analysis.advice_report import (
    Advice,
    advice_record,
    joint_study_yaml,
    plot,
)
from demcal.analysis.fidelity import median_cpu, runs_table
from demcal.analysis.solution_report import SolutionAnalysis, analyse
from demcal.analysis.solutions import MIN_SOLUTIONS, SOLUTION_SAMPLES
from demcal.cli.options import profile_argument, whole_number
from demcal.cli.sample import INTERRUPTED, simulate
from demcal.cli.study_argument import study_of, study_yaml
from demcal.daemon.session import locked_study
from demcal.domain.campaign import forecast, unit_to_box, write_points
from demcal.errors import ConfigError, SimulationFailed
from demcal.jobs.steps import response_paths
from demcal.optimizer.bounds import to_unit_box
from demcal.optimizer.membership import LIKELY, membership_probability
from demcal.results.layout import evaluation_id
from demcal.results.records import FINE, CampaignRecord, PointRecord, ResponsesRecord, Status
from demcal.results.storage import write_json
from demcal.scenes import SCENES
from demcal.scenes.base import MATERIAL_SETTINGS
from demcal.snakemake_command import check_profile
from demcal.study.model import Study
from demcal.study.study_file import read_study_yaml

#: The most parameter sets an advice simulates each candidate test at.
MOST_SETS = 200
#: Keys of the study's YAML a candidate test's campaign does not take: they concern the
#: calibration's own tests and search.
CALIBRATION_ONLY = (
    "study",
    "scenes",
    "targets",
    "optimizer",
    "staging",
    "objective",
    "reuse",
    "fidelities",
)


def arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--tests",
        nargs="+",
        metavar="SCENE",
        help="the candidate lab tests (default: every lab test demcal simulates that the study "
        "does not have)",
    )
    sub.add_argument(
        "--points",
        type=whole_number(1, MOST_SETS),
        metavar="K",
        help="parameter sets of the likely solution set each candidate is simulated at "
        "(default 2 d + 1 for d free parameters; at least d + 1)",
    )
    sub.add_argument(
        "--spread",
        action="append",
        default=[],
        metavar="SCENE.RESPONSE=SD",
        help="the spread of single lab tests of a candidate response, in its unit (default: "
        "demcal's typical one, docs/advise.md); may be given for several",
    )
    sub.add_argument(
        "--parameters",
        nargs="+",
        metavar="NAME",
        help="the free parameters to narrow (default: every one not pinned yet)",
    )
    sub.add_argument(
        "--samples",
        type=whole_number(*SOLUTION_SAMPLES),
        default=2**16,
        help="Sobol points sampled over the box for the solution set (default 65536)",
    )
    profile_argument(sub)


def advise(args: argparse.Namespace) -> int:
    profile = Path(args.profile)
    settings = check_profile(profile)
    config = study_yaml(args.config, "advise")
    study = study_of(config)
    tests = candidate_tests(study, args.tests)
    spreads = given_spreads(args.spread, tests)
    dimension = len(study.free)
    count = 2 * dimension + 1 if args.points is None else args.points
    if count < dimension + 1:
        raise ConfigError(
            f"--points {count}: give at least {dimension + 1} (the {dimension} free parameters "
            f"plus one): each candidate response is fitted over the set as a plane"
        )
    if not study.files.finished.exists():
        raise ConfigError(
            f"advise: study {study.name!r} has not finished; run it to the end first "
            f"(demcal run {config}), then ask which test to add"
        )
    analysis = analyse(study, samples=args.samples)
    if int(analysis.solutions.likely.sum()) < MIN_SOLUTIONS:
        raise ConfigError(
            f"advise: study {study.name!r} has no likely solution set to narrow: "
            f"{analysis.verdicts[0].sentence}"
        )
    chosen = chosen_parameters(analysis, args.parameters)
    if not chosen.any():
        print(
            f"demcal advise: every free parameter of {study.name!r} is pinned by its targets "
            f"already ({', '.join(v.sentence for v in analysis.verdicts)}); no test to add"
        )
        return 0
    likely = analysis.solutions.points_unit[analysis.solutions.likely]
    if count > len(likely):
        raise ConfigError(
            f"--points {count}: the likely set holds only {len(likely)} sampled sets; give at "
            f"most that, or more --samples"
        )
    sets, sets_unit, fresh = advised_sets(study, analysis, likely, count)
    print(
        f"demcal advise: {study.name}: narrowing "
        + ", ".join(
            f"{v.name} ({v.verdict}, {v.low:.3g}–{v.high:.3g})"
            for v, c in zip(analysis.verdicts, chosen)
            if c
        )
        + f"; {count} sets that span the likely set, {count - len(fresh)} of them simulated "
        f"by the study already; each simulated in {', '.join(tests)}",
        flush=True,
    )
    raw = read_study_yaml(config)
    status = 0
    if fresh:
        status, _ = simulate_at(study, own_campaign_yaml(study, raw), fresh, profile, settings)
        if status == INTERRUPTED:
            return status
    shrinks, values, fits = [], {}, {}
    for scene in tests:
        code, runs = simulate_at(study, campaign_yaml(study, raw, scene), sets, profile, settings)
        if code == INTERRUPTED:  # said by simulate; the same command resumes
            return code
        status = max(status, code)
        for response in SCENES.load(scene).responses:
            judged = judge(analysis, runs, scene, response, sets, sets_unit, spreads, study)
            if judged is not None:
                shrinks.append(judged[0])
                values[judged[0].key], fits[judged[0].key] = judged[1:]
    if not shrinks:
        raise ConfigError("advise: no candidate test gave values to judge it by")
    advice = Advice(analysis, chosen, rank(shrinks, chosen), sets_unit, values, fits)
    say(advice, study, raw)
    return status


def advised_sets(
    study: Study, analysis: SolutionAnalysis, likely: np.ndarray, count: int
) -> tuple[list[dict[str, float]], np.ndarray, list[dict[str, float]]]:
    """The ``count`` sets the candidates are simulated at (`spanning_sets` over the ``likely``
    points, preferring the study's own simulated sets): their values, their unit coordinates,
    and the values of those the study has not simulated."""
    pool_values, pool_unit = simulated_sets(study, analysis)
    picks = spanning_sets(likely, pool_unit, count)
    sets = [
        pool_values[i] if simulated else unit_to_box(study, likely[i][None, :])[0]
        for simulated, i in picks
    ]
    sets_unit = np.array([pool_unit[i] if simulated else likely[i] for simulated, i in picks])
    fresh = [values for values, (simulated, _) in zip(sets, picks) if not simulated]
    return sets, sets_unit, fresh


def judge(
    analysis: SolutionAnalysis,
    runs: Any,
    scene: str,
    response: str,
    sets: list[dict[str, float]],
    sets_unit: np.ndarray,
    spreads: dict[str, float],
    study: Study,
) -> tuple[Shrink, np.ndarray, PlaneFit] | None:
    """What measuring one candidate response would do (`spans_after` on its plane over the
    sets' values), with its mean at each set and the plane; None, said, when fewer than d + 1
    sets gave it a value."""
    spec = SCENES.load(scene).responses[response]
    key = f"{scene}.{response}"
    means = set_means(runs, key, sets, study)
    ok = np.isfinite(means)
    if ok.sum() < len(analysis.names) + 1:
        print(
            f"demcal advise: {key}: left out: {int(ok.sum())} of the {len(sets)} sets gave a "
            f"value, a plane needs {len(analysis.names) + 1} (see the campaign's log)"
        )
        return None
    fit = fit_plane(sets_unit[ok], means[ok])
    spread = spreads.get(key, spec.typical_spread(float(np.mean(means[ok]))))
    assert spread is not None, "candidates are lab tests: every response has a spread"
    lows, highs = spans_after(analysis.solutions, key, fit, means[ok], spread)
    before = np.array([v.share for v in analysis.verdicts])
    cpu = median_cpu(runs, FINE, scene)
    return (
        Shrink(scene, response, spec.unit, spread, before, lows, highs, cpu, fit.residual_sd),
        means,
        fit,
    )


def candidate_tests(study: Study, given: list[str] | None) -> list[str]:
    """The lab tests to consider: ``given`` (each checked) or every lab-test scene that runs on
    the study's engine and is not among the study's scenes."""
    engine = study.engine.name
    lab = [name for name in SCENES if SCENES.load(name).lab_test]
    runnable = [name for name in lab if SCENES.load(name).driver(engine) is not None]
    if given is None:
        tests = [name for name in runnable if name not in study.scenes]
        if not tests:
            raise ConfigError(
                f"advise: the study has every lab test demcal simulates on {engine} already "
                f"({', '.join(runnable)})"
            )
        return tests
    for name in given:
        if name not in SCENES:
            raise ConfigError(
                f"--tests {name}: not a test demcal simulates; lab tests: {', '.join(lab)}"
            )
        if name not in lab:
            raise ConfigError(
                f"--tests {name}: a design case, not a lab test; lab tests: {', '.join(lab)}"
            )
        if name not in runnable:
            raise ConfigError(f"--tests {name}: demcal does not simulate it on {engine}")
        if name in study.scenes:
            raise ConfigError(f"--tests {name}: a test of the study already")
    return list(dict.fromkeys(given))


def given_spreads(words: list[str], tests: list[str]) -> dict[str, float]:
    """The ``--spread SCENE.RESPONSE=SD`` words as {key: sd}, each checked."""
    spreads = {}
    for word in words:
        key, _, text = word.partition("=")
        scene, _, response = key.partition(".")
        if scene not in tests or response not in SCENES.load(scene).responses:
            known = [f"{t}.{r}" for t in tests for r in SCENES.load(t).responses]
            raise ConfigError(
                f"--spread {word}: give SCENE.RESPONSE=SD for a candidate response "
                f"({', '.join(known)})"
            )
        try:
            sd = float(text)
        except ValueError:
            sd = math.nan
        if not 0.0 < sd < math.inf:
            raise ConfigError(f"--spread {word}: the spread must be a number above 0")
        spreads[key] = sd
    return spreads


def chosen_parameters(analysis: SolutionAnalysis, names: list[str] | None) -> np.ndarray:
    """A mask of the free parameters to narrow: ``names`` (each checked), else every one not
    pinned."""
    if names is None:
        return np.array([v.verdict != "pinned" for v in analysis.verdicts])
    for name in names:
        if name not in analysis.names:
            raise ConfigError(
                f"--parameters {name}: not a free parameter of the study "
                f"({', '.join(analysis.names)})"
            )
    return np.array([name in names for name in analysis.names])


def simulated_sets(study: Study, analysis: SolutionAnalysis) -> tuple[list[dict[str, float]], Any]:
    """The parameter sets the study itself simulated (its own fine, ok evaluations, each once)
    that lie in its likely solution set: their values as written (so that the archive groups
    a candidate's runs with the study's at the same set) and their unit coordinates."""
    names = [p.name for p in study.free]
    found: dict[tuple[float, ...], dict[str, float]] = {}
    for directory in sorted(study.files.evals.glob("e[0-9]*")):
        files = study.files.evaluation(directory.name)
        try:
            point = PointRecord.read(files.params)
        except SimulationFailed:
            continue
        values = point.parameters
        if point.level != FINE or not all(isinstance(values.get(n), int | float) for n in names):
            continue
        if not all(ok_runs(study, directory.name)):
            continue
        found.setdefault(tuple(float(values[n]) for n in names), {n: values[n] for n in names})
    if not found:
        return [], np.empty((0, len(names)))
    unit = to_unit_box(np.array(list(found)), analysis.lower, analysis.upper)
    means, stds = analysis.predictor.predict(unit)
    s = analysis.solutions
    likely = (
        membership_probability(analysis.predictor.objective.targets, means, stds, s.noise_sd, s.k)
        >= LIKELY
    )
    return [v for v, keep in zip(found.values(), likely) if keep], unit[likely]


def ok_runs(study: Study, evaluation: str) -> list[bool]:
    """Whether each scene replicate of an evaluation finished ok."""
    oks = []
    for path in response_paths(study, evaluation):
        try:
            oks.append(ResponsesRecord.read(path).status == Status.OK)
        except SimulationFailed:
            oks.append(False)
    return oks


def simulate_at(
    study: Study,
    config: dict[str, Any],
    sets: list[dict[str, float]],
    profile: Path,
    settings: dict[str, Any],
) -> tuple[int, Any]:
    """Run the campaign study ``config`` (a study file's mapping) at ``sets`` (its YAML in the
    study's advice folder, its results under its own name); its exit status and its runs
    (`runs_table`)."""
    study.files.advice_dir.mkdir(parents=True, exist_ok=True)
    path = study.files.advice_dir / f"{config['study']}.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    with locked_study(path) as campaign_study:
        names, campaign = advice_points(campaign_study, sets)
        print(
            f"demcal advise: {campaign_study.name}: {forecast(campaign_study, campaign, settings)}",
            flush=True,
        )
        code = simulate(campaign_study, names, profile, 1, "advise")
        return code, runs_table(campaign_study, names)


def own_campaign_yaml(study: Study, raw: dict[str, Any]) -> dict[str, Any]:
    """The study file of the campaign that runs the study's own tests at the new sets, so that
    a joint study finds every test at each of them."""
    kept = {key: value for key, value in raw.items() if key not in CALIBRATION_ONLY}
    return {
        "study": f"{study.name}-advice",
        **kept,
        **({"scenes": raw["scenes"]} if raw.get("scenes") else {}),
        "targets": raw["targets"],
    }


def material_settings(study: Study, scene: str) -> dict[str, Any]:
    """The settings of the study's (first) scene that describe the material rather than the
    test (its particle sizes), for the candidate test ``scene``."""
    first = next(iter(study.scenes))
    known = SCENES.load(scene).settings
    return {
        name: study.settings[first][name]
        for name in MATERIAL_SETTINGS
        if name in study.settings[first] and name in known
    }


def campaign_yaml(study: Study, raw: dict[str, Any], scene: str) -> dict[str, Any]:
    """The study file of a candidate test's campaign: the study's material, engine, bounds and
    seeds, the test alone, with every response measured (a target that asks nothing: at least
    the response's physical lower bound)."""
    spec = SCENES.load(scene)
    kept = {key: value for key, value in raw.items() if key not in CALIBRATION_ONLY}
    carried = material_settings(study, scene)
    return {
        "study": f"{study.name}-advice-{scene}",
        **kept,
        "scenes": {scene: {"settings": carried} if carried else {}},
        "targets": [
            {"scene": scene, "response": name, "unit": response.unit, "at_least": response.lower}
            for name, response in spec.responses.items()
        ],
    }


def advice_points(
    candidate: Study, sets: list[dict[str, float]]
) -> tuple[list[str], CampaignRecord]:
    """The campaign's evaluation of each of ``sets``, in order (one already written for the
    same values, else a new one at the end: an earlier advice's points are kept), and the
    campaign. Writes campaign.json, then the new points' params.json; a failed run is
    retried (`write_points`)."""
    names = [p.name for p in candidate.free]
    existing = CampaignRecord.read_if_any(candidate.files.campaign)
    known: dict[tuple[float, ...], str] = {}
    count = 0 if existing is None else len(existing.unit_points)
    for index in range(count):
        try:
            point = PointRecord.read(candidate.files.evaluation(evaluation_id(index)).params)
            known[tuple(float(point.parameters[n]) for n in names)] = evaluation_id(index)
        except (SimulationFailed, KeyError, TypeError, ValueError):
            continue
    unit = [] if existing is None else list(existing.unit_points)
    lower = np.array([p.lower for p in candidate.free])
    upper = np.array([p.upper for p in candidate.free])
    new = []
    for values in sets:
        key = tuple(float(values[n]) for n in names)
        if key not in known:
            known[key] = evaluation_id(len(unit))
            unit.append(to_unit_box(np.array(key), lower, upper).tolist())
            new.append((known[key], values))
    campaign = CampaignRecord("advice", 0, unit, [FINE])
    campaign.write(candidate.files.campaign)
    for name, values in new:
        PointRecord(values, proposed_by="advice").write(candidate.files.evaluation(name).params)
    write_points(candidate, campaign)
    return [known[tuple(float(values[n]) for n in names)] for values in sets], campaign


def set_means(runs: Any, key: str, sets: list[dict[str, float]], study: Study) -> np.ndarray:
    """The mean of response ``key`` at each of ``sets`` (NaN where no run gave one)."""
    names = [p.name for p in study.free]
    rows = runs[runs["response"] == key]
    means = rows.groupby("point")["value"].mean().to_dict()
    return np.array(
        [means.get(tuple(float(v[n]) for n in names), math.nan) for v in sets], dtype=float
    )


def say(advice: Advice, study: Study, raw: dict[str, Any]) -> None:
    """The ranking in words, then the files: advice.json, the figure, and a joint study file
    per candidate test (its best response's placeholder target)."""
    files = study.files
    joint: dict[str, str] = {}
    written: set[str] = set()
    for shrink in advice.ranked:
        if shrink.scene in written:
            continue
        written.add(shrink.scene)
        name = f"{study.name}-{shrink.scene}"
        path = files.advice_dir / f"{name}.yaml"
        target = {
            "scene": shrink.scene,
            "response": shrink.response,
            "unit": shrink.unit,
            "spread": float(f"{shrink.spread:.3g}"),
        }
        path.write_text(
            joint_study_yaml(
                raw,
                list(study.scenes),
                name,
                shrink.scene,
                material_settings(study, shrink.scene),
                target,
                study.archive is not None,
                path,
            )
        )
        joint[shrink.key] = str(path)
    print("demcal advise: the candidates, the one that narrows the set most first:")
    for n, shrink in enumerate(advice.ranked, 1):
        print(f"  {n}. {advice.sentence(shrink)}")
    plot(advice, files.advice_figure)
    write_json(files.advice, advice_record(advice, study.name, joint))
    best = advice.ranked[0]
    print(
        f"demcal advise: figure {files.advice_figure}, ranking {files.advice}",
        f"demcal advise: next: measure {best.response} in the {best.scene.replace('_', ' ')}, "
        f"write it into {joint[best.key]} (targets: its value), then demcal run "
        f"{joint[best.key]}",
        sep="\n",
    )
