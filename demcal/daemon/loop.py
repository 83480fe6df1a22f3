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

An evaluation is taken as soon as all its responses.json are written, while
its child may still wait for its executor to see the jobs end (SLURM); the
child then writes objective.json, or, if it has not ended within
``ENDING_GRACE_S`` or ended without doing so, is ended and the daemon writes
the same record.
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
    append_estimates,
    early_termination_decisions,
    forget_reports,
    latest_estimates,
    partial_responses,
    share_done,
)
from demcal.errors import DemcalError, SimulationFailed
from demcal.jobs.evaluation import (
    archive,
    ask_to_stop,
    objective_record,
    rescore,
    response_paths,
    reused_objectives,
)
from demcal.optimizer import Optimizer, Proposal, RunProgress, estimate_heading
from demcal.optimizer.best import lowest_run
from demcal.optimizer.evaluation import ReusedPoint
from demcal.results.layout import EvaluationFiles, evaluation_id, proposal_id
from demcal.results.records import (
    FinishedRecord,
    ObjectiveRecord,
    PointRecord,
    SimulationRecord,
    Status,
)
from demcal.results.storage import atomic_write_text, log_tail, read_json, write_json
from demcal.study.model import RESUMABLE_OPTIMIZER_SETTINGS, Study

log = logging.getLogger("demcal.daemon")

