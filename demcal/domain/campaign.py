"""Sampling campaigns (``demcal sample``): a space-filling design over a study's box, simulated
once, into the archive (Richter & Will 2021, secs. 2.3 and 3: a material domain simulated
once serves every later calibration of a material in it).

A campaign is a study folder whose evaluations are the points of one design
(``campaign.json``): ``e0000`` is its first point. Each point runs through the same
simulate -> extract jobs as a calibration, all of them under one Snakemake with the chosen
profile (SLURM included), and every simulation lands in the study's archive. Run the same
command again to resume it (finished simulations are not run again, failed ones are, with a
new seed); give a larger ``--n``
to extend it: the design's next points follow (:func:`demcal.optimizer.designs.extend_design`),
so the whole stays space-filling. A campaign runs at most :data:`MAX_SIMULATIONS`
simulations. Its Snakemake ends with the demcal that started it, even a killed one
(:data:`GUARD`), and a run that finds one of an earlier run still going ends it first.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import subprocess
import sys
import time
import zlib
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from statistics import median
from typing import Any

import numpy as np

from demcal.archive.store import Archive
from demcal.daemon.launcher import is_snakemake_for
from demcal.engines.base import GRACE_SECONDS
from demcal.errors import ConfigError, SimulationFailed
from demcal.jobs.steps import response_paths
from demcal.optimizer.bounds import from_unit_box
from demcal.optimizer.designs import (
    EXTENSIBLE,
    cover_measure,
    extend_design,
    minimum_pairwise_distance,
)
from demcal.optimizer.registry import DESIGNS
from demcal.reporting.terminal import duration
from demcal.results.archive_url import missing_file
from demcal.results.layout import SIMULATION_FILE, evaluation_id
from demcal.results.records import FINE, CampaignRecord, PointRecord, ResponsesRecord, Status
from demcal.snakemake_command import runs_locally, snakemake_command
from demcal.study.model import Study

#: The designs a campaign may use (Richter & Will chose FSSF-f).
CAMPAIGN_DESIGNS = ("fssf_f", "sobol", "halton", "latin_hypercube")
#: A campaign whose first simulations all failed stops: something is wrong with every point.
FAIL_FAST = 5
#: Seconds between looks at the simulations that have finished.
POLL_S = 2.0
#: Simulations one campaign may hold (points x replicates x scenes): its Snakemake takes each
#: as a target on its command line, which the kernel bounds (2 MB on Linux), and the design's
#: quality measures hold the distances between every two points.
MAX_SIMULATIONS = 5000
#: Archived simulations of a scene whose median wall time is a campaign's cost per simulation.
COST_SAMPLE = 200
#: What a campaign's demcal tells the guard of its Snakemake once that has ended.
ENDED = b"ended"
#: The guard of a campaign's Snakemake session (arguments: the session, the grace time [s]):
#: a small process of its own, so that it outlives its demcal, even a killed one. When its
#: stdin closes without ENDED, it ends the session as Ctrl-C in a terminal would: SIGTERM to
#: Snakemake and its jobs (Snakemake alone would let its jobs finish first), then SIGKILL
#: after the grace time to those still running. A process that has ended but is not reaped
#: yet (a zombie: an orphan waits for init, which may take seconds) counts as ended.
GUARD = f"""
import os, signal, sys, time
session, grace = int(sys.argv[1]), float(sys.argv[2])

def running():
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{{entry}}/stat") as stat:
                state, _, group = stat.read().rsplit(")", 1)[1].split()[:3]
        except (OSError, ValueError):
            continue
        if int(group) == session and state != "Z":
            return True
    return False

if sys.stdin.buffer.read() != {ENDED!r}:
    try:
        os.killpg(session, signal.SIGTERM)
        deadline = time.monotonic() + grace
        while running() and time.monotonic() < deadline:
            time.sleep(0.1)
        if running():
            os.killpg(session, signal.SIGKILL)
    except ProcessLookupError:
        pass
"""


def unit_to_box(study: Study, unit: np.ndarray) -> list[dict[str, float]]:
    """Points of the unit box as free-parameter values inside the study's bounds."""
    lower = np.array([p.lower for p in study.free])
    upper = np.array([p.upper for p in study.free])
    values = from_unit_box(unit, lower, upper)
    return [{p.name: float(v) for p, v in zip(study.free, row)} for row in values]


