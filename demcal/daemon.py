"""The calibration daemon: owns the optimizer, runs one child Snakemake per evaluation.

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
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import logging
import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from demcal.config import Study
from demcal.errors import DemcalError, SimulationFailed
from demcal.evaluation import evaluation_dir, objective, response_paths
from demcal.files import atomic_write_text, log_tail, read_json, read_partial, write_json
from demcal.objective import objective_value, relative_error
from demcal.optimizer import Optimizer

log = logging.getLogger("demcal.daemon")
ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "Snakefile"
STOP_CALIBRATION = "STOP_CALIBRATION"
#: Written only when the calibration loop has ended (stop reason recorded); the
#: workflow's ``calibrate`` rule has it as output, so a daemon that died (killed,
#: disk error) leaves none and the next run resumes instead of reporting.
FINISHED = "finished.json"


#: Optimizer settings a resumed calibration takes from the current config.
RESUMABLE_SETTINGS = ("max_evaluations", "max_seconds", "target_objective",
                      "no_improvement_evaluations", "early_termination")


def study_definition(study: Study) -> dict:
    """What makes evaluations of a study comparable; resuming with another one is refused."""
    return json.loads(json.dumps({
        "parameters": {p.name: [p.lower, p.upper] for p in study.free},
        "fixed": study.fixed,
        "targets": [[t.key, t.value, t.weight] for t in study.targets],
        "settings": study.settings,
        "engine": {"name": study.engine.name, **study.engine.settings},
        "replicates": study.replicates,
        "timestep_fraction": study.timestep_fraction,
        "seed": study.seed,
        # only when used, so that studies from before the term still resume
        **({"rayleigh_cost_weight": study.rayleigh_cost_weight}
           if study.rayleigh_cost_weight else {}),
    }))


def evaluation_id(proposal_id: int) -> str:
    return f"e{proposal_id:04d}"


def proposal_id(evaluation: str) -> int:
    return int(evaluation[1:])


@dataclass
class Child:
    """A running child Snakemake of one evaluation (ours, or re-attached after a restart)."""

    evaluation: str
    pid: int
    process: subprocess.Popen | None
    started: float

    def finished(self) -> bool:
        if self.process is not None:
            return self.process.poll() is not None
        return not alive(self.pid)

    def returncode(self) -> int | None:
        return None if self.process is None else self.process.returncode


def alive(pid: int) -> bool:
    """True if ``pid`` is a live process that is not a zombie."""
    try:
        status = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return status.rsplit(")", 1)[1].split()[0] != "Z"


def _is_snakemake_for(pid: int, target: str) -> bool:
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return False
    return any(b"snakemake" in part for part in cmdline) and target.encode() in cmdline


class Calibration:
    """One study's calibration on disk under ``results/<study>/``."""

    def __init__(self, study: Study, configfile: Path, profile: Path | None, workers: int,
                 retries: int, poll_seconds: float = 2.0, child_cores: int | None = None,
                 watch_pid: int | None = None):
        self.study, self.configfile, self.profile = study, Path(configfile).resolve(), profile
        self.workers, self.retries, self.poll_seconds = workers, retries, poll_seconds
        self.child_cores = child_cores
        #: the Snakemake that started this daemon: when it dies, the daemon ends too
        self.watch_pid = watch_pid
        self.dir = study.results_dir
        self.state_file = self.dir / "optimizer.json"
        self.children: dict[str, Child] = {}
        self.names = [p.name for p in study.free]
        self.optimizer = self._load_or_create_optimizer()
        self.started_at = self._load_start_time()
        self.stop_requested: set[str] = set()

    # -- state ------------------------------------------------------------------
    def _load_or_create_optimizer(self) -> Optimizer:
        """The saved optimizer (with the config's current budget and stopping rules), or a new one."""
        if self.state_file.exists():
            try:
                optimizer = Optimizer.from_json(self.state_file.read_text())
            except (ValueError, KeyError) as exc:
                raise DemcalError(f"{self.state_file}: optimizer state unreadable ({exc}); "
                                  f"move it away to start the calibration afresh") from None
            optimizer.settings = dataclasses.replace(optimizer.settings, **{
                name: getattr(self.study.optimizer, name) for name in RESUMABLE_SETTINGS})
            return optimizer
        return Optimizer([p.lower for p in self.study.free], [p.upper for p in self.study.free],
                         self.study.optimizer, seed=self.study.seed, workers=self.workers)

    def _load_start_time(self) -> float:
        """Start of the calibration; refuses to resume one made with another study definition.

        Changed target values or weights (same responses) are no reason to
        simulate again: every finished evaluation is re-scored from its
        stored responses instead (``rescore``).
        """
        path = self.dir / "calibration.json"
        definition = study_definition(self.study)
        if path.exists():
            record = read_json(path, "calibration.json")
            old = record.get("definition", {})
            changed = sorted(k for k in definition if old.get(k) != definition[k])
            if changed == ["targets"] and _target_keys(old["targets"]) == _target_keys(
                    definition["targets"]):
                self.rescore()
                write_json(path, {**record, "definition": definition})
            elif changed:
                raise DemcalError(
                    f"{self.dir} holds a calibration of a different study definition (changed: "
                    f"{', '.join(changed)}); give the study a new name or move {self.dir} away")
            return float(record["started_at"])
        now = time.time()
        write_json(path, {"started_at": now, "study": self.study.name, "definition": definition})
        return now

    def rescore(self) -> None:
        """Recompute every finished evaluation's objective from its stored responses.

        For new target values or weights: objective.json is rewritten from the
        replicates' responses.json (no simulation runs) and the optimizer's
        values are replaced, so evaluations whose objective could not be
        computed before count now.
        """
        outcomes = {}
        for record in self.optimizer.records:
            if record["status"] == "pending":
                continue
            evaluation = evaluation_id(record["id"])
            paths = response_paths(self.study, evaluation)
            if not all(p.exists() for p in paths):
                continue  # never simulated to the end: nothing to re-score
            result = objective(self.study, evaluation, paths)
            outcomes[record["id"]] = (result["status"], result.get("objective"),
                                      _objective_per_replicate(self.study, result) or None)
        self.optimizer.rescore(outcomes)
        self.save_state()
        log.info("targets changed: re-scored %d evaluations from their stored responses",
                 len(outcomes))

    def save_state(self) -> None:
        atomic_write_text(self.state_file, self.optimizer.to_json())

    def elapsed(self) -> float:
        return time.time() - self.started_at

    # -- launching ---------------------------------------------------------------
    def target(self, evaluation: str) -> str:
        return str(evaluation_dir(self.study, evaluation) / "objective.json")

    def child_command(self, evaluation: str) -> list[str]:
        command = [sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE),
                   "--configfile", str(self.configfile), "--nolock", "--rerun-incomplete",
                   "--rerun-triggers", "mtime", "--quiet", "rules"]
        if self.profile is not None:
            command += ["--profile", str(self.profile)]
        if self.child_cores is not None:
            command += ["--cores", str(self.child_cores)]
        return command + [self.target(evaluation)]

    def launch(self, evaluation: str) -> None:
        """Start the child Snakemake of an evaluation; record its pid in launch.json."""
        evaldir = evaluation_dir(self.study, evaluation)
        (evaldir / "logs").mkdir(parents=True, exist_ok=True)
        with open(evaldir / "logs" / "snakemake.log", "a") as out:
            process = subprocess.Popen(self.child_command(evaluation), stdin=subprocess.DEVNULL,
                                       stdout=out, stderr=subprocess.STDOUT,
                                       start_new_session=True)
        now = time.time()
        write_json(evaldir / "launch.json", {"pid": process.pid, "started_at": now})
        self.children[evaluation] = Child(evaluation, process.pid, process, now)
        log.info("launched %s (pid %d)", evaluation, process.pid)

    def propose(self) -> None:
        """Fill free worker slots with new points from the optimizer."""
        while len(self.children) < self.workers:
            proposals = self.optimizer.ask(1)
            if not proposals:
                return
            proposal = proposals[0]
            evaluation = evaluation_id(proposal.id)
            point = dict(zip(self.names, proposal.x))
            params = evaluation_dir(self.study, evaluation) / "params.json"
            write_json(params, {"parameters": point, "attempt": 0, "previous_failures": [],
                                "in_initial_design": proposal.in_initial_design})
            self.save_state()
            self.launch(evaluation)

    # -- resuming ----------------------------------------------------------------
    def resume(self) -> None:
        """Re-attach, read back or relaunch the evaluations pending in the saved state."""
        for pid in self.optimizer.pending():
            evaluation = evaluation_id(pid)
            evaldir = evaluation_dir(self.study, evaluation)
            if not (evaldir / "params.json").exists():
                raise DemcalError(f"{evaldir}/params.json is missing for a pending evaluation; "
                                  f"the results directory was changed by hand")
            launch = evaldir / "launch.json"
            if launch.exists():
                pid_running = int(read_json(launch, "launch.json").get("pid", -1))
                if alive(pid_running) and _is_snakemake_for(pid_running, self.target(evaluation)):
                    self.children[evaluation] = Child(evaluation, pid_running, None, time.time())
                    log.info("re-attached %s (pid %d)", evaluation, pid_running)
                    continue
            if (evaldir / "objective.json").exists():
                self.children[evaluation] = Child(evaluation, -1, None, time.time())
                continue  # finished while no daemon ran: collected in the next poll
            self.launch(evaluation)

    # -- collecting ----------------------------------------------------------------
    def collect(self) -> None:
        """Tell the optimizer about every finished child; retry failures up to the cap."""
        for evaluation, child in list(self.children.items()):
            if not child.finished():
                continue
            del self.children[evaluation]
            evaldir = evaluation_dir(self.study, evaluation)
            try:
                record = read_json(evaldir / "objective.json", "objective.json")
            except SimulationFailed as exc:
                tail = log_tail(evaldir / "logs" / "snakemake.log", lines=3)
                record = {"status": "failed",
                          "reason": f"workflow ended with code {child.returncode()} and no "
                                    f"objective ({exc}): {tail}"}
            self.finish(evaluation, record)

    def finish(self, evaluation: str, record: dict) -> None:
        evaldir = evaluation_dir(self.study, evaluation)
        params = read_json(evaldir / "params.json", "params.json")
        status = record.get("status")
        if status == "failed" and params.get("attempt", 0) < self.retries:
            self.retry(evaluation, params, record.get("reason", ""))
            return
        pid = proposal_id(evaluation)
        if status == "ok":
            replicates = _objective_per_replicate(self.study, record)
            self.optimizer.tell(pid, value=record["objective"], replicates=replicates or None)
        elif status == "terminated":
            self.optimizer.tell(pid, status="terminated")
        else:
            self.optimizer.tell(pid, status="failed")
        self.save_state()
        self.stop_requested.discard(evaluation)
        log.info("%s: %s %s", evaluation, status,
                 record.get("objective", "") if status == "ok" else record.get("reason", ""))
        self.write_tables()

    def retry(self, evaluation: str, params: dict, reason: str) -> None:
        """Run a failed evaluation again with new seeds (attempt + 1)."""
        evaldir = evaluation_dir(self.study, evaluation)
        for scene in self.study.scenes:
            shutil.rmtree(evaldir / scene, ignore_errors=True)
        for stale in ("objective.json", "STOP"):
            (evaldir / stale).unlink(missing_ok=True)
        self.stop_requested.discard(evaluation)
        params["attempt"] = params.get("attempt", 0) + 1
        params["previous_failures"] = params.get("previous_failures", []) + [reason]
        write_json(evaldir / "params.json", params)
        log.info("%s failed (%s); retry %d of %d", evaluation, reason, params["attempt"],
                 self.retries)
        self.launch(evaluation)

    # -- early termination ---------------------------------------------------------
    def watch_running(self) -> None:
        """Stop running evaluations whose partial objective is hopeless (thesis sec. 2.6)."""
        for evaluation in self.children:
            if evaluation in self.stop_requested:
                continue
            estimate = partial_objective(self.study, evaluation_dir(self.study, evaluation))
            if estimate is None or self.optimizer.best_observed is None:
                continue
            decision = self.optimizer.early_termination(proposal_id(evaluation), estimate)
            if decision.stop:
                (evaluation_dir(self.study, evaluation) / "STOP").touch()
                self.stop_requested.add(evaluation)
                log.info("%s: early stop: %s", evaluation, decision.reason)

    # -- outputs ---------------------------------------------------------------------
    def write_tables(self) -> None:
        write_evaluations_csv(self.study, self.dir / "evaluations.csv")
        best = self.optimizer.best()
        if best is not None:
            evaluation = evaluation_id(best["id"])
            record = read_json(evaluation_dir(self.study, evaluation) / "objective.json",
                               "objective.json")
            write_json(self.dir / "best.json", {
                "evaluation": evaluation, "parameters": dict(zip(self.names, best["x"])),
                "objective": best["value"], "predicted_objective": best["predicted"],
                "responses": record.get("responses", {}), "targets": record.get("targets", {}),
                "relative_errors": record.get("relative_errors", {})})

    def progress_line(self) -> str:
        records = [r["status"] for r in self.optimizer.records]
        done = sum(s == "ok" for s in records)
        failed = sum(s == "failed" for s in records)
        stopped = sum(s == "terminated" for s in records)
        budget = self.optimizer.settings.max_evaluations
        best = self.optimizer.best()
        best_text = "no result yet" if best is None else (
            f"best {best['value']:.4g} at " + ", ".join(
                f"{n}={v:.3g}" for n, v in zip(self.names, best["x"])))
        elapsed = self.elapsed()
        finished = done + failed + stopped
        eta = ""
        if finished:
            eta = f", ~{_clock((budget - finished) * elapsed / finished)} to budget"
        return (f"[demcal {self.study.name}] {finished}/{budget} done ({failed} failed, "
                f"{stopped} stopped early), {len(self.children)} running | {best_text} | "
                f"{_clock(elapsed)} elapsed{eta}")

    # -- the loop ------------------------------------------------------------------
    def run(self, show_progress=print) -> str:
        """Calibrate until a stopping rule holds and nothing is running; return the reason.

        Only a loop that ends so writes ``finished.json``; a daemon that dies
        or is orphaned leaves the calibration unfinished, to be resumed.
        """
        (self.dir / STOP_CALIBRATION).unlink(missing_ok=True)  # a new run overrides an old stop
        (self.dir / FINISHED).unlink(missing_ok=True)  # running again: not finished any more
        self.resume()
        reason = None
        while True:
            self.check_parent()
            self.collect()
            self.watch_running()
            if (self.dir / STOP_CALIBRATION).exists():
                reason = reason or "stopped on request (demcal stop)"
            reason = reason or self.optimizer.stop_reason(self.elapsed())
            if reason is None:
                self.propose()
                if not self.children:
                    reason = "no more points to evaluate"
            if reason is not None and not self.children:
                break
            show_progress(self.progress_line())
            time.sleep(self.poll_seconds)
        self.write_tables()
        show_progress(self.progress_line())
        counts = {}
        for record in self.optimizer.records:
            counts[record["status"]] = counts.get(record["status"], 0) + 1
        write_json(self.dir / FINISHED, {"reason": reason, "ended_at": time.time(),
                                         "evaluations": counts})
        log.info("calibration finished: %s", reason)
        return reason

    def check_parent(self) -> None:
        """End the daemon when the Snakemake that started it is gone (killed, lost terminal).

        Running evaluations are left alone: each is a child Snakemake in its
        own session, re-attached or read back by the next daemon.
        """
        if self.watch_pid is not None and not alive(self.watch_pid):
            log.info("the Snakemake that started this daemon (pid %d) is gone; ending",
                     self.watch_pid)
            raise DemcalError(
                f"the Snakemake that started this daemon (pid {self.watch_pid}) has ended, so "
                f"the daemon ends too; {len(self.children)} running evaluations go on and are "
                f"collected when the same command runs again")


