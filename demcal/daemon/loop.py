"""The calibration loop: owns the optimizer, keeps up to P evaluations in flight.

Asynchronous master-worker loop after Samuelsson (2023), Algorithm 5: keep up
to P evaluations in flight, tell the optimizer each result as it arrives,
watch running simulations' partial outputs and stop hopeless ones (section
2.6), stop on the optimizer's stopping rules.

Crash safety: everything needed to resume is on disk, written before it is
acted on. For a new point the order is ask -> write ``params.json`` -> save
the optimizer state -> launch (``launch.json`` holds the child's pid). A
daemon killed at any moment and started again reloads the optimizer state;
the optimizer is deterministic, so a point asked but not yet saved is asked
again with the same id and values; pending evaluations are re-attached
(child still alive), read back (objective written) or launched again. A
completed evaluation is never redone.

An evaluation is taken (told to the optimizer) as soon as all its
responses.json are written, while its child may still wait for its executor
to see the jobs end (SLURM). Its files are still written by the child's jobs
only, objective.json and the archive rows by the objective and archive jobs:
the daemon waits for the child to end, and launches it again, to run just
those jobs, if it ended (was killed) before them.
"""

from __future__ import annotations

import dataclasses
import logging
import shutil
import time
from collections.abc import Callable

from demcal.daemon.control import saved_optimizer
from demcal.daemon.launcher import Child, Launcher, Running, SnakemakeLauncher, alive
from demcal.daemon.progress import Progress, answer_text
from demcal.daemon.tables import write_best, write_evaluations_csv
from demcal.daemon.termination import (
    EarlyTerminationWatch,
    forget_reports,
    partial_responses,
)
from demcal.errors import DemcalError, SimulationFailed
from demcal.jobs.steps import (
    objective_record,
    rescore,
    response_paths,
    reused_objectives,
    reused_origins,
)
from demcal.optimizer import Optimizer, Proposal
from demcal.optimizer.best import lowest_run
from demcal.optimizer.evaluation import ReusedPoint
from demcal.results.layout import CALIBRATION_FILE, SIMULATION_FILE, evaluation_id, proposal_id
from demcal.results.records import (
    FINE,
    FinishedRecord,
    LaunchRecord,
    ObjectiveRecord,
    PointRecord,
    SimulationRecord,
    Status,
)
from demcal.results.storage import atomic_write_text, log_tail, read_json, write_json
from demcal.study.model import NEIGHBOURS, RESUMABLE_OPTIMIZER_SETTINGS, Study

log = logging.getLogger("demcal.daemon")


