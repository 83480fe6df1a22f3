"""The study a command works on, given as its YAML file or, once it has run, its name."""

from __future__ import annotations

from pathlib import Path

from demcal.cli.options import quoted
from demcal.errors import ConfigError
from demcal.results.layout import RESULTS, StudyFiles
from demcal.study.config import load_study_file
from demcal.study.model import Study, load_frozen


def has_run(argument: str) -> bool:
    """Whether ``argument`` is the name of a study that has run (its results/<name>/study.json),
    not a file."""
    try:
        return (
            not Path(argument).is_file()
            and "/" not in argument
            and StudyFiles.of(argument).study.is_file()
        )
    except OSError as exc:  # a name too long for the file system
        raise ConfigError(
            f"{quoted(argument)}: {exc.strerror or exc}; give the study's YAML file or its name"
        ) from None


def study_source(argument: str) -> str:
    """The file that holds the study ``argument`` names: the frozen results/<name>/study.json
    of a study that has run, else ``argument``, its YAML file."""
    if has_run(argument):
        return str(StudyFiles.of(argument).study)
    if not Path(argument).exists() and "/" not in argument and "." not in argument:  # a name
        raise ConfigError(
            f"{quoted(argument)}: no such study file, and no study of that name in {RESULTS}/ "
            f"(a study is known by its name once it has run)"
        )
    return argument


def study_of(argument: str) -> Study:
    """The study named by its YAML file or its name: as it ran (its results/<name>/study.json)
    once it has run, else as the YAML file gives it."""
    source = study_source(argument)
    if source != argument:
        return load_frozen(source)
    study = load_study_file(argument, check_engine=False)
    return load_frozen(study.files.study) if study.files.study.is_file() else study


def study_yaml(argument: str, command: str) -> str:
    """``argument`` for a command that needs the study's YAML file; the name of a study that
    has run is refused, saying so."""
    if has_run(argument):
        raise ConfigError(
            f"{command} needs the study's YAML file: {quoted(argument)} is the name of a study "
            f"that has run ({StudyFiles.of(argument).dir}/), not a file; give the YAML file it "
            f"ran from"
        )
    return argument
