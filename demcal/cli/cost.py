"""What a command is about to simulate, and about how long that takes: said before the commands
that simulate for more than a few minutes (``convergence``, ``solutions --explore``,
``calibrate-metamodel --validate``; ``sample`` says it with its campaign's ``forecast``)."""

from __future__ import annotations

from collections.abc import Mapping

from demcal.domain.campaign import simulation_times
from demcal.reporting.terminal import duration
from demcal.study.model import Study


def per_scene(study: Study, points: int) -> dict[str, float]:
    """The simulations of ``points`` parameter sets, each a replicate set of every scene."""
    return {scene: float(points * study.replicates) for scene in study.scenes}


def cost_line(study: Study, runs: Mapping[str, float], count: int, at_once: int) -> str:
    """The line ``N simulations, W at a time: about T``: ``count`` of them, ``at_once`` at a
    time, at the median wall time of the archive's finished simulations of each scene on the
    study's engine; ``runs`` counts each scene's simulations in runs of that median (a finer
    time step counts for more). Until the archive holds one of a scene, the time is said to
    be unknown."""
    head = f"{count} simulation{'' if count == 1 else 's'}, {at_once} at a time"
    if study.archive is None:
        return f"{head}; how long they take is not known (the study keeps no archive)"
    times = simulation_times(study)
    unknown = [scene for scene in runs if scene not in times]
    if unknown:
        return (
            f"{head}; how long they take is not known yet (the archive holds no finished "
            f"{', '.join(unknown)} simulation on {study.engine.name})"
        )
    seconds = sum(times[scene][0] * weight for scene, weight in runs.items())
    measured = ", ".join(
        f"{scene} {duration(times[scene][0])} of {times[scene][1]}" for scene in runs
    )
    return (
        f"{head}: about {duration(seconds / at_once)} (median {study.engine.name} run in the "
        f"archive: {measured})"
    )
