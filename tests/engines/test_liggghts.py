"""The LIGGGHTS engine: input generation always; real runs when Debian's ``liggghts`` is installed.

The real runs use a tiny cylinder lift (200 spheres of 3 mm, a few seconds):
plausible responses, an oversized time step ending as a failure with its
reason, and STOP honoured.
"""

import math
import shutil
import threading
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import run_and_extract

from demcal.engines import liggghts
from demcal.engines.base import RunMonitor, SimulationJob
from demcal.engines.liggghts import LiggghtsEngine, read_dump, write_ascii_stl
from demcal.errors import ConfigError, SimulationFailed
from demcal.physics.catalogue import CATALOG
from demcal.physics.timestep import rayleigh_time
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.cylinder_lift import TINY_SETTINGS
from demcal.scenes.cylinder_lift.liggghts import (
    CylinderLiftInput,
    cylinder_triangles,
    place_spheres,
    polygon_segments,
)
from demcal.study.config import load_study

SCENE = SCENES.load("cylinder_lift")
needs_liggghts = pytest.mark.skipif(
    shutil.which(liggghts.BINARY) is None,
    reason="LIGGGHTS not installed (apt-get install liggghts)",
)


def tiny_job(
    tmp_path, fraction=0.25, responses=("bulk_density", "angle_of_repose"), settings=None, **params
):
    values = {name: spec.default for name, spec in CATALOG.items()}
    values.update(params)
    return SimulationJob(
        scene="cylinder_lift",
        parameters=values,
        settings=SCENE.resolve_settings({**TINY_SETTINGS, **(settings or {})}, "s"),
        seed=7,
        responses=list(responses),
        timestep_fraction=fraction,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )


# -- no binary needed ----------------------------------------------------------


def read_stl(path):
    """Normals (n, 3) and vertices (n, 3, 3) of an ASCII STL file."""
    normals, vertices = [], []
    for line in path.read_text().splitlines():
        words = line.split()
        if words[:2] == ["facet", "normal"]:
            normals.append([float(w) for w in words[2:]])
        elif words[:1] == ["vertex"]:
            vertices.append([float(w) for w in words[1:]])
    return np.array(normals), np.array(vertices).reshape(-1, 3, 3)


def test_stl_cylinder_is_closed_around_its_axis_and_faces_it(tmp_path):
    segments, rows, radius = 24, 3, 0.01
    write_ascii_stl(tmp_path / "c.stl", "c", cylinder_triangles(radius, 0.0, 0.02, segments, rows))
    normals, vertices = read_stl(tmp_path / "c.stl")
    assert len(normals) == len(vertices) == 2 * segments * rows
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert np.allclose(normals[:, 2], 0.0)
    centroids = vertices.mean(axis=1)
    assert (np.sum(normals[:, :2] * centroids[:, :2], axis=1) < 0.0).all()  # towards the axis
    assert np.allclose(np.hypot(vertices[..., 0], vertices[..., 1]), radius)
    edges = {}
    for tri in np.round(vertices, 12):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            key = tuple(sorted((tuple(tri[a]), tuple(tri[b]))))
            edges[key] = edges.get(key, 0) + 1
    open_edges = [e for e, n in edges.items() if n == 1]
    assert set(edges.values()) == {1, 2}
    assert len(open_edges) == 2 * segments  # only the two rims are open
    assert all(e[0][2] == e[1][2] in (0.0, 0.02) for e in open_edges)


def test_polygon_stays_within_tolerance_of_the_circle():
    radius, tolerance = 12.5e-3, 2.0e-5
    n = polygon_segments(radius, tolerance)
    assert radius * (1.0 - math.cos(math.pi / n)) <= tolerance
    assert radius * (1.0 - math.cos(math.pi / (n - 1))) > tolerance


