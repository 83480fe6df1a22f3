"""Engines behave alike on disk: progress in partial.csv, STOP honoured, failures with reasons."""

import ast
import importlib.util
import os
import re
import subprocess
import sys
import textwrap
import threading
import time
import tracemalloc
from pathlib import Path

import pytest

from demcal.daemon.termination import latest_estimates
from demcal.engines import command
from demcal.engines.analytic import AnalyticEngine
from demcal.engines.base import RunMonitor, SimulationJob
from demcal.engines.command import CommandEngine, SimulatorProgress, command_words
from demcal.engines.lammps import LammpsEngine
from demcal.errors import ConfigError
from demcal.physics.catalogue import CATALOG
from demcal.results.layout import EvaluationFiles
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES

SCENE = SCENES.load("cylinder_lift")


def make_job(tmp_path, **parameters):
    values = {name: spec.default for name, spec in CATALOG.items()}
    values.update(parameters)
    return SimulationJob(
        scene="cylinder_lift",
        parameters=values,
        settings=SCENE.resolve_settings({}, "s"),
        seed=11,
        responses=["bulk_density", "angle_of_repose"],
        timestep_fraction=0.25,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )


def run(engine, job):
    return engine.run(job, RunMonitor(job), SCENES.load(job.scene).driver(engine.name))


def stop_after(path, seconds):
    timer = threading.Timer(seconds, path.touch)
    timer.start()
    return timer


def test_analytic_is_seeded_and_noisy(tmp_path):
    engine = AnalyticEngine({"noise": 0.05})
    first = run(engine, make_job(tmp_path)).measurements
    again = run(engine, make_job(tmp_path)).measurements
    exact = SCENE.analytic_model(make_job(tmp_path).parameters, {})
    assert first == again
    assert first["bulk_density"] != pytest.approx(exact["bulk_density"], rel=1e-6)
    assert first["bulk_density"] == pytest.approx(exact["bulk_density"], rel=0.25)


def test_analytic_streams_progress_and_early_estimates(tmp_path):
    job = make_job(tmp_path)
    result = run(AnalyticEngine({"noise": 0.0, "chunks": 4}), job)
    rows = read_partial(job.partial_file)
    assert result.status == Status.OK
    assert [r["progress"] for r in rows if r["response"] in (None, "bulk_density")] == [
        0.25,
        0.5,
        0.75,
        1.0,
    ]
    assert {r["response"] for r in rows if r["progress"] >= 0.5} == {
        "bulk_density",
        "angle_of_repose",
    }


def test_analytic_honours_stop(tmp_path):
    job = make_job(tmp_path)
    timer = stop_after(tmp_path / "STOP", 0.3)
    start = time.monotonic()
    result = run(AnalyticEngine({"duration": 5.0, "chunks": 50}), job)
    timer.join()
    assert result.status == Status.TERMINATED and result.reason == "stop requested"
    assert time.monotonic() - start < 2.0
    assert result.measurements == {}


def test_analytic_failure_injection_always_and_once(tmp_path):
    rules = [
        {"when": {"sliding_friction_pp": [0.4, 0.6]}, "mode": "once", "reason": "flaky"},
        {"when": {"sliding_friction_pp": [0.8, 1.0]}, "reason": "always broken"},
    ]
    engine = AnalyticEngine({"failures": rules})
    once_dir, always_dir, fine_dir = (tmp_path / n for n in ("once", "always", "fine"))
    for d in (once_dir, always_dir, fine_dir):
        d.mkdir()
    assert run(engine, make_job(once_dir, sliding_friction_pp=0.5)).reason == "flaky"
    retry = make_job(once_dir, sliding_friction_pp=0.5)
    retry.attempt = 1
    assert run(engine, retry).status == Status.OK
    for _ in range(2):
        result = run(engine, make_job(always_dir, sliding_friction_pp=0.9))
        assert (result.status, result.reason) == (Status.FAILED, "always broken")
    assert run(engine, make_job(fine_dir, sliding_friction_pp=0.2)).status == Status.OK