class Calibration:
    """One study's calibration on disk under ``results/<study>/``.

    ``study`` is the frozen study (``demcal.study.model.freeze``): its
    ``study.json`` is what the children read.
    """

    def __init__(
        self,
        study: Study,
        launcher: Launcher | None,
        workers: int,
        watch_pid: int | None = None,
    ):
        self.study, self.workers = study, workers
        self.files = study.files
        #: runs the evaluations (None: a child Snakemake each, with the local profile)
        self.launcher = launcher or SnakemakeLauncher(self.files.study)
        self.retries = int(study.calibration["retries"])
        self.poll_seconds = float(study.calibration["poll_seconds"])
        #: the Snakemake that started this daemon: when it dies, the daemon ends too
        self.watch_pid = watch_pid
        self.children: dict[str, Running] = {}
        #: evaluations taken from their responses.json whose child Snakemake has not ended
        #: yet: the child and the outcome the optimizer was told
        self.ending: dict[str, tuple[Running, ObjectiveRecord]] = {}
        #: taken evaluations whose child this daemon launched again to run their last jobs
        self.relaunched: set[str] = set()
        self.names = [p.name for p in study.free]
        self.optimizer = self._load_or_create_optimizer()
        self.started_at = self._load_start_time()
        self.stop_requested: set[str] = set()
        #: per response, whether the cheaper level pays, as last logged (`say_verdicts`)
        self.verdicts_said: dict[str, bool] = {}
        self.watch = EarlyTerminationWatch(
            study, self.optimizer, self.started_at, self.stop_requested
        )
        self.rescore()

    # -- state ------------------------------------------------------------------
    def _load_or_create_optimizer(self) -> Optimizer:
        """The saved optimizer (with the study's current budget and stopping
        rules), or a new one."""
        if self.files.optimizer.exists():
            optimizer = saved_optimizer(self.study)
            optimizer.settings = dataclasses.replace(
                optimizer.settings,
                **{
                    name: getattr(self.study.optimizer, name)
                    for name in RESUMABLE_OPTIMIZER_SETTINGS
                },
            )
            return optimizer
        return Optimizer(
            [p.lower for p in self.study.free],
            [p.upper for p in self.study.free],
            self.study.optimizer,
            seed=self.study.seed,
            workers=self.workers,
            objective=self.study.response_objective,
            reused=self._reused_points(),
        )

    def _reused_points(self) -> list[ReusedPoint]:
        """With ``reuse: archive``: the archive's points compatible with the study (and with
        ``reuse: neighbours`` those of neighbouring materials), written to reused.json and
        scored by the study's objective, for a calibration that starts; [] when reuse is
        off."""
        if self.study.reuse is None:
            return []
        from demcal.archive.reuse import reused_points
        from demcal.archive.store import Archive

        assert self.study.archive is not None, "the study's config requires an archive to reuse"
        level = self.study.optimizer.fidelity
        with Archive(self.study.archive) as archive:
            reused = reused_points(self.study, archive)
            if level is not None:  # and the coarse runs of the same material
                reused.points.extend(reused_points(self.study, archive, level).points)
            if self.study.reuse == NEIGHBOURS:
                reused.points.extend(reused_points(self.study, archive, neighbours=True).points)
            reused.write(self.files.reused)
        origins = reused_origins(self.study)
        points = [
            ReusedPoint(
                [record.parameters[name] for name in self.names],
                record.replicates,
                record.objective,
                self._replicate_values(record),
                record.evaluation,
                origins[record.evaluation].fidelity,
                {
                    name: value - self.study.fixed[name]
                    for name, value in origins[record.evaluation].material.items()
                },
            )
            for record in reused_objectives(self.study)
            if (record.ok and record.objective is not None) or record.status == Status.TERMINATED
        ]
        cheap = sum(point.fidelity != FINE for point in points)
        partial = sum(point.value is None for point in points)
        near = sorted({name for point in points for name in point.material})
        log.info(
            "reused %d points of the archive as data (reused.json)%s%s%s",
            len(points),
            f", {cheap} of them at {level}" if cheap else "",
            f", {partial} of them with only some of the tests (data of their models)"
            if partial
            else "",
            f", {sum(bool(p.material) for p in points)} of neighbouring materials "
            f"(other {', '.join(near)})"
            if near
            else "",
        )
        return points

    def _load_start_time(self) -> float:
        """Start of the calibration (calibration.json), written on the first run."""
        if self.files.calibration.exists():
            return float(read_json(self.files.calibration, CALIBRATION_FILE)["started_at"])
        now = time.time()
        write_json(self.files.calibration, {"started_at": now, "study": self.study.name})
        return now

    def rescore(self) -> None:
        """Re-score the evaluations scored against other targets, weights, spreads or form.

        After corrected targets (``demcal.study.model.freeze`` allows them): each
        such evaluation gets a ``rescored.json`` computed from the replicates'
        responses its objective job kept (no simulation runs), and the
        optimizer's value is replaced; a reused point is scored anew from reused.json.
        """
        version = self.study.objective.version
        outcomes: dict[int, tuple[str, float | None, list[float] | None]] = {}
        reused = {r.evaluation: r for r in reused_objectives(self.study)}
        for record in self.optimizer.records:
            if record.status == Status.PENDING:
                continue
            if record.reused_from is not None:  # scored from reused.json, with no files here
                now = reused[record.reused_from]
                if (now.status, now.objective) != (record.status, record.value):
                    outcomes[record.id] = (now.status, now.objective, self._replicate_values(now))
                continue
            evaluation = evaluation_id(record.id)
            files = self.files.evaluation(evaluation)
            if not files.objective.exists():  # taken from its responses, not written yet
                taken = self.taken_early(evaluation)
                if taken is not None and (taken.status, taken.objective) != (
                    record.status,
                    record.value,
                ):
                    outcomes[record.id] = (
                        taken.status,
                        taken.objective,
                        self._replicate_values(taken),
                    )
                continue
            try:
                job = ObjectiveRecord.read(files.objective)
                latest = ObjectiveRecord.read_latest(files, job)
            except SimulationFailed:
                continue
            if not job.ok or latest.scored_with == version:
                continue  # never scored (a failed simulation), or scored as now
            result = rescore(self.study, files, job)
            outcomes[record.id] = (
                result.status,
                result.objective,
                self._replicate_values(result),
            )
        if outcomes:
            self.optimizer.rescore(outcomes)
            self.save_state()
            log.info(
                "re-scored %d evaluations from their stored responses (targets changed, "
                "or scored before the records' format 1)",
                len(outcomes),
            )

    def save_state(self) -> None:
        atomic_write_text(self.files.optimizer, self.optimizer.to_json())

    def elapsed(self) -> float:
        return time.time() - self.started_at

    # -- launching ---------------------------------------------------------------
    def launch(self, evaluation: str) -> None:
        """Hand an evaluation to the launcher."""
        running = self.launcher.launch(self.files.evaluation(evaluation))
        self.children[evaluation] = running
        log.info("launched %s%s", evaluation, f" (pid {running.pid})" if running.pid > 0 else "")

    def propose(self) -> None:
        """Fill free worker slots with new points from the optimizer."""
        while len(self.children) < self.workers:
            proposals = self.optimizer.ask(1)
            if not proposals:
                return
            proposal = proposals[0]
            self.write_point(proposal)
            self.save_state()
            self.launch(evaluation_id(proposal.id))

    def write_point(self, proposal: Proposal) -> None:
        """The proposal's params.json; a confirmation run names the point it repeats; an
        evaluation early termination may stop is staged in a staged study."""
        of = None
        if proposal.confirms is not None:  # a reused point is named by its source
            confirmed = next(r for r in self.optimizer.records if r.id == proposal.confirms)
            of = confirmed.reused_from or evaluation_id(confirmed.id)
        PointRecord(
            dict(zip(self.names, proposal.x)),
            in_initial_design=proposal.in_initial_design,
            proposed_by=None if of is None else f"confirmation of {of}",
            staged=self.study.staging is not None and self.optimizer.can_stop_early(proposal.id),
            fidelity=None if proposal.fidelity == FINE else proposal.fidelity,
        ).write(self.files.evaluation(evaluation_id(proposal.id)).params)

    def confirm_best(self, reason: str) -> bool:
        """Launch the re-simulations of the best point (``confirm_replicates``) once the
        calibration has stopped, unless it was stopped on request; True if any were launched."""
        if reason.startswith("stopped on request"):
            return False
        proposals = self.optimizer.confirm()
        if not proposals:
            return False
        for proposal in proposals:
            self.write_point(proposal)
        self.save_state()
        log.info("confirming the best point with %d more simulations", len(proposals))
        for proposal in proposals:
            self.launch(evaluation_id(proposal.id))
        return True

    # -- resuming ----------------------------------------------------------------
    def resume(self) -> None:
        """Re-attach, read back or relaunch the evaluations pending in the saved state."""
        for pid in self.optimizer.pending():
            evaluation = evaluation_id(pid)
            files = self.files.evaluation(evaluation)
            if not files.params.exists():
                raise DemcalError(
                    f"{files.params} is missing for a pending evaluation; "
                    f"the results directory was changed by hand"
                )
            running = self.launcher.reattach(files)
            if running is not None:
                self.children[evaluation] = running
                log.info("re-attached %s (pid %d)", evaluation, running.pid)
                continue
            if files.objective.exists() or self.taken_early(evaluation) is not None:
                self.children[evaluation] = Child(evaluation, -1, None, time.time())
                continue  # finished while no daemon ran: collected in the next poll
            self.launch(evaluation)
        for record in self.optimizer.records:
            if record.status != Status.PENDING and record.reused_from is None:
                self._finish_writing(evaluation_id(record.id))

    def _finish_writing(self, evaluation: str) -> None:
        """An evaluation taken from its responses before a daemon ended: its child Snakemake,
        re-attached when still alive, else launched again, writes its objective.json."""
        files = self.files.evaluation(evaluation)
        if files.objective.exists():
            return
        record = self.taken_early(evaluation)
        if record is None:
            return
        running = self.launcher.reattach(files)
        if running is None:
            self.run_last_jobs(evaluation, record)
        else:
            self.ending[evaluation] = (running, record)

    # -- collecting ----------------------------------------------------------------
    def collect(self) -> None:
        """Tell the optimizer about every finished evaluation, as soon as all its responses
        are written (:meth:`taken_early`) or else when its child has ended; retry failures up
        to the cap."""
        for evaluation, child in list(self.children.items()):
            if child.finished():
                record = self._objective_written(evaluation, child)
            elif (early := self.taken_early(evaluation)) is not None:
                record = early
                self.ending[evaluation] = (child, early)
            else:
                continue
            del self.children[evaluation]
            self.watch.forget(evaluation)
            self.finish(evaluation, record)
        self.collect_ending()

    def collect_ending(self) -> None:
        """Forget the children of taken evaluations that have ended; one that ended before its
        objective and archive jobs wrote their files (killed) is launched again to run them.

        Through SLURM a child learns that its jobs have ended only at the
        executor's next status check, up to 3 minutes away; it is left to end
        on its own, as its jobs write the evaluation's last files.
        """
        ended = False
        for evaluation, (child, taken) in list(self.ending.items()):
            if not child.finished():
                continue
            del self.ending[evaluation]
            ended = True
            if not self.jobs_done(evaluation):
                self.run_last_jobs(evaluation, taken)
        if ended:
            self.write_tables()

    def jobs_done(self, evaluation: str) -> bool:
        """Whether an evaluation's last jobs have run: its objective.json and archive mark."""
        files = self.files.evaluation(evaluation)
        return files.objective.exists() and files.archived.exists()

    def run_last_jobs(self, evaluation: str, taken: ObjectiveRecord) -> None:
        """Launch the child of a taken evaluation again, once per daemon, to run what its last
        one did not (objective, archive); its simulations are done and are not redone. A child
        launched again that ends without them too ends the daemon, the calibration unfinished."""
        files = self.files.evaluation(evaluation)
        if evaluation in self.relaunched:
            missing = [
                what
                for path, what in (
                    (files.objective, files.objective.name),
                    (files.archived, "archive"),
                )
                if not path.exists()
            ]
            raise DemcalError(
                f"the child Snakemake of {evaluation} ended twice without writing its "
                f"{' and '.join(missing)} (see {files.snakemake_log}); the same command "
                "resumes the calibration"
            )
        self.relaunched.add(evaluation)
        first = LaunchRecord.read_if_any(files.launch)
        child = self.launcher.launch(files)
        if first is not None:  # the evaluation started with its first child (evaluations.csv)
            LaunchRecord(child.pid, first.started_at).write(files.launch)
        self.ending[evaluation] = (child, taken)
        log.info("%s: child launched again to write objective.json and the archive", evaluation)

    def _objective_written(self, evaluation: str, child: Running) -> ObjectiveRecord:
        """The outcome of an evaluation whose child has ended: its objective.json; else, when
        every response is there (a child ended before its last jobs, launched again to run
        them: :meth:`run_last_jobs`), the outcome taken from them; else a failure that says
        why there is none."""
        files = self.files.evaluation(evaluation)
        if not self.jobs_done(evaluation) and (taken := self.taken_early(evaluation)) is not None:
            self.run_last_jobs(evaluation, taken)
            return taken
        try:
            return ObjectiveRecord.read(files.objective)
        except SimulationFailed as exc:
            tail = log_tail(files.snakemake_log, lines=3)
            return ObjectiveRecord(
                evaluation,
                Status.FAILED,
                f"workflow ended with code {child.returncode()} and no objective ({exc}): {tail}",
            )

    def taken_early(self, evaluation: str) -> ObjectiveRecord | None:
        """The outcome of an evaluation once every replicate's responses.json is written, the
        same record its objective job will write; None before, and for a failure (that waits
        for the child: its log says why, and a retry needs it gone).

        Through SLURM, a child Snakemake learns that a job has ended only at the
        executor's next status check, which comes up to 3 minutes apart; the
        simulation and its extraction are one SLURM job (group ``run``), so
        the responses are there as soon as the simulation ends.
        """
        paths = response_paths(self.study, evaluation)
        if not all(path.exists() for path in paths):
            return None
        try:
            attempt = PointRecord.read(self.files.evaluation(evaluation).params).attempt
            if any(  # a job of an earlier attempt, still running, wrote into the new folders
                SimulationRecord.read(path.with_name(SIMULATION_FILE)).attempt
                not in (attempt, None)
                for path in paths
            ):
                return None
            record = objective_record(self.study, evaluation, paths)
        except Exception as exc:  # noqa: BLE001  (the objective job will record what is wrong)
            log.debug("%s: not taken from its responses (%s: %s)", evaluation, type(exc), exc)
            return None
        return record if record.status in (Status.OK, Status.TERMINATED) else None

    def finish(self, evaluation: str, record: ObjectiveRecord) -> None:
        point = PointRecord.read(self.files.evaluation(evaluation).params)
        status = record.status
        # after `demcal stop` nothing is launched any more, retries included
        if (
            status == Status.FAILED
            and point.attempt < self.retries
            and not self.files.stop_calibration.exists()
        ):
            self.retry(evaluation, point, record.reason)
            return
        pid = proposal_id(evaluation)
        if status == Status.OK:
            self.optimizer.tell(
                pid,
                value=record.objective,
                replicates=self._replicate_values(record),
                responses=record.replicates,
                cpu_s=record.cost.get("cpu_s"),
            )
            self.say_verdicts()
        elif status == Status.TERMINATED:  # what it did learn enters the response models
            self.optimizer.tell(
                pid,
                status=Status.TERMINATED,
                partial=partial_responses(
                    self.files.evaluation(evaluation),
                    list(self.study.scenes),
                    self.study.replicates,
                ),
            )
        else:
            self.optimizer.tell(pid, status=Status.FAILED)
        self.save_state()
        self.stop_requested.discard(evaluation)
        log.info(
            "%s: %s %s",
            evaluation,
            status,
            record.objective if status == Status.OK else record.reason,
        )
        self.write_tables()

    def say_verdicts(self) -> None:
        """Log each response for which the cheaper level's verdict (does it pay?) is new or has
        changed: where it does not pay, the response is modelled from fine runs alone."""
        level = self.optimizer.settings.fidelity
        if level is None:
            return
        for key, verdict in self.optimizer.level_verdicts().items():
            if self.verdicts_said.get(key) == verdict.pays:
                continue
            self.verdicts_said[key] = verdict.pays
            log.info(
                "level %s %s for %s (correlation %.2f with the fine runs at %d points, cost "
                "ratio %.2f)%s",
                level,
                "pays" if verdict.pays else "does not pay",
                key,
                verdict.correlation,
                verdict.points,
                verdict.cost_ratio,
                "" if verdict.pays else ": modelled from fine runs alone",
            )

    def _replicate_values(self, record: ObjectiveRecord) -> list[float] | None:
        """Eq. 3.3 per replicate of an evaluation, for the optimizer's noise estimate: the
        study's objective with the time-step cost its objective job recorded."""
        if not record.ok:
            return None
        return (
            self.study.objective.per_replicate(record.replicates, record.timestep_cost or 0.0)
            or None
        )

    def retry(self, evaluation: str, point: PointRecord, reason: str) -> None:
        """Run a failed evaluation again with new seeds (attempt + 1)."""
        files = self.files.evaluation(evaluation)
        for scene in self.study.scenes:
            shutil.rmtree(files.scene_dir(scene), ignore_errors=True)
        forget_reports()
        for stale in (files.objective, files.rescored, files.stop, files.archived):
            stale.unlink(missing_ok=True)
        self.stop_requested.discard(evaluation)
        point = point.retried(reason)
        point.write(files.params)
        log.info("%s failed (%s); retry %d of %d", evaluation, reason, point.attempt, self.retries)
        self.launch(evaluation)

    # -- outputs ---------------------------------------------------------------------
    def write_tables(self, stop_reason: str | None = None) -> None:
        write_evaluations_csv(self.study)
        best = self.optimizer.best()
        if best is not None:
            taken = self.ending.get(evaluation_id(best.id))
            write_best(
                self.study,
                best,
                self.optimizer.confirmation(),
                stop_reason,
                self.reuse_counts(),
                taken=None if taken is None else taken[1],
                lowest=lowest_run(self.optimizer.records),
            )

    def reuse_counts(self) -> dict[str, int] | None:
        """With ``reuse: archive``: the evaluations simulated by this study (``new``, told)
        and the points taken from the archive (``reused``; with ``reuse: neighbours`` also
        those of neighbouring materials, ``neighbours``); None when reuse is off."""
        if self.study.reuse is None:
            return None
        return {
            "new": self.optimizer.completed_evaluations(),
            "reused": self.optimizer.reused_points,
        } | (
            {"neighbours": len(self.optimizer.neighbour_records)}
            if self.study.reuse == NEIGHBOURS
            else {}
        )

    def progress(self) -> Progress:
        counts = self.optimizer.status_counts()
        failed, stopped = counts.get(Status.FAILED, 0), counts.get(Status.TERMINATED, 0)
        optimizer = self.optimizer
        searched = sum(not (r.maps_solutions or r.reused_from) for r in optimizer.records)
        budget = (
            searched if optimizer.search_ended else optimizer.settings.max_evaluations
        ) + optimizer.mapping_budget
        best_text = answer_text(self.optimizer.best(), optimizer.records, self.names)
        elapsed = self.elapsed()
        finished = self.optimizer.completed_evaluations()
        s = self.optimizer.settings
        # "to budget" only when the budget is the stop to expect: no other rule
        # may end the run first
        budget_rules = not (
            s.max_seconds or s.target_objective is not None or s.no_improvement_evaluations
        )
        to_budget = (
            (budget - finished) * elapsed / finished
            if budget_rules and 0 < finished < budget
            else None
        )
        return Progress(
            self.study.name,
            finished,
            budget,
            failed,
            stopped,
            len(self.children),
            best_text,
            elapsed,
            to_budget,
            cheaper_text(optimizer),
        )

    # -- the loop ------------------------------------------------------------------
    def run(self, show_progress: Callable[[Progress], None] = lambda p: print(p.line())) -> str:
        """Calibrate until a stopping rule holds and nothing is running; return the reason.

        Only a loop that ends so writes ``finished.json``; a daemon that dies
        or is orphaned leaves the calibration unfinished, to be resumed.
        """
        self.files.stop_calibration.unlink(missing_ok=True)  # a new run overrides an old stop
        self.files.finished.unlink(missing_ok=True)  # running again: not finished any more
        self.resume()
        reason = None
        while True:
            self.check_parent()
            self.collect()
            self.watch.check(self.children)
            if self.files.stop_calibration.exists():
                reason = reason or "stopped on request (demcal stop)"
            reason = reason or self.optimizer.stop_reason(self.elapsed())
            if reason is None:
                self.propose()
                if not self.children:  # e.g. the strategy has converged and says so
                    reason = (
                        self.optimizer.stop_reason(self.elapsed()) or "no more points to evaluate"
                    )
            if reason is not None and not self.children and not self.confirm_best(reason):
                break
            show_progress(self.progress())
            time.sleep(self.poll_seconds)
        self.wait_for_ending()
        self.write_tables(reason)
        show_progress(self.progress())
        counts = self.reuse_counts()
        FinishedRecord(
            reason,
            time.time(),
            self.optimizer.status_counts(),
            None if counts is None else counts["reused"],
            None if counts is None else counts.get("neighbours"),
        ).write(self.files.finished)
        log.info("calibration finished: %s", reason)
        return reason

    def wait_for_ending(self) -> None:
        """Wait until the children of taken evaluations have ended (:meth:`collect_ending`),
        so that the calibration ends with every record on disk."""
        while self.ending:
            self.check_parent()
            self.collect()
            if self.ending:
                time.sleep(self.poll_seconds)

    def check_parent(self) -> None:
        """End the daemon when the Snakemake that started it is gone (killed, lost terminal).

        Running evaluations are left alone: each is a child Snakemake in its
        own session, re-attached or read back by the next daemon.
        """
        if self.watch_pid is not None and not alive(self.watch_pid):
            log.info(
                "the Snakemake that started this daemon (pid %d) is gone; ending", self.watch_pid
            )
            raise DemcalError(
                f"the Snakemake that started this daemon (pid {self.watch_pid}) has ended, so "
                f"the daemon ends too; {len(self.children)} running evaluations go on and are "
                f"collected when the same command runs again"
            )


def cheaper_text(optimizer: Optimizer) -> str:
    """The evaluations done at the cheaper level and for how many responses it pays, as
    "+9 coarse, pays for 1 of 2 responses" ("" without a level)."""
    level = optimizer.settings.fidelity
    if level is None:
        return ""
    done = sum(r.status != Status.PENDING and not r.reused_from for r in optimizer.cheap_records)
    verdicts = optimizer.level_verdicts()
    paying = sum(v.pays for v in verdicts.values())
    judged = f", pays for {paying} of {len(verdicts)} responses" if verdicts else ""
    return f"+{done} {level}{judged}"
