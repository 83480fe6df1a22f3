"""The per-evaluation Snakemake DAG end to end, on the analytic engine."""

import html
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from demcal.archive.store import Archive
from demcal.scenes import SCENES

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = [sys.executable, "-m", "snakemake"]


def run_snakemake(workdir, config, *args):
    (workdir / "study.yaml").write_text(yaml.safe_dump(config))
    return subprocess.run(
        [
            *SNAKEMAKE,
            "-s",
            str(ROOT / "Snakefile"),
            "--directory",
            str(workdir),
            "--configfile",
            str(workdir / "study.yaml"),
            "--cores",
            "2",
            *args,
        ],
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )


def write_point(workdir, study, evaluation, staged=False, **point):
    """params.json of an evaluation; ``staged`` as the daemon marks one it may stop early."""
    path = workdir / "results" / study / "evals" / evaluation / "params.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"parameters": point, "staged": staged}))
    return path.parent


@pytest.mark.slow
def test_objective_matches_eq_3_3_of_the_closed_form(tmp_path, analytic_config):
    point = {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1}
    evaldir = write_point(tmp_path, "unit", "e1", **point)
    proc = run_snakemake(tmp_path, analytic_config, "results/unit/evals/e1/objective.json")
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    params = {
        "sliding_friction_pp": 0.4,
        "rolling_friction_pp": 0.1,
        "sliding_friction_pw": 0.5,
        "rolling_friction_pw": 0.1,
        "restitution_pp": 0.5,
        "youngs_modulus": 5e6,
        "poisson_ratio": 0.3,
        "particle_density": 2500.0,
    }
    exact = SCENES.load("cylinder_lift").analytic_model(params, {})
    expected = ((exact["angle_of_repose"] - 25.0) / 25.0) ** 2 + (
        (exact["bulk_density"] - 1450.0) / 1450.0
    ) ** 2
    assert record["status"] == "ok"
    assert record["objective"] == pytest.approx(expected)
    assert len(record["replicates"]["cylinder_lift.bulk_density"]) == 2
    for rep in (0, 1):
        assert (evaldir / "logs" / f"simulate_cylinder_lift_rep{rep}.log").exists()
        assert (evaldir / "cylinder_lift" / f"rep{rep}" / "partial.csv").exists()


@pytest.mark.slow
def test_evaluate_centre_runs_the_middle_of_the_bounds(tmp_path, analytic_config):
    proc = run_snakemake(tmp_path, analytic_config, "evaluate_centre")
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((tmp_path / "results/unit/evals/centre/objective.json").read_text())
    assert record["parameters"] == {"sliding_friction_pp": 0.5, "rolling_friction_pp": 0.16}
    assert record["status"] == "ok"


