"""``reuse: archive``: the archive's simulations a new calibration may start from.

A simulation is compatible with a study when it ran the same scene on the same simulator
(``Study.simulator``: engine, its version and settings, the files a command reads, the scene's
script) with the same resolved settings and time-step fraction, its fixed parameters and
variable settings are the study's, and its free ones lie inside the study's bounds
(:meth:`Archive.compatible` does the first part, on :meth:`Study.archive_view`). A command
engine must name its version (``engine.version``) to reuse anything. The compatible
simulations of every scene are grouped by their free values into points; a point is usable
when every targeted response has at least one final value there, and a partial point (some
of them, at the fine level of the study's own material) teaches the models of those
responses only. Replicates and repeated runs of one point (a confirmation) pool into one
point. A study whose search spends a cheaper level
(``optimizer.fidelity``) also takes the simulations compatible with that level: the coarse
runs of the same material (docs/fidelity.md). With ``reuse: neighbours`` it takes as well the
runs of neighbouring materials, compatible in everything but the values of fixed parameters:
each point names the values in which its material differs, and the response models take
them as inputs (:mod:`demcal.optimizer.surrogates.material`, docs/archive.md).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable

from demcal.archive.simulation import ArchivedSimulation, digest
from demcal.archive.store import Archive
from demcal.errors import ConfigError
from demcal.results.archive_url import shown
from demcal.results.records import FINE, ReusedRecord
from demcal.study.model import Study


def compatible_simulations(
    study: Study,
    archive: Archive,
    from_study: Callable[[str], bool] = lambda name: True,
    fidelity: str = FINE,
    neighbours: bool = False,
) -> list[ArchivedSimulation]:
    """The archive's ok simulations of the study's scenes that the study could have run, each
    once: two studies that differ only in name or targets run the same points with the same
    seeds, and the archive keeps both records (its key names the study); one scene's run with
    one seed at one point is one simulation, not two replicates. ``from_study`` picks the
    studies whose simulations count (the metamodels hold a validation campaign out);
    ``fidelity``: the study's level whose settings, time step and simulator they must share.
    With ``neighbours``, those of neighbouring materials instead: every fixed parameter may
    differ, and at least one does (:func:`material_of`)."""
    problem = study.engine.reuse_problem()
    if problem is not None:
        raise ConfigError(problem)
    names = [p.name for p in study.free]
    level = study.level(fidelity)
    found, seen = [], set()
    for scene in study.scenes:
        settings, fixed, inputs = study.archive_view(scene, fidelity)
        material = sorted(study.fixed) if neighbours else []
        for record in archive.compatible(
            scene=scene,
            engine=level.engine.name,
            settings=settings,
            fixed=fixed,
            inputs=[*inputs, *material],
            simulator=digest(study.simulator(scene, fidelity)),
        ):
            inside = all(p.lower <= record.parameters[p.name].value <= p.upper for p in study.free)
            run = (record.scene, record.seed, tuple(record.values([*names, *material])))
            counts = inside and from_study(record.study)
            counts = counts and bool(material_of(study, record)) == neighbours
            if counts and record.timestep_fraction == level.timestep_fraction and run not in seen:
                seen.add(run)
                found.append(record)
    return found


def material_of(study: Study, record: ArchivedSimulation) -> dict[str, float]:
    """The archived simulation's values of the study's fixed parameters where they differ from
    the study's (empty for a run of the study's own material)."""
    return {
        name: record.parameters[name].value
        for name, value in study.fixed.items()
        if name in record.parameters and record.parameters[name].value != value
    }


def reused_points(
    study: Study, archive: Archive, fidelity: str = FINE, neighbours: bool = False
) -> ReusedRecord:
    """The usable points of the study's compatible simulations at level ``fidelity``, in
    archive order (each point of a cheaper level names it; with ``neighbours``, those of
    neighbouring materials, each naming its values of the fixed parameters that differ); a
    damaged simulation is left out, or counts without its damaged values, as the archive
    reads it (:meth:`Archive.warn_damaged` names them). A fine point of the study's own
    material where only some of the targeted responses ran (the first test of a joint study,
    before the second was added) is ``partial``: data of those responses' models only."""
    names = [p.name for p in study.free]
    groups: dict[tuple[object, ...], list[ArchivedSimulation]] = defaultdict(list)
    for record in compatible_simulations(study, archive, fidelity=fidelity, neighbours=neighbours):
        other = tuple(sorted(material_of(study, record).items()))
        groups[(*record.values(names), *other)].append(record)
    archive.warn_damaged()
    points = []
    for records in groups.values():
        replicates = {
            t.key: [
                r.responses[t.response].value
                for r in records
                if r.scene == t.scene and t.response in r.responses and r.final.get(t.response)
            ]
            for t in study.targets
        }
        present = {key: values for key, values in replicates.items() if values}
        partial = len(present) < len(replicates)
        if not present or (partial and (fidelity != FINE or neighbours)):
            continue
        material = material_of(study, records[0])
        # one evaluation of a robust study ran several materials: each is its own point
        named = " ".join(f"({name} {value:g})" for name, value in material.items())
        points.append(
            {
                "source": "+".join(dict.fromkeys(f"{r.study}/{r.evaluation}" for r in records))
                + (f" {named}" if named else ""),
                "parameters": dict(zip(names, records[0].values(names))),
                "replicates": present,
                "simulations": [
                    {
                        "id": r.id,
                        "study": r.study,
                        "evaluation": r.evaluation,
                        "scene": r.scene,
                        "replicate": r.replicate,
                        "seed": r.seed,
                    }
                    for r in records
                ],
            }
            | ({"partial": True} if partial else {})
            | ({} if fidelity == FINE else {"fidelity": fidelity})
            | ({"material": material} if material else {})
        )
    return ReusedRecord(shown(archive.url), points)
