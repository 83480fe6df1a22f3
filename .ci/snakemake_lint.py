"""``snakemake --lint`` on demcal's workflow; every lint fails the check but the waived ones.

Snakemake's linter cannot waive a lint in the workflow itself, and in
Snakemake 9 ``--lint json`` still prints text; so this runs ``--lint`` and
reads its text (blocks "Lints for <item>:" of items "    * <title>:"). The
study is frozen in a temporary folder (``--directory``), not in results/.

    python .ci/snakemake_lint.py [CONFIGFILE]    # from the repository root
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile

#: Lint titles that do not apply to demcal, each with the reason.
WAIVED = {
    "Specify a conda environment or container for each rule.": (
        "every job runs demcal's own code (the scripts import the demcal package) in the "
        "environment that runs Snakemake, pinned by environment.lock; an environment per rule "
        "would have to install demcal itself"
    ),
}


def lint_blocks(text: str) -> list[tuple[str, list[str]]]:
    """(heading, items) per "Lints for ..." block; an item is its title line and its body."""
    blocks: list[tuple[str, list[str]]] = []
    for line in text.splitlines():
        if line.startswith("Lints for "):
            blocks.append((line, []))
        elif blocks and line.startswith("    * "):
            blocks[-1][1].append(line)
        elif blocks and blocks[-1][1] and line.startswith("      "):
            blocks[-1][1][-1] += "\n" + line
    return blocks


def title(item: str) -> str:
    return re.sub(r"^    \* (.*):$", r"\1", item.splitlines()[0])


def main(argv: list[str]) -> int:
    configfile = argv[0] if argv else "config/examples/analytic.yaml"
    with tempfile.TemporaryDirectory(prefix="demcal-lint-") as folder:
        proc = subprocess.run(
            ["snakemake", "--lint", "--snakefile", "Snakefile", "--directory", folder]
            + ["--configfile", configfile],
            capture_output=True,
            text=True,
        )
    text = proc.stdout + proc.stderr
    blocks = lint_blocks(text)
    if proc.returncode != 0 and not blocks:  # not a lint: the workflow did not load
        print(text, file=sys.stderr)
        return proc.returncode
    failed = 0
    for heading, items in blocks:
        kept = [item for item in items if title(item) not in WAIVED]
        if kept:
            print(heading, *kept, "", sep="\n", file=sys.stderr)
            failed += len(kept)
    waived = sum(title(item) in WAIVED for _, items in blocks for item in items)
    print(f"snakemake --lint: {failed} lints, {waived} waived ({', '.join(WAIVED)})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