@pytest.mark.slow
@pytest.mark.parametrize("staging", ["parallel", "staged"])
def test_failed_simulation_is_recorded_not_raised(tmp_path, analytic_config, staging):
    """In parallel both replicates fail; staged, the second is not started after the first
    failed, and it is not archived (nothing ran)."""
    analytic_config["staging"] = staging
    analytic_config["engine"]["failures"] = [
        {"when": {"sliding_friction_pp": [0.8, 0.9]}, "reason": "particles escaped"}
    ]
    evaldir = write_point(
        tmp_path,
        "unit",
        "bad",
        staged=staging == "staged",
        sliding_friction_pp=0.85,
        rolling_friction_pp=0.1,
    )
    proc = run_snakemake(
        tmp_path,
        analytic_config,
        "results/unit/evals/bad/objective.json",
        "results/unit/evals/bad/archived",  # the archive job, as the daemon's child builds it
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    assert record["status"] == "failed"
    assert "cylinder_lift rep0: particles escaped" in record["reason"]
    second = json.loads((evaldir / "cylinder_lift" / "rep1" / "simulation.json").read_text())
    with Archive(f"sqlite:///{tmp_path}/results/archive.sqlite") as archive:
        archived = archive.count()
    if staging == "parallel":
        assert "cylinder_lift rep1: particles escaped" in record["reason"]
        assert archived == 2
    else:
        assert second["status"] == "terminated"
        assert second["reason"] == "not started: cylinder_lift rep0 failed"
        assert "rep1" not in record["reason"]
        assert archived == 1


def joint_evaluation(tmp_path, analytic_config, duration, staged=False, **study):
    """One evaluation of a study of two scenes (cylinder lift and calibration device) x 2
    replicates, on the analytic engine (``staged`` as the daemon marks one it may stop); its
    folder and the Snakemake run."""
    config = {
        **analytic_config,
        "engine": {"name": "analytic", "noise": 0.0, "duration": duration},
        "parameters": {
            **analytic_config["parameters"],
            "sliding_friction_pw": {"lower": 0.2, "upper": 0.9},
        },
        "targets": [
            *analytic_config["targets"],
            {"scene": "calibration_device", "response": "mass_flow", "value": 0.02, "unit": "kg/s"},
            {"scene": "calibration_device", "response": "slide_time", "value": 0.6, "unit": "s"},
        ],
        **study,
    }
    evaldir = write_point(
        tmp_path,
        "unit",
        "e1",
        staged=staged,
        sliding_friction_pp=0.4,
        rolling_friction_pp=0.1,
        sliding_friction_pw=0.4,
    )
    return evaldir, run_snakemake(tmp_path, config, "results/unit/evals/e1/objective.json")


def simulation_spans(evaldir) -> dict:
    """(start, end) of each (scene, replicate) simulation of a joint evaluation."""
    spans = {}
    for scene in ("cylinder_lift", "calibration_device"):
        for rep in (0, 1):
            sim = json.loads((evaldir / scene / f"rep{rep}" / "simulation.json").read_text())
            spans[scene, rep] = (sim["started_at"], sim["ended_at"])
    return spans


@pytest.mark.slow
def test_staged_scenes_run_in_their_order_and_replicates_after_the_first(tmp_path, analytic_config):
    """staging [calibration_device, cylinder_lift]: the device's replicate 0, then the lift's,
    then both second replicates (side by side on 2 cores)."""
    evaldir, proc = joint_evaluation(
        tmp_path,
        analytic_config,
        1.0,
        staged=True,
        staging=["calibration_device", "cylinder_lift"],
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((evaldir / "objective.json").read_text())["status"] == "ok"
    span = simulation_spans(evaldir)
    assert span["cylinder_lift", 0][0] >= span["calibration_device", 0][1]
    first_done = max(span["cylinder_lift", 0][1], span["calibration_device", 0][1])
    assert all(span[scene, 1][0] >= first_done for scene in ("cylinder_lift", "calibration_device"))


@pytest.mark.slow
def test_out_of_range_point_is_a_failure_with_reason(tmp_path, analytic_config):
    evaldir = write_point(tmp_path, "unit", "odd", sliding_friction_pp=7.0, rolling_friction_pp=0.1)
    proc = run_snakemake(tmp_path, analytic_config, "results/unit/evals/odd/objective.json")
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    assert record["status"] == "failed"
    assert "sliding_friction_pp = 7 is outside the allowed range [0, 2]" in record["reason"]


@pytest.mark.slow
def test_stop_file_ends_the_evaluation_as_terminated(tmp_path, analytic_config):
    analytic_config["engine"]["duration"] = 30.0
    evaldir = write_point(tmp_path, "unit", "st", sliding_friction_pp=0.3, rolling_friction_pp=0.1)
    (evaldir / "STOP").touch()
    proc = run_snakemake(tmp_path, analytic_config, "results/unit/evals/st/objective.json")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((evaldir / "objective.json").read_text())["status"] == "terminated"


@pytest.mark.slow
def test_dag_of_one_evaluation_renders(tmp_path, analytic_config):
    write_point(tmp_path, "unit", "e1", sliding_friction_pp=0.4, rolling_friction_pp=0.1)
    proc = run_snakemake(
        tmp_path, analytic_config, "--dag", "dot", "results/unit/evals/e1/objective.json"
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    dot = proc.stdout[proc.stdout.index("digraph") :]
    for rule in ("simulate", "extract", "objective"):
        assert rule in dot
    if shutil.which("dot") is None:
        pytest.skip("graphviz 'dot' not installed (apt install graphviz); DOT text checked")
    svg = subprocess.run(["dot", "-Tsvg"], input=dot, capture_output=True, text=True, timeout=60)
    assert svg.returncode == 0 and "<svg" in svg.stdout


@pytest.mark.lammps
@pytest.mark.slow
def test_real_lammps_evaluation_through_the_dag(tmp_path, analytic_config):
    """One tiny cylinder lift on the embedded LAMMPS engine, through Snakemake."""
    analytic_config["engine"] = {"name": "lammps"}
    analytic_config["replicates"] = 1
    analytic_config["scenes"] = {
        "cylinder_lift": {
            "settings": {
                "particle_count": 150,
                "d50": 3.0e-3,
                "cylinder_diameter": 21.0e-3,
                "plate_width": 0.08,
                "lift_speed": 0.05,
                "max_settle_time": 0.5,
            }
        }
    }
    evaldir = write_point(tmp_path, "unit", "lmp", sliding_friction_pp=0.5, rolling_friction_pp=0.1)
    proc = run_snakemake(tmp_path, analytic_config, "results/unit/evals/lmp/objective.json")
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    assert record["status"] == "ok", record.get("reason")
    simulation = json.loads((evaldir / "cylinder_lift/rep0/simulation.json").read_text())
    assert simulation["engine_version"].startswith("lammps ")
    assert simulation["cost"]["steps"] > 1000
    assert 0 < record["responses"]["cylinder_lift.angle_of_repose"] < 90


def test_garbled_files_become_recorded_failures(tmp_path, analytic_config, monkeypatch):
    from demcal.jobs.steps import extract, objective
    from demcal.study.config import load_study

    study = load_study(analytic_config)
    simulation = tmp_path / "sim" / "simulation.json"
    simulation.parent.mkdir()
    simulation.write_text('{"status": "ok", "scen')  # torn write
    assert "unreadable" in extract(study, simulation).reason
    simulation.write_text('{"status": "ok"}')  # no scene, no settings
    assert "malformed" in extract(study, simulation).reason
    simulation.write_text('{"status": "ok", "format": 99}')  # a newer demcal's record
    assert "written by a newer demcal" in extract(study, simulation).reason
    monkeypatch.chdir(tmp_path)
    record = objective(study, "x", [simulation.parent / "responses.json", tmp_path / "none.json"])
    assert record.status == "failed" and "responses.json missing" in record.reason


@pytest.fixture(scope="module")
def reported(tmp_path_factory):
    """A 5-evaluation calibration on the analytic engine through the default
    target (report made)."""
    from helpers import ANALYTIC_STUDY

    config = {
        **ANALYTIC_STUDY,
        "optimizer": {"max_evaluations": 5},
        "replicates": 1,
        "calibration": {"workers": 2, "poll_seconds": 0.3},
    }
    workdir = tmp_path_factory.mktemp("reported")
    return workdir, run_snakemake(workdir, config, "--profile", str(ROOT / "profiles" / "local"))


@pytest.mark.slow
def test_default_target_calibrates_and_reports(reported):
    tmp_path, proc = reported
    assert proc.returncode == 0, proc.stderr[-3000:]
    study = tmp_path / "results" / "unit"
    assert "report: results/unit/report.html" in proc.stdout
    assert (study / "report.html").stat().st_size > 100_000
    # the landing page opens with the answer; docutils rendered it without complaint
    landing = (study / "report.html").read_text()
    landing = landing[
        landing.index("var workflow_desc") : landing.index(
            "</script>", landing.index("var workflow_desc")
        )
    ]
    assert "<h1>The answer</h1>" in landing and "Best parameters" in landing
    assert "cylinder_lift.angle_of_repose [deg]" in landing and "data:image/png;base64," in landing
    assert "System Message" not in landing
    for name in (
        "objective_vs_evaluation",
        "objective_vs_time",
        "parameter_traces",
        "responses_vs_targets",
        "parallel_coordinates",
        "early_termination",
        "solution_space",
        "sensitivity",
        "objective_slices",
    ):
        assert (study / "plots" / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
    assert "<svg" in (study / "plots" / "evaluation_dag.svg").read_text()
    table = (study / "plots" / "best_point.csv").read_text()
    assert "cylinder_lift.angle_of_repose" in table and "objective" in table


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="needs Chromium (.ci/run installs it)")
@pytest.mark.slow
def test_the_report_opens_with_the_answer_in_a_browser(reported):
    """The report rendered by headless Chromium (its JavaScript builds the page): what
    a user sees first."""
    tmp_path, proc = reported
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = (tmp_path / "results/unit/report.html").as_uri()
    shown = chromium_at((1400, 900), tmp_path, "--dump-dom", report).stdout
    assert (
        "The answer" in shown
        and "Best parameters" in shown
        and "Responses against the targets" in shown
    )
    assert shown.index("The answer") < shown.index("How it was calibrated")
    assert "System Message" not in shown


#: Screens the report's landing page must open on with the answer in view.
SCREENS = [(1366, 768), (1920, 1080)]

#: Appended to a copy of report.html: once Snakemake's scripts have drawn the landing page
#: (styled, its figures decoded), writes where the answer lies on the first screen, and where
#: the description's last element lies after scrolling the page's box to its end.
LANDING_PAGE_PROBE = """<script>
addEventListener("load", function measure() {
  const heading = [...document.querySelectorAll("h1")].find(
    (h) => h.textContent.trim() === "The answer");
  let box = heading && heading.parentElement;
  while (box && !["auto", "scroll"].includes(getComputedStyle(box).overflowY)) {
    box = box.parentElement;
  }
  const description = heading && heading.closest(".prose");
  if (!box || ![...description.querySelectorAll("img")].every((img) => img.complete)) {
    return setTimeout(measure, 100);
  }
  const place = (element) => {
    const r = element.getBoundingClientRect();
    return {top: r.top, bottom: r.bottom};
  };
  let last = description;
  while (last.lastElementChild) last = last.lastElementChild;
  const seen = {
    viewport: [innerWidth, innerHeight],
    heading: place(heading),
    parameters: place(heading.parentElement.querySelector("table")),
  };
  box.scrollTop = box.scrollHeight;
  seen.end = place(last);
  const out = document.createElement("pre");
  out.id = "demcal-probe";
  out.textContent = JSON.stringify(seen);
  document.body.append(out);
});
</script>"""


def chromium_at(screen, tmp_path, *arguments):
    """Headless Chromium on a screen of ``screen`` (width, height) pixels, the page filling it."""
    width, height = screen
    return subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-quic",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={tmp_path / 'chromium'}",
            "--kiosk",
            f"--screen-info={{{width}x{height}}}",
            "--virtual-time-budget=10000",
            *arguments,
        ],
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )


@pytest.mark.skipif(CHROMIUM is None, reason="needs Chromium (.ci/run installs it)")
@pytest.mark.slow
@pytest.mark.parametrize("screen", SCREENS, ids=lambda screen: "x".join(map(str, screen)))
def test_the_report_shows_the_answer_on_its_first_screen(reported, screen, tmp_path):
    """Issue 36: Snakemake centres a page in its scrolling box, so a landing page taller than
    the window stuck out above the top, answer and all, where no scrolling reaches. The
    answer's heading and parameters must lie on the first screen, and the page's end must be
    reachable. Screenshots: in tmp_path, and copied to $DEMCAL_SCREENSHOTS when it is set."""
    workdir, proc = reported
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = workdir / "results/unit/report.html"
    probed = tmp_path / "probed.html"
    head, _, _ = report.read_text().rpartition("</body>")
    probed.write_text(head + LANDING_PAGE_PROBE + "</body></html>\n")
    shown = chromium_at(screen, tmp_path, "--dump-dom", probed.as_uri())
    found = re.search(r'<pre id="demcal-probe">(.*?)</pre>', shown.stdout, re.DOTALL)
    assert found, shown.stderr[-2000:]
    seen = json.loads(html.unescape(found.group(1)))
    width, height = screen
    assert seen["viewport"] == [width, height], f"Chromium ignored the screen size: {seen}"
    for part in ("heading", "parameters"):
        assert 0 <= seen[part]["top"] and seen[part]["bottom"] <= height, (part, seen)
    assert 0 <= seen["end"]["top"] and seen["end"]["bottom"] <= height, seen

    shot = tmp_path / f"report-{width}x{height}.png"
    drawn = chromium_at(screen, tmp_path, f"--screenshot={shot}", report.as_uri())
    assert shot.is_file(), drawn.stderr[-2000:]
    if keep := os.environ.get("DEMCAL_SCREENSHOTS"):
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, keep)


