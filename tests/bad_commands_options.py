"""Options out of their range, a parameter given twice, argparse's own usage errors and a
damaged calibration under a design study's ``material:`` (issue 35, items 5 and 6): each one
line naming the option or the field, and the range or what is allowed."""

from __future__ import annotations

import json
from pathlib import Path

from bad_commands import SMALL_STUDY, STUDY_FILE, BadCommand, finished_study, write_study

#: How a refused option's line ends: the command's own help.
HELP = r"; 'demcal {} --help' shows the options$"
#: The largest row number of the archive, as the messages give it.
LARGEST_ROW = "9223372036854775807"
#: The design study that takes its material from the finished small calibration.
DESIGN_FILE = "design.yaml"


def out_of_range(command: str, option: str, value: str, low: int | str, high: int | str) -> str:
    """The line of a whole-number option refused by the parser."""
    return (
        rf"^demcal: {command}: {option}: '{value}' is not a whole number from {low} to {high}"
        + (HELP.format(command))
    )


def design_with_damaged_material(folder: Path) -> None:
    """The finished small calibration with text for a number in its best.json, and a design
    study that takes its material from it."""
    finished_study(folder)
    best = folder / "results" / "small" / "best.json"
    record = json.loads(best.read_text())
    record["parameters"]["sliding_friction_pp"] = "0.7 (rounded)"
    best.write_text(json.dumps(record))
    design = {
        **{key: value for key, value in SMALL_STUDY.items() if key != "fixed"},
        "study": "design",
        "material": "small",
        "parameters": {"sliding_friction_pw": {"lower": 0.2, "upper": 0.8}},
    }
    write_study(folder, design, DESIGN_FILE)


PAIR = ("sliding_friction_pp=0.3", "sliding_friction_pp=0.4")

CASES = [
    BadCommand(
        "archive_show_a_23_digit_number",
        ("archive", "show", "12345678901234567890123"),
        rf"archive show: '12345678901234567890123' is not a whole number from 1 to {LARGEST_ROW}"
        r" \(a simulation's number\); or give at least 6 characters of its key",
        finished_study,
    ),
    BadCommand(
        "archive_show_superscript_digits",
        ("archive", "show", "²²²²²²"),
        rf"archive show: '²²²²²²' is not a whole number from 1 to {LARGEST_ROW}",
        finished_study,
    ),
    BadCommand(
        "archive_list_limit_1e20",
        ("archive", "list", "--limit", "1e20"),
        out_of_range("archive list", "--limit", "1e20", 1, LARGEST_ROW),
        finished_study,
    ),
    BadCommand(
        "archive_list_limit_beyond_64_bits",
        ("archive", "list", "--limit", "100000000000000000000"),
        out_of_range("archive list", "--limit", "100000000000000000000", 1, LARGEST_ROW),
        finished_study,
    ),
    BadCommand(
        "metamodel_build_seed_negative",
        ("metamodel", "build", STUDY_FILE, "--seed", "-1"),
        out_of_range("metamodel", "--seed", "-1", 0, 2**32 - 1),
        finished_study,
    ),
    BadCommand(
        "metamodel_build_seed_beyond_32_bits",
        ("metamodel", "build", STUDY_FILE, "--seed", str(2**32)),
        out_of_range("metamodel", "--seed", str(2**32), 0, 2**32 - 1),
        finished_study,
    ),
    BadCommand(
        "calibrate_metamodel_a_billion_starts",
        ("calibrate-metamodel", STUDY_FILE, "--domain", STUDY_FILE, "--starts", "1000000000"),
        out_of_range("calibrate-metamodel", "--starts", "1000000000", 1, 1024),
        finished_study,
    ),
    BadCommand(
        "calibrate_metamodel_a_billion_validations",
        ("calibrate-metamodel", STUDY_FILE, "--domain", STUDY_FILE, "--validate", "1000000000"),
        out_of_range("calibrate-metamodel", "--validate", "1000000000", 0, 1000),
        finished_study,
    ),
    BadCommand(
        "solutions_samples_1e10",
        ("solutions", "small", "--samples", "1e10"),
        out_of_range("solutions", "--samples", "1e10", 64, 2**20),
        finished_study,
    ),
    BadCommand(
        "solutions_ten_billion_samples",
        ("solutions", "small", "--samples", "10000000000"),
        out_of_range("solutions", "--samples", "10000000000", 64, 2**20),
        finished_study,
    ),
    BadCommand(
        "solutions_explore_a_billion",
        ("solutions", "small", "--explore", "1000000000"),
        out_of_range("solutions", "--explore", "1000000000", 1, 1000),
        finished_study,
    ),
    BadCommand(
        "solutions_tolerance_infinite",
        ("solutions", "small", "--tolerance", "inf"),
        r"^demcal: --tolerance inf: give a number of standard deviations above 0$",
        finished_study,
    ),
    BadCommand(
        "solutions_point_a_parameter_twice",
        ("solutions", "small", "--point", *PAIR, "rolling_friction_pp=0.1"),
        r"--point sliding_friction_pp=0.4: sliding_friction_pp is given twice "
        r"\(sliding_friction_pp=0.3 before\); give each free parameter once",
        finished_study,
    ),
    BadCommand(
        "add_point_a_parameter_twice",
        ("add-point", "small", *PAIR, "rolling_friction_pp=0.1"),
        r"add-point sliding_friction_pp=0.4: sliding_friction_pp is given twice",
        finished_study,
    ),
    BadCommand(
        "convergence_no_workers",
        ("convergence", STUDY_FILE, "--workers", "0"),
        out_of_range("convergence", "--workers", "0", 1, 1024),
        write_study,
    ),
    BadCommand(
        "convergence_no_seeds",
        ("convergence", STUDY_FILE, "--seeds", "0"),
        out_of_range("convergence", "--seeds", "0", 1, 100),
        write_study,
    ),
    BadCommand(
        "usage_an_unknown_command",
        ("calibrate", STUDY_FILE),
        r"^demcal: command: invalid choice: 'calibrate' \(choose from 'check', 'run', .*\)"
        r"; 'demcal --help' shows the options$",
    ),
    BadCommand(
        "usage_an_option_of_another_command",
        ("status", STUDY_FILE, "--every", "3"),
        r"^demcal: status: unrecognized arguments: --every 3" + HELP.format("status"),
        write_study,
    ),
    BadCommand(
        "usage_a_required_option_missing",
        ("calibrate-metamodel", STUDY_FILE),
        r"^demcal: calibrate-metamodel: the following arguments are required: --domain"
        + HELP.format("calibrate-metamodel"),
        write_study,
    ),
    BadCommand(
        "usage_a_number_that_is_not_one",
        ("solutions", "small", "--tolerance", "two"),
        r"^demcal: solutions: --tolerance: invalid float value: 'two'" + HELP.format("solutions"),
        finished_study,
    ),
    BadCommand(
        "design_material_best_json_text_for_a_number",
        ("run", DESIGN_FILE),
        r"material: results/small/best.json: parameters.sliding_friction_pp is "
        r"'0.7 \(rounded\)', not a number",
        design_with_damaged_material,
    ),
]
