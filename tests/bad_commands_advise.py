"""Bad uses of ``demcal advise`` (issue 39, item 4): a study that has not finished, one with no
likely solution set, a test demcal does not simulate (or that is no lab test, or that the
study has already), too few parameter sets, and bad spreads and parameter names. Each is
refused in one line, before any simulation."""

from __future__ import annotations

from pathlib import Path

from bad_commands import STUDY_FILE, BadCommand, finished_study, write_study


def unfinished(folder: Path) -> None:
    write_study(folder)


CASES = [
    BadCommand(
        "advise on a study that has not run",
        ("advise", STUDY_FILE),
        r"study 'small' has not finished; run it to the end first",
        unfinished,
    ),
    BadCommand(
        "advise on a study with no likely solution set",
        ("advise", STUDY_FILE),
        r"no likely solution set to narrow",
        finished_study,
    ),
    BadCommand(
        "advise with a test demcal does not simulate",
        ("advise", STUDY_FILE, "--tests", "ring_shear_cell"),
        r"--tests ring_shear_cell: not a test demcal simulates; lab tests: .*uniaxial_compression",
        unfinished,
    ),
    BadCommand(
        "advise with a design case as a test",
        ("advise", STUDY_FILE, "--tests", "transfer_chute"),
        r"--tests transfer_chute: a design case, not a lab test",
        unfinished,
    ),
    BadCommand(
        "advise with a test the study has",
        ("advise", STUDY_FILE, "--tests", "cylinder_lift"),
        r"--tests cylinder_lift: a test of the study already",
        unfinished,
    ),
    BadCommand(
        "advise with fewer sets than the free parameters plus one",
        ("advise", STUDY_FILE, "--points", "2"),
        r"--points 2: give at least 3 \(the 2 free parameters plus one\)",
        unfinished,
    ),
    BadCommand(
        "advise with a spread of a response no candidate has",
        ("advise", STUDY_FILE, "--spread", "shear_box.porosity=1"),
        r"--spread shear_box.porosity=1: give SCENE.RESPONSE=SD for a candidate response",
        unfinished,
    ),
    BadCommand(
        "advise with a negative spread",
        ("advise", STUDY_FILE, "--spread", "shear_box.bulk_density=-5"),
        r"--spread shear_box.bulk_density=-5: the spread must be a number above 0",
        unfinished,
    ),
    BadCommand(
        "advise with a spread that is not a number",
        ("advise", STUDY_FILE, "--spread", "shear_box.bulk_density=nan"),
        r"the spread must be a number above 0",
        unfinished,
    ),
]