def test_dag_drawing_without_graphviz_says_how_to_get_it(monkeypatch):
    import demcal.reporting.figures

    monkeypatch.setattr(demcal.reporting.figures.shutil, "which", lambda name: None)
    svg = demcal.reporting.figures.dag_svg('digraph { simulate -> "extract" }')
    assert svg.startswith("<svg") and "apt install graphviz" in svg
    assert "simulate -&gt; &quot;extract&quot;" in svg


@pytest.mark.slow
def test_joint_study_runs_every_scene_replicate_in_parallel(tmp_path, analytic_config):
    """Two scenes x 2 replicates in one evaluation: four simulate/extract pairs, two at a time."""
    evaldir, proc = joint_evaluation(tmp_path, analytic_config, 1.5)
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    assert record["status"] == "ok"
    assert set(record["responses"]) == {
        "cylinder_lift.angle_of_repose",
        "cylinder_lift.bulk_density",
        "calibration_device.mass_flow",
        "calibration_device.slide_time",
    }
    for scene in ("cylinder_lift", "calibration_device"):
        for rep in (0, 1):
            sim = json.loads((evaldir / scene / f"rep{rep}" / "simulation.json").read_text())
            assert sim["responses_needed"] == (
                ["bulk_density", "angle_of_repose"]
                if scene == "cylinder_lift"
                else ["mass_flow", "slide_time"]
            )
    spans = list(simulation_spans(evaldir).values())
    # two at a time with 2 cores: some ran side by side, never three at once (which pairs
    # run together is the scheduler's choice between ready simulate and extract jobs)
    at_once = [sum(start <= moment < end for start, end in spans) for moment, _ in spans]
    assert max(at_once) == 2, spans