SIMULATOR = textwrap.dedent("""
    import json, os, signal, sys, time
    mu, seed, mode = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    with open("progress.csv", "w") as f:
        f.write("progress,response,value\\n0.5,bulk_density,%g\\n" % (1400 + mu))
    if mode == "crash":
        sys.exit("solver diverged")
    if mode == "segv":
        os.kill(os.getpid(), signal.SIGSEGV)
    if mode == "flood_partial":  # 3 MB of estimates of responses nobody asked for, then a hang
        with open("progress.csv", "a") as f:
            for i in range(120_000):
                f.write("0.6,made_up_%d,%d\\n" % (i, i))
                if i % 4000 == 0:
                    f.flush()
                    time.sleep(0.05)
        time.sleep(30)
    if mode.startswith("detach"):  # a process of its own session, as with setsid or a double fork
        import subprocess
        sleeper = subprocess.Popen(["sleep", "300"], start_new_session=True)
        open("detached.pid", "w").write(str(sleeper.pid))
        if mode == "detach_hang":
            time.sleep(30)
    if mode == "slow":
        time.sleep(30)
    if mode == "flood":
        sys.stderr.write("x" * 4_000_000 + " solver diverged\\n")
        sys.exit(1)
    lies = {"true": True, "text": "1400 kg/m3", "null": None, "nan": float("nan"), "list": [1400]}
    if mode in lies:
        json.dump({"bulk_density": lies[mode], "angle_of_repose": 20 + mu}, open("out.json", "w"))
    elif mode == "array":
        json.dump([1400, 20], open("out.json", "w"))
    elif mode == "huge":
        json.dump({"bulk_density": 1400, "angle_of_repose": 20, "log": "x" * 2_000_000},
                  open("out.json", "w"))
    elif mode != "silent":
        json.dump({"bulk_density": 1400 + mu, "angle_of_repose": 20 + mu}, open("out.json", "w"))
""")


def command_engine(tmp_path, mode):
    script = tmp_path / "sim.py"
    script.write_text(SIMULATOR)
    return CommandEngine(
        {
            "command": f"{sys.executable} {script} {{sliding_friction_pp}} {{seed}} {mode}",
            "responses_file": "out.json",
            "partial_file": "progress.csv",
        }
    )


def test_command_engine_reads_responses(tmp_path):
    job = make_job(tmp_path, sliding_friction_pp=0.25)
    engine = command_engine(tmp_path, "ok")
    engine.check([SCENE])
    result = run(engine, job)
    assert result.status == Status.OK
    assert result.measurements == {"bulk_density": 1400.25, "angle_of_repose": 20.25}


@pytest.mark.parametrize(
    "mode,reason",
    [
        ("crash", r"simulator exited with code 1: solver diverged"),
        ("silent", r"simulator responses file missing"),
        ("true", r"out.json: 'bulk_density' is true \(bool\), not a number$"),
        ("text", r"out.json: 'bulk_density' is \"1400 kg/m3\" \(str\), not a number$"),
        ("null", r"out.json: 'bulk_density' is null, not a number$"),
        ("nan", r"out.json: 'bulk_density' is nan, not a finite number$"),
        ("list", r"out.json: 'bulk_density' is \[1400\] \(list\), not a number$"),
        ("array", r"simulator responses file is not a JSON object"),
        (
            "flood",
            r"simulator exited with code 1: \.\.\.x+ solver diverged \(its output: command.log",
        ),
        ("segv", r"^simulator died from SIGSEGV \(no output\)$"),
        (
            "huge",
            r"^simulator responses file \S+/out.json is 1.91 MB, more than the limit of 1 MB$",
        ),
    ],
)
def test_command_engine_failures_have_reasons(tmp_path, mode, reason):
    result = run(command_engine(tmp_path, mode), make_job(tmp_path))
    assert result.status == Status.FAILED
    assert re.search(reason, result.reason), result.reason
    assert len(result.reason) < 600  # a flooding simulator's 4 MB line is not copied into records


def test_a_flooding_partial_file_fails_the_run_in_bounded_memory(tmp_path, monkeypatch):
    """Past its limit the simulator is stopped with a reason; demcal copies only the job's
    responses into partial.csv and never holds the simulator's file in memory."""
    monkeypatch.setattr(command, "PARTIAL_FILE_BYTES", 2**20)
    engine = command_engine(tmp_path, "flood_partial")
    engine.settings["timeout"] = 8.0
    job = make_job(tmp_path)
    tracemalloc.start()
    try:
        result = run(engine, job)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert result.status == Status.FAILED
    assert result.reason.startswith(
        "partial file progress.csv grew beyond 1 MB; the simulator was stopped"
    ), result.reason
    assert peak < 8 * 2**20
    assert {r["response"] for r in read_partial(job.partial_file)} == {"bulk_density"}
    assert job.partial_file.stat().st_size < 10_000