def _target_keys(targets: list) -> set[str]:
    """The responses a study definition targets (its ``targets`` entries are [key, value, weight])."""
    return {entry[0] for entry in targets}


def _clock(seconds: float) -> str:
    seconds = int(max(seconds, 0))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def _objective_per_replicate(study: Study, record: dict) -> list[float]:
    """Eq. 3.3 per replicate index, for the optimizer's noise estimate (equal replicate counts)."""
    reps = record.get("replicates", {})
    counts = {len(v) for v in reps.values()}
    if len(counts) != 1 or counts == {1}:
        return []
    cost = study.timestep_cost(record["parameters"])
    return [objective_value(study.targets, {k: v[i] for k, v in reps.items()}) + cost
            for i in range(counts.pop())]


def partial_objective(study: Study, evaldir: Path) -> float | None:
    """Objective estimate from the latest early estimates in the replicates' partial.csv.

    Each targeted response's estimate is averaged over the replicates that
    have one; the sum runs over the targets with an estimate (so it is a
    lower bound of eq. 3.3 when some responses are not estimated yet), plus
    the Rayleigh time-step cost, known from the start.
    """
    estimates: dict[str, list[float]] = {}
    for scene in study.scenes:
        for rep in range(study.replicates):
            latest = {}
            for row in read_partial(evaldir / scene / f"rep{rep}" / "partial.csv"):
                if row["response"] is not None and row["value"] is not None:
                    latest[row["response"]] = row["value"]
            for response, value in latest.items():
                estimates.setdefault(f"{scene}.{response}", []).append(value)
    total, used = 0.0, 0
    if study.rayleigh_cost_weight:
        try:
            total = study.timestep_cost(read_json(evaldir / "params.json",
                                                  "params.json")["parameters"])
        except (DemcalError, KeyError, TypeError):
            return None  # the evaluation will record why
    for t in study.targets:
        if t.key in estimates:
            mean = sum(estimates[t.key]) / len(estimates[t.key])
            total += t.weight * relative_error(mean, t.value) ** 2
            used += 1
    return total if used and math.isfinite(total) else None