@pytest.mark.slow
def test_rayleigh_cost_is_added_to_the_objective(tmp_path, analytic_config):
    """Rackl & Hanley eq. 10 at the stiffest E of the bounds: the cost is W^2 on top of eq. 3.3."""
    config = {
        **analytic_config,
        "rayleigh_cost_weight": 0.5,
        "parameters": {
            **analytic_config["parameters"],
            "youngs_modulus": {"lower": 5.0e6, "upper": 5.0e8},
        },
    }
    evaldir = write_point(
        tmp_path,
        "unit",
        "e1",
        sliding_friction_pp=0.4,
        rolling_friction_pp=0.1,
        youngs_modulus=5.0e8,
    )
    proc = run_snakemake(tmp_path, config, "results/unit/evals/e1/objective.json")
    assert proc.returncode == 0, proc.stderr[-3000:]
    record = json.loads((evaldir / "objective.json").read_text())
    errors = sum(e * e for e in record["relative_errors"].values())
    assert record["timestep_cost"] == pytest.approx(0.25)
    assert record["objective"] == pytest.approx(errors + 0.25)


def readme_run(folder, configfile: str) -> subprocess.CompletedProcess:
    """The README's command (snakemake --profile profiles/local) on a study file in ``folder``."""
    return subprocess.run(
        [
            *SNAKEMAKE,
            "-s",
            str(ROOT / "Snakefile"),
            "--profile",
            str(ROOT / "profiles/local"),
            f"--configfile={configfile}",
        ],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
        stdin=subprocess.DEVNULL,
    )


