"""What softening Young's modulus does to each lab test's responses, on LAMMPS.

    python benchmarks/softening.py [--modulus 5e7] [--seeds 2] [--jobs 1]

Every lab-test example (cylinder lift, calibration device, shear box, rotating drum) holds
Young's modulus at a softened 5e6 Pa for a larger time step. This runs each at its noise
point (the point of its ``scene_noise`` file at 5e6 Pa, whose seeds it repeats) with the
modulus raised to ``--modulus`` through ``benchmarks/scene_noise.py``, and prints and writes
benchmarks/results/softening.md: each response's mean at both moduli, the change and the
change in seed standard deviations (over all of the noise file's seeds), with the CPU per
simulation. A scene whose stiff noise file exists already is not simulated again.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

from demcal.scenes import SCENES

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
#: (example, its noise file at the softened modulus).
EXAMPLES = {
    "config/config.yaml": "noise_quickstart_cylinder_lift.json",
    "config/examples/calibration_device.yaml": "noise_device_calibration_device_truth.json",
    "config/examples/shear_box.yaml": "noise_shear-box_shear_box.json",
    "config/examples/rotating_drum.yaml": "noise_rotating-drum_rotating_drum.json",
}


def stiffened(example: str, modulus: float, folder: Path) -> Path:
    """The example's study file with Young's modulus fixed at ``modulus`` under a new name."""
    study = yaml.safe_load((ROOT / example).read_text())
    study["study"] = f"{study['study']}-stiff"
    study["fixed"]["youngs_modulus"] = modulus
    path = folder / f"{study['study']}.yaml"
    path.write_text(yaml.safe_dump(study))
    return path


def ok_runs(path: Path) -> tuple[dict, list[dict]]:
    data = json.loads(path.read_text())
    return data, [r for r in data["runs"] if r["status"] == "ok"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modulus", type=float, default=5.0e7)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    lines = [
        f"# Young's modulus 5e6 Pa (the examples' softened value) against {args.modulus:g} Pa",
        "",
        f"Command: `python benchmarks/softening.py --modulus {args.modulus:g} --seeds "
        f"{args.seeds}`; the same seeds at both moduli (the first {args.seeds} of the noise "
        f"file's).",
        "",
        "| scene | response | 5e6 Pa | stiff | change | in seed sd | CPU s (5e6 → stiff) |",
        "|---|---|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as folder:
        for example, noise in EXAMPLES.items():
            soft_data, soft = ok_runs(RESULTS / noise)
            config = stiffened(example, args.modulus, Path(folder))
            point = [f"{name}={value}" for name, value in soft_data["point"].items()]
            tag = f"stiff_{args.modulus:g}"
            study = yaml.safe_load(config.read_text())
            # Noise files older than their "scene" field are of the study's first scene.
            scene = soft_data.get("scene") or next(iter(study["scenes"]))
            stiff_file = RESULTS / f"noise_{study['study']}_{scene}_{tag}.json"
            if not stiff_file.is_file():
                subprocess.run(
                    [sys.executable, str(ROOT / "benchmarks" / "scene_noise.py"), str(config),
                     "--scene", scene, "--seeds", str(args.seeds), "--jobs",
                     str(args.jobs), "--point", *point, "--tag", tag],
                    check=True,
                )  # fmt: skip
            _, stiff = ok_runs(stiff_file)
            declared = SCENES.load(scene).responses
            responses = [name for name in declared if name in stiff[0] and name in soft[0]]
            noise = {name: statistics.stdev(r[name] for r in soft) for name in responses
                     if len(soft) > 1}  # fmt: skip
            soft = soft[: args.seeds]
            cpu = f"{statistics.fmean(r['cpu_s'] for r in soft):.0f} → " + (
                f"{statistics.fmean(r['cpu_s'] for r in stiff):.0f}"
            )
            for name in responses:
                before = statistics.fmean(r[name] for r in soft)
                after = statistics.fmean(r[name] for r in stiff)
                sd = noise.get(name, 0.0)
                in_sd = f"{(after - before) / sd:+.1f}" if sd > 0 else "—"
                lines.append(
                    f"| {scene} | {name} | {before:.4g} | {after:.4g} | "
                    f"{100 * (after - before) / before:+.1f} % | {in_sd} | {cpu} |"
                )
    (RESULTS / "softening.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
