"""Sampling campaigns (``demcal sample``): a space-filling design over a study's box, simulated
once, into the archive (Richter & Will 2021, secs. 2.3 and 3: a material domain simulated
once serves every later calibration of a material in it).

A campaign is a study folder whose evaluations are the points of one design
(``campaign.json``): ``e0000`` is its first point. Each point runs through the same
simulate -> extract jobs as a calibration, all of them under one Snakemake with the chosen
profile (SLURM included), and every simulation lands in the study's archive. Run the same
command again to resume it (finished simulations are not run again); give a larger ``--n``
to extend it: the design's next points follow (:func:`demcal.optimizer.designs.extend_design`),
so the whole stays space-filling.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from demcal.errors import ConfigError, SimulationFailed
from demcal.jobs.evaluation import response_paths
from demcal.optimizer.designs import (
    EXTENSIBLE,
    cover_measure,
    extend_design,
    minimum_pairwise_distance,
)
from demcal.optimizer.registry import DESIGNS
from demcal.results.layout import evaluation_id
from demcal.results.records import CampaignRecord, PointRecord, ResponsesRecord, Status
from demcal.study.model import Study
from demcal.workflow import snakemake_command

#: The designs a campaign may use (Richter & Will chose FSSF-f).
CAMPAIGN_DESIGNS = ("fssf_f", "sobol", "halton", "latin_hypercube")
#: A campaign whose first simulations all failed stops: something is wrong with every point.
FAIL_FAST = 5
#: Seconds between looks at the simulations that have finished.
POLL_S = 2.0


def unit_to_box(study: Study, unit: np.ndarray) -> list[dict[str, float]]:
    """Points of the unit box as free-parameter values inside the study's bounds."""
    lower = np.array([p.lower for p in study.free])
    upper = np.array([p.upper for p in study.free])
    values = lower + np.asarray(unit) * (upper - lower)
    return [{p.name: float(v) for p, v in zip(study.free, row)} for row in values]


def plan(study: Study, size: int, design: str) -> CampaignRecord:
    """The campaign of ``size`` points: the one on disk, extended if ``size`` is larger, or a
    new design. A ConfigError says why a campaign cannot become what was asked."""
    if design not in CAMPAIGN_DESIGNS:
        raise ConfigError(f"--design {design}: use one of {', '.join(CAMPAIGN_DESIGNS)}")
    if size < 2:
        raise ConfigError(f"--n {size}: give at least 2 points")
    dimension, existing = len(study.free), CampaignRecord.read_if_any(study.files.campaign)
    if existing is None:
        rng = np.random.default_rng(study.seed)
        if design in EXTENSIBLE:
            unit = extend_design(design, np.empty((0, dimension)), size, dimension, rng)
        else:
            unit = DESIGNS[design].load()(size, dimension, rng)
        return CampaignRecord(design, study.seed, np.asarray(unit).tolist())
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
            f"--n {size}: a {design} design of {len(taken)} points cannot be extended and stay "
            f"space-filling; start another study with --design fssf_f, sobol or halton"
        )
    more = extend_design(design, taken, size, dimension, np.random.default_rng(existing.seed))
    return CampaignRecord(design, existing.seed, np.vstack([taken, more]).tolist())


def write_points(study: Study, campaign: CampaignRecord) -> list[str]:
    """params.json of every point not written yet; returns every evaluation's name."""
    names = []
    for index, point in enumerate(unit_to_box(study, np.asarray(campaign.unit_points))):
        name = evaluation_id(index)
        params = study.files.evaluation(name).params
        if not params.exists():
            PointRecord(point, proposed_by=f"campaign ({campaign.design})").write(params)
        names.append(name)
    campaign.write(study.files.campaign)
    return names


@dataclass
class Tally:
    """How a campaign's simulations stand: finished ones by status, the commonest reason."""

    total: int
    statuses: Counter
    reasons: Counter

    @property
    def finished(self) -> int:
        return sum(self.statuses.values())

    def hopeless(self) -> bool:
        """True when the first FAIL_FAST simulations that finished all failed."""
        return self.finished >= FAIL_FAST and self.statuses[Status.OK] == 0

    def line(self) -> str:
        counts = ", ".join(f"{n} {s}" for s, n in sorted(self.statuses.items()))
        return f"{self.finished} of {self.total} simulations finished ({counts or 'none yet'})"


def tally(study: Study, names: list[str]) -> Tally:
    """The finished simulations of the evaluations ``names`` (their responses.json)."""
    paths = [path for name in names for path in response_paths(study, name)]
    statuses: Counter = Counter()
    reasons: Counter = Counter()
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


def run(
    study: Study,
    names: list[str],
    profile: Path,
    cores: int | None,
    show: Callable[[Tally], None],
) -> Tally:
    """Build every evaluation's responses under one Snakemake (``profile``), showing the tally
    as simulations finish; stop it when the first simulations all failed (the tally is then
    the one that decided it: Snakemake removes what its killed jobs were writing)."""
    targets = [str(path) for name in names for path in response_paths(study, name)]
    command = snakemake_command(
        study.files.study, "--keep-going", *targets, profile=profile, cores=cores
    )
    with open(study.files.campaign_log, "a") as log:
        process = subprocess.Popen(
            command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
        )
    try:
        while process.poll() is None:
            time.sleep(POLL_S)
            state = tally(study, names)
            show(state)
            if state.hopeless():
                os.killpg(process.pid, signal.SIGTERM)
                process.wait()
                return state
    except KeyboardInterrupt:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait()
        raise
    state = tally(study, names)
    show(state)
    return state