def write(path, text, mode="a"):
    with open(path, mode) as handle:
        handle.write(text)


def test_simulator_progress_reads_on_from_where_it_stopped(tmp_path):
    """Read in pieces, a half-written last line waiting for its end, it learns what one read of
    the whole file does; a file cut short or replaced is read again from its start."""
    path = tmp_path / "progress.csv"
    pieces = [
        "progress,response,value\n0.1,bulk_density,1401\n0.2,",
        "",
        "angle_of_repose,2",
        "1\n0.3,bulk_density,14",
        "02\n0.4,made_up,7\n0.5,,\n0.6,bulk_density,nan\n",
    ]
    seen = [
        (None, {}),
        (0.1, {"bulk_density": 1401.0}),
        (0.1, {"bulk_density": 1401.0}),
        (0.1, {"bulk_density": 1401.0}),
        (0.2, {"bulk_density": 1401.0, "angle_of_repose": 21.0}),
        (0.6, {"bulk_density": 1402.0, "angle_of_repose": 21.0}),
    ]
    progress = SimulatorProgress(path, "progress.csv", ["bulk_density", "angle_of_repose"])
    progress.read_on()  # not written yet
    assert (progress.progress, progress.estimates) == seen[0]
    for piece, expected in zip(pieces, seen[1:]):
        write(path, piece)
        progress.read_on()
        assert (progress.progress, progress.estimates) == expected
    whole = SimulatorProgress(path, "progress.csv", ["bulk_density", "angle_of_repose"])
    whole.read_on()
    assert (whole.progress, whole.estimates) == (progress.progress, progress.estimates)

    write(path, "progress,response,value\n0.05,angle_of_repose,30\n", mode="w")  # rewritten
    progress.read_on()
    assert (progress.progress, progress.estimates) == (0.05, {"angle_of_repose": 30.0})
    replacement = tmp_path / "new.csv"
    write(replacement, "progress,response,value\n0.07,angle_of_repose,31\n", mode="w")
    os.replace(replacement, path)  # same size, another file
    progress.read_on()
    assert (progress.progress, progress.estimates) == (0.07, {"angle_of_repose": 31.0})


def test_the_daemon_reads_partial_csv_on_as_a_whole_read_would(tmp_path):
    """The early-termination watch, fed a partial.csv a few bytes at a time, sees at each step
    the latest estimates that a whole read of the complete lines finds (none of a torn line)."""
    job = make_job(tmp_path)
    run(AnalyticEngine({"noise": 0.0, "chunks": 6}), job)
    text = job.partial_file.read_bytes()
    files = EvaluationFiles(tmp_path / "evals" / "e1")
    growing = files.replicate("cylinder_lift", 0).partial
    growing.parent.mkdir(parents=True)
    complete = tmp_path / "complete.csv"
    for end in range(0, len(text) + 1, 7):
        growing.write_bytes(text[:end])  # rewritten in place, its start unchanged: an append
        complete.write_bytes(text[: text.rfind(b"\n", 0, end) + 1])
        whole = {
            f"cylinder_lift.{r['response']}": [r["value"]]
            for r in read_partial(complete)
            if r["response"] is not None and r["value"] is not None
        }
        assert latest_estimates(files, ["cylinder_lift"], 1) == whole
    assert set(whole) == {"cylinder_lift.bulk_density", "cylinder_lift.angle_of_repose"}


@pytest.mark.parametrize(
    "executable,message",
    [
        ("/no/such/simulator", r"executable '/no/such/simulator' not found$"),
        ("no_such_simulator_on_path", r"executable 'no_such_simulator_on_path' not found on PATH"),
        ("{tmp}/sim.py", r"'\S+/sim.py' is not executable \(no execute permission: chmod \+x it"),
        ("{tmp}", r"'\S+' is not executable \(a directory\)$"),
    ],
)
def test_command_engine_says_why_it_cannot_run_the_executable(tmp_path, executable, message):
    (tmp_path / "sim.py").write_text(SIMULATOR)
    engine = CommandEngine(
        {"command": f"{executable.format(tmp=tmp_path)} {{seed}}", "responses_file": "out.json"}
    )
    with pytest.raises(ConfigError, match=message):
        engine.check([SCENE])