def test_script_time_step_walls_and_contact_model(tmp_path):
    job = tiny_job(
        tmp_path,
        fraction=0.2,
        sliding_friction_pp=0.45,
        sliding_friction_pw=0.6,
        rolling_friction_pp=0.16,
        rolling_friction_pw=0.07,
    )
    case = CylinderLiftInput(job)
    lines = case.script().splitlines()
    p = job.parameters
    dt = 0.2 * rayleigh_time(
        TINY_SETTINGS["d50"] / 2, p["particle_density"], p["youngs_modulus"], p["poisson_ratio"]
    )
    assert f"timestep {dt:.10g}" in lines
    model = "model hertz tangential history rolling_friction epsd"
    assert f"pair_style gran {model}" in lines
    assert f"fix floor all wall/gran {model} primitive type 2 zplane 0.0" in lines
    assert "fix tube all mesh/surface file tube.stl type 2" in lines
    assert "fix ring all mesh/surface file ring.stl type 2" in lines
    assert f"fix walls all wall/gran {model} mesh n_meshes 2 meshes tube ring" in lines
    assert (
        "fix m4 all property/global coefficientFriction peratomtypepair 2 0.45 0.6 0.6 0.6" in lines
    )
    assert (
        "fix m5 all property/global coefficientRollingFriction peratomtypepair 2 "
        "0.16 0.07 0.07 0.07" in lines
    )
    assert "fix lift all move/mesh mesh tube linear 0 0 0.05" in lines
    assert (
        lines.index("thermo_modify lost error norm no")
        < lines.index("write_dump all custom fill.dump id x y z radius mass")
        < lines.index("thermo_modify lost ignore norm no")
    )  # losses are errors until the lift
    assert "write_dump all custom heap.dump id x y z radius mass" in lines


def test_script_without_ring_or_heap(tmp_path):
    job = tiny_job(tmp_path, responses=("bulk_density",), settings={"ring_height": 0.0})
    case = CylinderLiftInput(job)
    case.write(tmp_path)
    text = (tmp_path / "in.liggghts").read_text()
    assert "mesh n_meshes 1 meshes tube\n" in text and "ring.stl" not in text
    assert not (tmp_path / "ring.stl").exists()
    assert "move/mesh" not in text and "heap.dump" not in text
    data = (tmp_path / "particles.data").read_text().splitlines()
    assert "200 atoms" in data and "2 atom types" in data


def test_placement_keeps_spheres_apart_inside_the_cylinder():
    rng = np.random.default_rng(1)
    x = place_spheres(np.full(300, 2e-3), 0.01, 0.0, 0.03, 2.002e-3, rng)
    gaps = np.linalg.norm(x[:, None] - x[None], axis=2) + np.eye(len(x))
    assert gaps.min() >= 2.002e-3
    assert (np.hypot(x[:, 0], x[:, 1]) <= 0.01).all()
    assert ((x[:, 2] >= 0.0) & (x[:, 2] <= 0.03)).all()
    with pytest.raises(SimulationFailed, match="could place only"):
        place_spheres(np.full(300, 2e-3), 0.005, 0.0, 0.005, 2.002e-3, rng)


def test_read_dump_sorts_by_id(tmp_path):
    (tmp_path / "d").write_text(
        "ITEM: TIMESTEP\n5\nITEM: NUMBER OF ATOMS\n2\n"
        "ITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\n"
        "ITEM: ATOMS id x y z radius mass\n"
        "2 0.2 0 0 0.001 1e-5\n1 0.1 0 0 0.002 2e-5\n"
    )
    data = read_dump(tmp_path / "d")
    assert data["id"].tolist() == [1.0, 2.0]
    assert data["radius"].tolist() == [0.002, 0.001]


def test_check_names_the_install_and_refuses_settings_and_other_scenes(monkeypatch):
    monkeypatch.setattr(liggghts.shutil, "which", lambda name: None)
    with pytest.raises(ConfigError, match="apt-get install liggghts"):
        LiggghtsEngine().check([SCENE])
    monkeypatch.setattr(liggghts.shutil, "which", lambda name: "/usr/bin/" + name)
    with pytest.raises(ConfigError, match="takes no settings"):
        LiggghtsEngine({"binary": "x"}).check([SCENE])
    with pytest.raises(ConfigError, match="no LIGGGHTS driver for scene 'shear_box'"):
        LiggghtsEngine().check([SCENE, SCENES.load("shear_box")])
    LiggghtsEngine().check([SCENE])