def simulations_per_point(study: Study, levels: int = 1) -> int:
    """The simulations of one design point: a replicate set of every scene at each of
    ``levels`` fidelity levels."""
    return study.replicates * len(study.scenes) * levels


def check_request(size: int, design: str, bundle: int = 1, per_point: int = 1) -> None:
    """A ConfigError for a design size or kind, or a bundle of simulations per cluster job,
    that no campaign can have; ``per_point``: the simulations of each point."""
    if design not in CAMPAIGN_DESIGNS:
        raise ConfigError(f"--design {design}: use one of {', '.join(CAMPAIGN_DESIGNS)}")
    most = MAX_SIMULATIONS // per_point
    if not 2 <= size <= most:
        raise ConfigError(
            f"--points {size}: give 2 to {most} points (a campaign runs at most {MAX_SIMULATIONS} "
            f"simulations, here {per_point} per point)"
        )
    if bundle < 1:
        raise ConfigError(f"--bundle {bundle}: give at least 1 simulation per cluster job")


def design_seed(study: Study) -> int:
    """The seed of a new campaign's design: the study's seed and its name, so that a campaign
    run under another name (``--name``, a held-out set) gets other points."""
    key = [study.seed, zlib.crc32(study.name.encode())]
    return int(np.random.SeedSequence(key).generate_state(1)[0])


def plan(
    study: Study, size: int, design: str, fidelities: Sequence[str] = (FINE,)
) -> CampaignRecord:
    """The campaign of ``size`` points, each run at every level of ``fidelities``: the one on
    disk, extended if ``size`` is larger, or a new design. A ConfigError says why a campaign
    cannot become what was asked, and refuses a study folder that holds evaluations of
    something else (a calibration)."""
    check_request(size, design, per_point=simulations_per_point(study, len(fidelities)))
    dimension, existing = len(study.free), CampaignRecord.read_if_any(study.files.campaign)
    if existing is not None and existing.fidelities != list(fidelities):
        raise ConfigError(
            f"the campaign in {study.files.dir} runs at {', '.join(existing.fidelities)}, not "
            f"{', '.join(fidelities)}; run it at its levels, or give the study another name"
        )
    if existing is None and study.files.evals.is_dir() and any(study.files.evals.iterdir()):
        raise ConfigError(
            f"{study.files.dir} holds evaluations that are not a campaign's (a calibration?); "
            f"run the campaign as another study: --name"
        )
    if existing is None:
        seed = design_seed(study)
        rng = np.random.default_rng(seed)
        if design in EXTENSIBLE:
            unit = extend_design(design, np.empty((0, dimension)), size, dimension, rng)
        else:
            unit = DESIGNS[design].load()(size, dimension, rng)
        return CampaignRecord(design, seed, np.asarray(unit).tolist(), list(fidelities))
    if existing.design != design:
        raise ConfigError(
            f"--design {design}: the campaign in {study.files.dir} is a {existing.design} design; "
            f"extend it with --design {existing.design}, or give the study another name"
        )
    taken = np.asarray(existing.unit_points)
    if size <= len(taken):
        return existing
    if design not in EXTENSIBLE:
        raise ConfigError(
            f"--points {size}: a {design} design of {len(taken)} points cannot be extended and "
            f"stay space-filling; start another study with --design fssf_f, sobol or halton"
        )
    more = extend_design(design, taken, size, dimension, np.random.default_rng(existing.seed))
    return CampaignRecord(
        design, existing.seed, np.vstack([taken, more]).tolist(), existing.fidelities
    )


def write_points(study: Study, campaign: CampaignRecord) -> list[str]:
    """params.json of every point not written yet, and of every point whose simulation failed
    (its next attempt: a new seed, so the archive keeps both runs); returns every
    evaluation's name. campaign.json is written first, so that a run killed while writing the
    points is still taken for a campaign when it is run again."""
    campaign.write(study.files.campaign)
    names = point_names(campaign)
    runs = [
        (point, level)
        for point in unit_to_box(study, np.asarray(campaign.unit_points))
        for level in campaign.fidelities
    ]
    for name, (point, level) in zip(names, runs):
        files = study.files.evaluation(name)
        if not files.params.exists():
            PointRecord(
                point,
                proposed_by=f"campaign ({campaign.design})",
                fidelity=None if level == FINE else level,
            ).write(files.params)
        else:
            retry_failed(study, name)
    return names