@pytest.mark.slow
def test_the_readme_analytic_command_prints_a_short_terminal_story(tmp_path):
    """The README's analytic command (the example shortened to 8 quick evaluations): besides
    the progress lines, at most 30 lines, ending with the answer and where the report is."""
    example = yaml.safe_load((ROOT / "config/examples/analytic.yaml").read_text())
    example["engine"]["duration"] = 0.3
    example["optimizer"]["max_evaluations"] = 8
    (tmp_path / "analytic.yaml").write_text(yaml.safe_dump(example))
    proc = readme_run(tmp_path, "analytic.yaml")
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = [
        line for line in (proc.stdout + proc.stderr).splitlines() if not line.startswith("[demcal ")
    ]
    assert len(lines) <= 30, "\n".join(lines)
    text = "\n".join(lines)
    assert (
        "finished: evaluation budget reached (8 of 8)" in text
        and "cylinder_lift.bulk_density [kg/m^3]" in text
    )
    assert "report: results/analytic-demo/report.html" in text


@pytest.mark.slow
def test_when_every_evaluation_fails_the_run_ends_with_the_commonest_reason(tmp_path):
    """No Snakemake 'missing output / filesystem latency' story: the calibration ends, says that
    nothing succeeded and why, and still makes its report."""
    example = yaml.safe_load((ROOT / "config/examples/analytic.yaml").read_text())
    example["engine"].update(
        duration=0.2,
        failures=[{"when": {"sliding_friction_pp": [0.0, 1.0]}, "reason": "solver diverged"}],
    )
    example["optimizer"]["max_evaluations"] = 3
    example["calibration"] = {"retries": 0, "poll_seconds": 0.3}
    (tmp_path / "failing.yaml").write_text(yaml.safe_dump(example))
    proc = readme_run(tmp_path, "failing.yaml")
    assert proc.returncode == 0, proc.stderr[-3000:]
    text = proc.stdout + proc.stderr
    assert re.search(
        r"no evaluation succeeded, most often: "
        r"'cylinder_lift rep0: solver diverged[^']*' \(3 of 3\)",
        text,
    ), text
    assert "latency" not in text and "Traceback" not in text and "Exception" not in text
    assert (tmp_path / "results/analytic-demo/report.html").exists()