def test_run_uses_the_driver_it_is_given(tmp_path, monkeypatch):
    monkeypatch.setattr(liggghts.shutil, "which", lambda name: "/usr/bin/" + name)
    job = tiny_job(tmp_path)
    result = LiggghtsEngine().run(job, RunMonitor(job), None)
    assert result.status == Status.FAILED and "no driver for scene 'cylinder_lift'" in result.reason

    def refuse(workdir):
        raise SimulationFailed(f"fake driver asked to write into {workdir.name}")

    def fake_driver(job):
        return SimpleNamespace(dumps={}, write=refuse)

    result = LiggghtsEngine().run(job, RunMonitor(job), fake_driver)
    assert result.status == Status.FAILED
    assert result.reason == f"fake driver asked to write into {tmp_path.name}"


@pytest.mark.parametrize(
    "body, expected",
    [
        (
            'echo "ERROR: Lost atoms: original 200 current 199 (src/thermo.cpp:445)" '
            "> liggghts.log\nexit 1",
            "LIGGGHTS error: Lost atoms: original 200 current 199",
        ),
        ("kill -SEGV $$", "LIGGGHTS died from SIGSEGV"),
        (
            'echo "demcal-unstable fill 3.5" > liggghts.log',
            "unstable during fill: kinetic energy 3.5 J",
        ),
        (
            'echo "demcal-progress fill 1 30 0.1" > liggghts.log',
            "stopped before the end of its script",
        ),
    ],
)
def test_failures_of_the_child_are_failed_results_with_reasons(
    tmp_path, monkeypatch, body, expected
):
    fake = tmp_path / "fake-liggghts"
    fake.write_text("#!/bin/sh\n" + body + "\n")
    fake.chmod(0o755)
    monkeypatch.setattr(liggghts, "BINARY", str(fake))
    work = tmp_path / "run"
    work.mkdir()
    job = tiny_job(work)
    result = LiggghtsEngine().run(job, RunMonitor(job), SCENE.driver("liggghts"))
    assert result.status == Status.FAILED
    assert expected in result.reason
    assert result.arrays == {}


def test_study_config_selects_the_engine(analytic_config):
    analytic_config["engine"] = {"name": "liggghts"}
    study = load_study(analytic_config, check_engine=False)
    assert isinstance(study.engine, LiggghtsEngine)
    analytic_config["engine"] = {"name": "liggghts", "binary": "/opt/x"}
    with pytest.raises(ConfigError, match="takes no settings"):
        load_study(analytic_config)


# -- the real binary ------------------------------------------------------------


def simulate(job):
    return run_and_extract(LiggghtsEngine(), job)


@needs_liggghts
def test_version_and_check():
    assert "3.8" in LiggghtsEngine().version()
    LiggghtsEngine().check([SCENE])


@needs_liggghts
def test_tiny_cylinder_lift_is_plausible(tmp_path):
    job = tiny_job(tmp_path)
    result, responses = simulate(job)
    assert result.status == Status.OK, result.reason
    solid_fraction = responses["bulk_density"] / job.parameters["particle_density"]
    assert 0.42 < solid_fraction < 0.66
    assert 5.0 < responses["angle_of_repose"] < 40.0
    assert result.measurements["fill_at_rest"] == 1.0
    assert result.measurements["lost_particles"] < 10
    assert result.cost["steps"] > 0 and result.cost["timestep_s"] == pytest.approx(
        0.25 * result.cost["rayleigh_time_s"]
    )
    rows = read_partial(job.partial_file)
    assert rows[-1]["progress"] == 1.0
    estimate = [r["value"] for r in rows if r["response"] == "bulk_density"]
    assert estimate == [pytest.approx(responses["bulk_density"])]


@needs_liggghts
def test_oversized_time_step_fails_with_reason(tmp_path):
    result, _ = simulate(tiny_job(tmp_path, fraction=5.0))
    assert result.status == Status.FAILED
    assert "Lost atoms" in result.reason or "unstable" in result.reason
    assert "5 T_R" in result.reason


@needs_liggghts
def test_stop_terminates_the_run(tmp_path):
    job = tiny_job(tmp_path, settings={"max_settle_time": 5.0, "lift_speed": 0.005})
    timer = threading.Timer(1.0, (tmp_path / "STOP").touch)
    timer.start()
    result, _ = simulate(job)
    timer.join()
    assert result.status == Status.TERMINATED and result.reason == "stop requested"
    assert result.cost["wall_s"] < 5.0
