"""Packaging beyond pyproject.toml: the workflow files travel inside the package.

The Snakefile, rules, job scripts, report captions, schema and profiles live
at the top of the source tree (where Snakemake users expect them); a wheel
carries them as ``demcal/project/{workflow,scripts,profiles}``, where
``demcal.resources`` finds them when there is no source tree.
"""

from setuptools import find_packages, setup

PROJECT_FILES = {
    "demcal.project.workflow": (
        "workflow",
        [
            "Snakefile",
            "rules/*.smk",
            "report/*.rst",
            "report/*.css",
            "schemas/*.yaml",
        ],
    ),
    "demcal.project.scripts": ("scripts", ["*.py"]),
    "demcal.project.profiles": ("profiles", ["*/config.yaml"]),
}

setup(
    # snakemake_logger_plugin_demcal: the profiles' logger (Snakemake finds loggers by that name)
    packages=find_packages(include=["demcal*", "snakemake_logger_plugin_demcal"])
    + list(PROJECT_FILES),
    package_dir={name: folder for name, (folder, _) in PROJECT_FILES.items()},
    package_data={name: patterns for name, (_, patterns) in PROJECT_FILES.items()},
)