def point_names(campaign: CampaignRecord) -> list[str]:
    """The evaluation of each point of the design at each of its levels, in order: e0000,
    e0001, ... (point k at level j is evaluation ``k * len(fidelities) + j``)."""
    runs = len(campaign.unit_points) * len(campaign.fidelities)
    return [evaluation_id(index) for index in range(runs)]


def retry_failed(study: Study, name: str) -> None:
    """When a simulation of evaluation ``name`` failed: the point's next attempt in its
    params.json, and the failed outputs removed, so that Snakemake runs it again."""
    failed = []
    for path in response_paths(study, name):
        try:
            record = ResponsesRecord.read(path)
        except SimulationFailed:
            continue
        if record.status == Status.FAILED:
            failed.append((path, record.reason))
    if not failed:
        return
    files = study.files.evaluation(name)
    point = PointRecord.read(files.params)
    dataclasses.replace(
        point,
        attempt=point.attempt + 1,
        previous_failures=[*point.previous_failures, *(reason for _, reason in failed)],
    ).write(files.params)
    for path, _ in failed:
        path.unlink()
        path.with_name(SIMULATION_FILE).unlink(missing_ok=True)


@dataclass
class Tally:
    """How a campaign's simulations stand: finished ones by status, the commonest reason."""

    total: int
    statuses: Counter[str]
    reasons: Counter[str]
    #: the campaign was stopped because its first simulations all failed
    stopped: bool = False

    @property
    def finished(self) -> int:
        return sum(self.statuses.values())

    def hopeless(self, before: Tally | None = None) -> bool:
        """True when the first FAIL_FAST simulations that finished (since ``before``) all
        failed."""
        done = self.finished - (before.finished if before else 0)
        ok = self.statuses[Status.OK] - (before.statuses[Status.OK] if before else 0)
        return done >= FAIL_FAST and ok == 0

    def line(self) -> str:
        counts = ", ".join(f"{n} {s}" for s, n in sorted(self.statuses.items()))
        return f"{self.finished} of {self.total} simulations finished ({counts or 'none yet'})"


def tally(study: Study, names: list[str]) -> Tally:
    """The finished simulations of the evaluations ``names`` (their responses.json)."""
    paths = [path for name in names for path in response_paths(study, name)]
    statuses: Counter[str] = Counter()
    reasons: Counter[str] = Counter()
    for path in paths:
        try:
            record = ResponsesRecord.read(path)
        except SimulationFailed:  # not written yet, or being written
            continue
        statuses[str(record.status)] += 1
        if record.status != Status.OK:
            reasons[record.reason.split(":")[0]] += 1
    return Tally(len(paths), statuses, reasons)


def design_quality(campaign: CampaignRecord) -> tuple[float, float]:
    """The design's minimum inter-site distance and cover measure in the unit box (Richter &
    Will 2021, eqs. 7-8): larger and smaller are better."""
    points = np.asarray(campaign.unit_points)
    return minimum_pairwise_distance(points), cover_measure(points)


def simulation_times(study: Study) -> dict[str, tuple[float, int]]:
    """Per scene of the study, the median wall time [s] of the archive's ok simulations of it
    on the study's engine (the first COST_SAMPLE), and how many that is; a scene the archive
    holds none of is left out."""
    if study.archive is None or missing_file(study.archive) is not None:
        return {}
    times = {}
    with Archive(study.archive) as archive:
        for scene in study.scenes:
            walls = [
                float(record.cost["wall_s"])
                for record in archive.records(
                    scene=scene, engine=study.engine.name, statuses=[Status.OK], limit=COST_SAMPLE
                )
                if isinstance(record.cost.get("wall_s"), int | float)
            ]
            if walls:
                times[scene] = (median(walls), len(walls))
    return times


def runs_at_once(settings: Mapping[str, Any]) -> int:
    """Simulations a campaign's Snakemake runs at a time with a profile's ``settings``: its
    ``jobs`` on a cluster, its ``cores`` on this machine (all of them when it sets none)."""
    local = settings.get("executor", "local") == "local"
    value = settings.get("cores" if local else "jobs")
    if isinstance(value, int) and value > 0:
        return value
    return (os.cpu_count() or 1) if local else 1


