"""Where demcal finds its workflow files: the Snakefile, rules, scripts, schema and profiles.

In a source checkout (``pip install -e .``) they are the checkout's own
``workflow/`` (with its rules), ``scripts/`` (the job scripts) and ``profiles/``; an installed
wheel carries the same files inside the package (``demcal/project/``, see setup.py). One root
serves both, found once here.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _project_root() -> Path:
    for root in (_PACKAGE.parent, _PACKAGE / "project"):
        if (root / "workflow" / "Snakefile").is_file():
            return root
    raise RuntimeError(
        f"demcal's workflow files are missing (looked in {_PACKAGE.parent} "
        f"and {_PACKAGE / 'project'}); reinstall demcal"
    )


PROJECT_ROOT = _project_root()
WORKFLOW_DIR = PROJECT_ROOT / "workflow"
#: The workflow every demcal command and child Snakemake runs.
SNAKEFILE = WORKFLOW_DIR / "Snakefile"
SCHEMA_PATH = WORKFLOW_DIR / "schemas" / "config.schema.yaml"
PROFILES_DIR = PROJECT_ROOT / "profiles"
#: The study file a command or Snakemake reads when given none; unlike the paths
#: above, relative to the folder it runs in (the user's project, not demcal's).
DEFAULT_CONFIG = "config/config.yaml"