#: Seconds a child Snakemake gets to end on its own once its evaluation has been taken, before
#: the daemon ends it: its SLURM jobs wrote their last file, and end within a second or two.
ENDING_GRACE_S = 10.0


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
        #: yet: the child, the outcome the optimizer was told and when (Unix s)
        self.ending: dict[str, tuple[Running, ObjectiveRecord, float]] = {}
        self.names = [p.name for p in study.free]
        self.optimizer = self._load_or_create_optimizer()
        self.started_at = self._load_start_time()
        self.stop_requested: set[str] = set()
        #: (estimate, limit) last written to early_termination.csv, per evaluation
        self.recorded_estimates: dict[str, tuple] = {}
        #: (share done, estimate, estimates reporting) of each running evaluation as it changed
        self.estimate_history: dict[str, list[tuple[float, float, int]]] = {}
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
        """With ``reuse: archive``: the archive's points compatible with the study, written to
        reused.json and scored by the study's objective, for a calibration that starts; []
        when reuse is off."""
        if self.study.reuse is None:
            return []
        from demcal.archive.reuse import reused_points
        from demcal.archive.store import Archive

        assert self.study.archive is not None, "the study's config requires an archive to reuse"
        with Archive(self.study.archive) as archive:
            reused_points(self.study, archive).write(self.files.reused)
        points = [
            ReusedPoint(
                [record.parameters[name] for name in self.names],
                record.replicates,
                record.objective,
                self._replicate_values(record),
                record.evaluation,
            )
            for record in reused_objectives(self.study)
            if record.ok and record.objective is not None
        ]
        log.info("reused %d points of the archive as data (reused.json)", len(points))
        return points

    def _load_start_time(self) -> float:
        """Start of the calibration (calibration.json), written on the first run."""
        if self.files.calibration.exists():
            return float(read_json(self.files.calibration, "calibration.json")["started_at"])
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
        when still alive, writes its objective.json; else the daemon does."""
        files = self.files.evaluation(evaluation)
        if files.objective.exists():
            return
        record = self.taken_early(evaluation)
        if record is None:
            return
        running = self.launcher.reattach(files)
        if running is None:
            self._write_what_the_child_did_not(evaluation, record)
        else:
            self.ending[evaluation] = (running, record, time.time())

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
                self.ending[evaluation] = (child, early, time.time())
            else:
                continue
            del self.children[evaluation]
            self.estimate_history.pop(evaluation, None)
            self.finish(evaluation, record)
        self.end_taken()

    def end_taken(self) -> None:
        """End the children of taken evaluations: each is given ``ENDING_GRACE_S`` to end on
        its own (writing objective.json), then ended, and the daemon writes the record.

        Through SLURM a child learns that its jobs have ended only at the
        executor's next status check, up to 3 minutes away. Its jobs' outputs
        are all there by then and the Snakemake inside each job has cleared
        their incomplete marks, so ending it loses nothing and a later run
        redoes none of them (checked by hand on the one-node SLURM: a dry run
        afterwards plans only the objective job).
        """
        now, ended = time.time(), False
        for evaluation, (child, taken, taken_at) in list(self.ending.items()):
            files = self.files.evaluation(evaluation)
            if not child.finished():
                if now - taken_at > ENDING_GRACE_S and not objective_job_started(files, child):
                    child.end()
                continue
            del self.ending[evaluation]
            self._write_what_the_child_did_not(evaluation, taken)
            ended = True
        if ended:
            self.write_tables()

    def _write_what_the_child_did_not(
        self, evaluation: str, record: ObjectiveRecord | None = None
    ) -> None:
        """After a child has ended (on its own, or ended by the daemon): the evaluation's
        objective.json (``record``, when given and the child did not write it) and its
        simulations in the archive (:func:`demcal.jobs.evaluation.archive`), the child's last
        jobs, where it did not run them."""
        files = self.files.evaluation(evaluation)
        if record is not None and not files.objective.exists():
            record.write(files.objective)
        if not files.archived.exists():
            archive(self.study, evaluation)

    def _objective_written(self, evaluation: str, child: Running) -> ObjectiveRecord:
        """The outcome of an evaluation whose child has ended: its objective.json; else, when
        every response is there (a child ended before its objective job), the outcome from
        them, written; else a failure that says why there is none."""
        files = self.files.evaluation(evaluation)
        taken = None if files.objective.exists() else self.taken_early(evaluation)
        self._write_what_the_child_did_not(evaluation, taken)
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
                SimulationRecord.read(path.with_name("simulation.json")).attempt
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
            )
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

    # -- early termination ---------------------------------------------------------
    def watch_running(self) -> None:
        """Stop running evaluations whose partial objective is hopeless (thesis sec. 2.6);
        record each new estimate with its limit in early_termination.csv."""
        if self.optimizer.best_observed is None:
            return
        watched = {
            evaluation: self._estimate(evaluation)
            for evaluation in self.children
            if evaluation not in self.stop_requested
        }
        decide = lambda evaluation, estimate: self.optimizer.early_termination(  # noqa: E731
            proposal_id(evaluation), estimate, self._run_progress(evaluation, estimate)
        )
        decisions = early_termination_decisions(watched, decide)
        now, rows = time.time(), []
        for evaluation, decision in decisions.items():
            if self.recorded_estimates.get(evaluation) != (watched[evaluation], decision.limit):
                self.recorded_estimates[evaluation] = (watched[evaluation], decision.limit)
                rows.append(
                    (
                        f"{now - self.started_at:.1f}",
                        evaluation,
                        f"{now - self.children[evaluation].started:.1f}",
                        f"{watched[evaluation]:.7g}",
                        "" if decision.limit is None else f"{decision.limit:.7g}",
                        int(decision.stop),
                        "" if decision.judged is None else f"{decision.judged:.7g}",
                    )
                )
            if decision.stop:
                ask_to_stop(
                    self.files.evaluation(evaluation),
                    f"stopped early by early termination: {decision.reason}",
                )
                self.stop_requested.add(evaluation)
                log.info("%s: early stop: %s", evaluation, decision.reason)
        append_estimates(self.files.early_termination, rows)

    def _run_progress(self, evaluation: str, estimate: float) -> RunProgress:
        """Where a running evaluation stands: its share done and its estimate's heading. The
        trend starts anew whenever another simulation starts reporting (the estimate, a mean
        over the reporting ones, jumps then)."""
        files, scenes = self.files.evaluation(evaluation), list(self.study.scenes)
        done = share_done(files, scenes, self.study.replicates)
        estimates = partial_responses(files, scenes, self.study.replicates)
        reporting = sum(len(estimate["values"]) for estimate in estimates.values())
        history = self.estimate_history.setdefault(evaluation, [])
        if history and history[-1][2] != reporting:
            history.clear()
        if not history or history[-1][:2] != (done, estimate):
            history.append((done, estimate, reporting))
        heading = estimate_heading([(d, e) for d, e, _ in history])
        provisional = [key for key, estimate in estimates.items() if not estimate["final"]]
        return RunProgress(done, heading, tuple(sorted(estimates)), tuple(sorted(provisional)))

    def _estimate(self, evaluation: str) -> float | None:
        """Objective estimate of a running evaluation from its replicates' early estimates."""
        files = self.files.evaluation(evaluation)
        cost = 0.0
        if self.study.rayleigh_cost_weight:
            try:
                cost = self.study.timestep_cost(PointRecord.read(files.params).parameters)
            except DemcalError:
                return None  # the evaluation will record why
        return self.study.objective.estimate(
            latest_estimates(files, list(self.study.scenes), self.study.replicates), cost
        )

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
        and the points taken from the archive (``reused``); None when reuse is off."""
        if self.study.reuse is None:
            return None
        return {
            "new": self.optimizer.completed_evaluations(),
            "reused": self.optimizer.reused_points,
        }

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
            self.watch_running()
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
        ).write(self.files.finished)
        log.info("calibration finished: %s", reason)
        return reason

    def wait_for_ending(self) -> None:
        """Wait until the children of taken evaluations have ended (:meth:`end_taken`), so
        that the calibration ends with every record on disk."""
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


def objective_job_started(files: EvaluationFiles, child: Running) -> bool:
    """Whether the child has started its objective job (its log is newer than the child):
    that job takes a second or two, and a child ended during it would leave objective.json
    marked incomplete for Snakemake."""
    try:
        return files.job_log("objective").stat().st_mtime >= child.started
    except OSError:
        return False