def forecast(study: Study, campaign: CampaignRecord, settings: Mapping[str, Any]) -> str:
    """How many of the campaign's simulations are still to run (the failed ones run again),
    and how long they take ``runs_at_once`` at a time at the archive's median wall time per
    simulation of each scene; or that the archive does not know that time yet."""
    state = tally(study, point_names(campaign))
    left = state.total - state.finished + state.statuses[Status.FAILED]
    parallel = runs_at_once(settings)
    head = f"{left} of {state.total} simulations to run, {parallel} at a time"
    if left == 0:
        return head
    times = simulation_times(study)
    unknown = [scene for scene in study.scenes if scene not in times]
    if unknown:
        return (
            f"{head}; how long they take is not known yet: the archive holds no finished "
            f"{', '.join(unknown)} simulation on {study.engine.name}"
        )
    each = sum(wall for wall, _ in times.values()) / len(times)  # every point runs every scene
    measured = ", ".join(
        f"{scene} {duration(wall)} ({count} runs)" for scene, (wall, count) in times.items()
    )
    return (
        f"{head}: about {duration(left * each / parallel)}, at the median wall time of the "
        f"archive's simulations on {study.engine.name}: {measured}"
    )


def guard(session: int) -> subprocess.Popen[bytes]:
    """A :data:`GUARD` over the Snakemake session ``session``, in a session of its own."""
    return subprocess.Popen(
        [sys.executable, "-I", "-c", GUARD, str(session), str(GRACE_SECONDS)],
        stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )


def release(watch: subprocess.Popen[bytes], ended: bool) -> None:
    """Close the stdin of the guard ``watch``, saying whether its Snakemake has ``ended``: if
    not, the guard ends it."""
    assert watch.stdin is not None  # guard() opens it
    with contextlib.suppress(OSError):  # a guard gone already
        if ended:
            watch.stdin.write(ENDED)
        watch.stdin.close()


def end_earlier_runs(study: Study) -> list[int]:
    """End every Snakemake of an earlier run of this campaign still going, found in /proc by
    the study file on its command line, as its guard would; returns their pids."""
    argument = f"study_file={study.files.study.resolve()}"
    stale = [
        int(entry.name)
        for entry in Path("/proc").glob("[0-9]*")
        if is_snakemake_for(int(entry.name), argument)
    ]
    guards = [guard(pid) for pid in stale]
    for watch in guards:
        release(watch, ended=False)
    for watch in guards:
        watch.wait()
    return stale


def run(
    study: Study, names: list[str], profile: Path, show: Callable[[Tally], None], bundle: int = 1
) -> Tally:
    """Build every evaluation's responses under one Snakemake (``profile``), showing the tally
    as simulations finish; stop it when the first simulations of this run all failed (the
    tally is then the one that decided it: Snakemake removes what its killed jobs were
    writing). An interrupt (Ctrl-C) ends the Snakemake and is raised again. Through a cluster,
    each job runs ``bundle`` simulations (with their extraction: group ``run``) one after
    another on one core (Snakemake's ``--group-components``), its time limit their sum. The
    Snakemake of an earlier run still going is ended first (:func:`end_earlier_runs`), and
    this one has a :func:`guard` that ends it when this process ends, however."""
    targets = [str(path) for name in names for path in response_paths(study, name)]
    targets += [str(study.files.evaluation(name).archived) for name in names]
    bundling = []
    if bundle > 1 and not runs_locally(profile):
        # "=": one value each (--group-components takes several, and would take the targets);
        # one core per job: Snakemake would otherwise ask for one per simulation in it, which
        # the SLURM executor runs one after another, and then it adds up their run times
        bundling = [f"--group-components=run={bundle}", "--cores=1"]
    command = snakemake_command(
        study.files.study, "--keep-going", *bundling, *targets, profile=profile
    )
    before = tally(study, names)
    with open(study.files.campaign_log, "a") as log:
        for pid in end_earlier_runs(study):
            print(
                f"demcal: ended the Snakemake of an earlier run still going (pid {pid})", file=log
            )
        log.flush()
        process = subprocess.Popen(
            command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
        )
    watch = guard(process.pid)
    try:
        while process.poll() is None:
            time.sleep(POLL_S)
            state = tally(study, names)
            show(state)
            if state.hopeless(before):
                state.stopped = True
                return state
    finally:  # the Snakemake has ended, or the guard ends it (stopped, interrupted, an error)
        release(watch, ended=process.poll() is not None)
        process.wait()
        watch.wait()
    state = tally(study, names)
    show(state)
    return state