def test_a_relative_executable_path_is_taken_from_where_the_study_was_checked(
    tmp_path, monkeypatch
):
    """bin/sim passes the check in the project folder and runs from there, not from the run dir."""
    simulator = tmp_path / "bin" / "sim"
    simulator.parent.mkdir()
    simulator.write_text(f"#!{sys.executable}\n" + SIMULATOR)
    simulator.chmod(0o755)
    monkeypatch.chdir(tmp_path)
    engine = CommandEngine(
        {"command": "bin/sim {sliding_friction_pp} {seed} ok", "responses_file": "out.json"}
    )
    engine.check([SCENE])
    run_directory = tmp_path / "results" / "rep0"
    run_directory.mkdir(parents=True)
    result = run(engine, make_job(run_directory, sliding_friction_pp=0.25))
    assert result.status == Status.OK, result.reason


def test_command_engine_stop_terminates_the_process(tmp_path):
    job = make_job(tmp_path)
    timer = stop_after(tmp_path / "STOP", 1.0)
    start = time.monotonic()
    result = run(command_engine(tmp_path, "slow"), job)
    timer.join()
    assert result.status == Status.TERMINATED
    assert time.monotonic() - start < 10.0
    assert any(r["response"] == "bulk_density" for r in read_partial(job.partial_file))


@pytest.mark.parametrize("mode", ["detach_hang", "detach_ok"])
def test_processes_a_simulator_detaches_end_with_it(tmp_path, mode):
    """A timeout kill, or a normal end, leaves no process of the simulator running, not even
    one in a session of its own (setsid)."""
    engine = command_engine(tmp_path, mode)
    engine.settings["timeout"] = 2.0
    job = make_job(tmp_path)
    result = run(engine, job)
    assert result.status == (Status.FAILED if mode == "detach_hang" else Status.OK), result.reason
    detached = int((Path(job.workdir) / "detached.pid").read_text())
    assert not Path(f"/proc/{detached}").exists()  # ended and reaped


def test_command_words_are_not_shell_expanded():
    words = command_words("sim -in {input} -mu {mu}", {"input": "a b; rm -rf /", "mu": 0.5})
    assert words == ["sim", "-in", "a b; rm -rf /", "-mu", "0.5"]


def test_command_engine_never_deletes_through_a_symlink(tmp_path):
    """A responses_file that a link points outside the run directory is not deleted or run."""
    outside = tmp_path / "precious.json"
    outside.write_text("{}")
    workdir = tmp_path / "run"
    workdir.mkdir()
    (workdir / "out.json").symlink_to(outside)
    result = run(command_engine(tmp_path, "ok"), make_job(workdir))
    assert result.status == Status.FAILED and "outside the run directory" in result.reason
    assert outside.read_text() == "{}"


# -- engines and scenes ---------------------------------------------------------

ENGINES_DIR = Path(__file__).resolve().parents[2] / "demcal" / "engines"


def test_engines_never_import_scenes():
    """Not at load time, not lazily inside a function: engines receive drivers instead."""
    for path in ENGINES_DIR.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                module = importlib.util.resolve_name(
                    "." * node.level + (node.module or ""), "demcal.engines"
                )
                names = [module] + [f"{module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            assert not any(n.startswith("demcal.scenes") for n in names), (path.name, names)
    loaded = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys, demcal.engines, demcal.engines.lammps_worker, "
            "demcal.engines.lammps_driver; print(sorted(sys.modules))",
        ],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "demcal.scenes" not in loaded


def test_scenes_name_their_drivers_per_engine():
    from demcal.scenes.cylinder_lift import analytic, lammps, liggghts

    assert SCENE.driver("analytic") is SCENE.analytic_model is analytic.analytic_model
    assert SCENE.driver("lammps") is lammps.run
    assert SCENE.driver("liggghts") is liggghts.case
    assert SCENES.load("shear_box").driver("liggghts") is None
    assert SCENE.driver("command") is None


def test_lammps_engine_without_a_driver_fails_with_a_reason(tmp_path):
    job = make_job(tmp_path)
    result = LammpsEngine().run(job, RunMonitor(job), None)
    assert (result.status, result.reason) == (
        Status.FAILED,
        "LAMMPS engine has no driver for scene 'cylinder_lift'",
    )


def test_recorded_reasons_are_bounded_and_keep_both_ends():
    from demcal.errors import REASON_CHARS, bounded_reason

    text = "start " + "x" * 100_000 + " end"
    short = bounded_reason(text)
    assert short.startswith("start ") and short.endswith(" end") and len(short) < REASON_CHARS + 60
    assert "characters cut; see the log" in short and bounded_reason("fine") == "fine"
