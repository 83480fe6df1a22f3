"""A scene script's fingerprint (part of what identifies a simulator for reuse) moves with its
code, not with its types, docstrings, comments or layout."""

from __future__ import annotations

from demcal.scenes.base import code_digest

PLAIN = """
import math

def angle(state, settings):
    return math.degrees(math.atan(state["height"] / settings["radius"]))

class Heap:
    radius = 0.05
"""

DRESSED = '''
"""The angle of a heap."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np


def angle(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    """Its slope in degrees."""
    # rise over run
    return math.degrees(
        math.atan(state["height"] / settings["radius"])
    )


class Heap:
    """A heap."""

    radius = 0.05  # m
'''


def digest(tmp_path, name: str, text: str) -> str:
    path = tmp_path / f"{name}.py"
    path.write_text(text)
    return code_digest(path)


def test_types_docstrings_comments_and_layout_leave_the_fingerprint(tmp_path):
    assert digest(tmp_path, "plain", PLAIN) == digest(tmp_path, "dressed", DRESSED)


def test_a_changed_number_or_a_new_field_moves_it(tmp_path):
    plain = digest(tmp_path, "plain", PLAIN)
    assert digest(tmp_path, "number", PLAIN.replace("0.05", "0.06")) != plain
    assert digest(tmp_path, "call", PLAIN.replace("math.atan(", "math.atan2(1, ")) != plain
    field = PLAIN.replace("    radius = 0.05", "    radius = 0.05\n    height: float")
    assert digest(tmp_path, "field", field) != plain


def test_a_scene_script_is_every_module_of_its_package_but_other_engines_drivers():
    """The drum's LAMMPS driver reads its speed from regime.py: an edit there makes another
    simulator too; the analytic stand-in and another engine's driver do not count."""
    from pathlib import Path

    from demcal.scenes import SCENES

    def digests(scene: str, *files: str) -> list[str]:
        folder = Path(__file__).resolve().parents[2] / "demcal" / "scenes" / scene
        return sorted(code_digest(folder / file) for file in files)

    drum = SCENES.load("rotating_drum")
    assert drum.script_digests("lammps") == digests(
        "rotating_drum", "__init__.py", "lammps.py", "regime.py"
    )
    assert drum.script_digests("analytic") == digests(
        "rotating_drum", "__init__.py", "analytic.py", "regime.py"
    )
    lift = SCENES.load("cylinder_lift")
    assert lift.script_digests("liggghts") == digests("cylinder_lift", "__init__.py", "liggghts.py")