def write_evaluations_csv(study: Study, path: Path) -> None:
    """One row per evaluation: parameters, responses per replicate, objective, status, cost."""
    names = [p.name for p in study.free]
    header = ["evaluation", "status", "reason", "objective", "attempts", *names,
              *[t.key for t in study.targets],
              *[f"{t.key}.rep{r}" for t in study.targets for r in range(study.replicates)],
              "started_at", "ended_at", "cpu_s"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=header, extrasaction="ignore")
    writer.writeheader()
    for evaldir in sorted((study.results_dir / "evals").glob("e[0-9]*")):
        try:
            params = read_json(evaldir / "params.json", "params.json")
        except SimulationFailed:
            continue
        objective_file = evaldir / "objective.json"
        try:
            record = read_json(objective_file, "objective.json")
            ended = objective_file.stat().st_mtime
        except (SimulationFailed, OSError):
            record, ended = {"status": "running"}, ""
        launch = {}
        if (evaldir / "launch.json").exists():
            launch = read_json(evaldir / "launch.json", "launch.json")
        writer.writerow({
            "evaluation": evaldir.name, "status": record.get("status"),
            "reason": record.get("reason", ""), "objective": record.get("objective", ""),
            "attempts": params.get("attempt", 0) + 1, **params.get("parameters", {}),
            **record.get("responses", {}),
            **{f"{key}.rep{i}": value for key, values in record.get("replicates", {}).items()
               for i, value in enumerate(values)},
            "started_at": launch.get("started_at", ""), "ended_at": ended,
            "cpu_s": (record.get("cost") or {}).get("cpu_s", "")})
    atomic_write_text(path, buffer.getvalue())