@pytest.mark.slow
def test_the_readme_route_on_a_reuse_study_ends_with_exit_0_and_a_report(tmp_path):
    """A second study with ``reuse: archive`` through the README's command: its e0000 is a point
    of the first study, with no folder here, and the report (its DAG drawing included) is made
    from the first evaluation it simulated itself (issue 35, item 2)."""
    example = yaml.safe_load((ROOT / "config/examples/analytic.yaml").read_text())
    example["engine"]["duration"] = 0.3
    example["optimizer"]["max_evaluations"] = 4
    (tmp_path / "first.yaml").write_text(yaml.safe_dump(example))
    assert readme_run(tmp_path, "first.yaml").returncode == 0
    second = {**example, "study": "second", "reuse": "archive"}
    second["optimizer"] = {**example["optimizer"], "max_evaluations": 2}
    (tmp_path / "second.yaml").write_text(yaml.safe_dump(second))
    proc = readme_run(tmp_path, "second.yaml")
    assert proc.returncode == 0, proc.stderr[-3000:]
    study = tmp_path / "results" / "second"
    reused = json.loads((study / "reused.json").read_text())["points"]
    assert len(reused) == 4 and not (study / "evals" / "e0000" / "params.json").exists()
    assert "report: results/second/report.html" in proc.stdout
    assert (study / "report.html").stat().st_size > 100_000
    assert "simulate" in (study / "plots" / "evaluation_dag.svg").read_text()