def profile_settings(profile: Path | None) -> dict:
    if profile is None:
        return {}
    path = Path(profile) / "config.yaml"
    try:
        return yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise DemcalError(f"profile {profile}: cannot read {path}: {exc}") from None


def reopen_failed(study: Study) -> list[str]:
    """Mark every failed evaluation for a rerun with new seeds by the next daemon run.

    The optimizer forgets the failure (the point is pending again), the
    evaluation's outputs are removed and its attempt count goes on, so the
    rerun uses new seeds; finished.json goes too, so Snakemake's default
    target runs the daemon again.
    """
    state_file = study.results_dir / "optimizer.json"
    if not state_file.exists():
        raise DemcalError(f"study {study.name!r} has not started ({state_file} missing)")
    optimizer = Optimizer.from_json(state_file.read_text())
    reopened = []
    for evaldir in sorted((study.results_dir / "evals").glob("e[0-9]*")):
        try:
            status = read_json(evaldir / "objective.json", "objective.json").get("status")
        except SimulationFailed:
            continue
        if status != "failed":
            continue
        params = read_json(evaldir / "params.json", "params.json")
        optimizer.reopen(proposal_id(evaldir.name))
        for scene in study.scenes:
            shutil.rmtree(evaldir / scene, ignore_errors=True)
        for stale in ("objective.json", "STOP", "launch.json"):
            (evaldir / stale).unlink(missing_ok=True)
        params["attempt"] = params.get("attempt", 0) + 1
        write_json(evaldir / "params.json", params)
        reopened.append(evaldir.name)
    atomic_write_text(state_file, optimizer.to_json())
    (study.results_dir / FINISHED).unlink(missing_ok=True)
    write_evaluations_csv(study, study.results_dir / "evaluations.csv")
    return reopened


def request_stop(study: Study) -> None:
    """Make a running daemon stop proposing and stop running evaluations cleanly."""
    study.results_dir.mkdir(parents=True, exist_ok=True)
    (study.results_dir / STOP_CALIBRATION).touch()
    for launch in (study.results_dir / "evals").glob("*/launch.json"):
        if not (launch.parent / "objective.json").exists():
            (launch.parent / "STOP").touch()
