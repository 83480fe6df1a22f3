"""``demcal sample STUDY.yaml --points N``: a sampling campaign over the study's box, into the
archive (``demcal.domain.campaign``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from demcal.cli.options import former_name, profile_argument
from demcal.cli.study_argument import study_yaml
from demcal.daemon.session import locked_study
from demcal.domain.campaign import (
    CAMPAIGN_DESIGNS,
    FAIL_FAST,
    Tally,
    check_request,
    design_quality,
    forecast,
    plan,
    run,
    simulations_per_point,
    write_points,
)
from demcal.errors import ConfigError
from demcal.results.records import FINE
from demcal.snakemake_command import check_profile, runs_locally
from demcal.study.config import load_study_file
from demcal.study.model import Study

#: The exit status of a campaign interrupted by Ctrl-C (`simulate`).
INTERRUPTED = 130


def arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--points",
        type=int,
        metavar="N",
        help="points of the design, in all (required; a larger N extends a campaign that has run)",
    )
    former_name(sub, "--n", "--points", type=int)
    sub.add_argument(
        "--design",
        default="fssf_f",
        choices=CAMPAIGN_DESIGNS,
        help="space-filling design (default fssf_f, Richter & Will's choice)",
    )
    sub.add_argument(
        "--fidelity",
        default=FINE,
        metavar="LEVEL",
        help="the fidelity level the points run at (default fine: the study's own settings; "
        "another is one of the study's fidelities)",
    )
    sub.add_argument(
        "--name",
        help="run the campaign as this study (same box, its own folder and design), e.g. a "
        "held-out set for demcal metamodel validate",
    )
    profile_argument(sub)
    sub.add_argument(
        "--bundle",
        type=int,
        default=1,
        help="simulations per cluster job, run one after another (default 1): for simulations "
        "of seconds, where job submission and the scheduler's limits would take longer",
    )


def sample(args: argparse.Namespace) -> int:
    if args.points is None:
        raise ConfigError("sample: give --points N, the number of points of the design")
    profile = Path(args.profile)
    settings = check_profile(profile)
    config = study_yaml(args.config, "sample")
    given = load_study_file(config)
    check_request(args.points, args.design, args.bundle, simulations_per_point(given))
    if given.archive is None:
        raise ConfigError(
            "archive: false: a campaign is for the archive; give the study an archive"
        )
    if args.bundle > 1 and runs_locally(profile):
        print(
            f"demcal sample: --bundle {args.bundle} has no effect with {profile}: its simulations "
            f"run on this machine's cores, not as cluster jobs",
            file=sys.stderr,
        )
    if args.fidelity not in given.levels:
        raise ConfigError(
            f"--fidelity {args.fidelity}: not a level of the study ({', '.join(given.levels)}); "
            f"a cheaper one is declared under fidelities: (docs/fidelity.md)"
        )
    with locked_study(config, name=args.name) as study:
        campaign = plan(study, args.points, args.design, [args.fidelity])
        distance, cover = design_quality(campaign)
        # said before the points are written: a campaign of thousands takes a while to write
        print(
            f"demcal sample: {study.name}, {campaign.design} design of "
            f"{len(campaign.unit_points)} points at {', '.join(campaign.fidelities)} in "
            f"{len(study.free)} parameters "
            f"({', '.join(p.name for p in study.free)}); minimum inter-site distance "
            f"{distance:.3g}, cover measure {cover:.3g} (unit box)",
            f"demcal sample: {forecast(study, campaign, settings)}",
            sep="\n",
            flush=True,
        )
        names = write_points(study, campaign)
        return simulate(study, names, profile, args.bundle, "sample")


def simulate(study: Study, names: list[str], profile: Path, bundle: int, command: str) -> int:
    """Run a campaign's evaluations ``names`` under one Snakemake (``campaign.run``) with a
    progress bar, and say how it ended; the exit status (0: every simulation finished)."""
    bar = tqdm(
        total=len(names) * simulations_per_point(study),
        unit="sim",
        file=sys.stderr,
        mininterval=1.0 if sys.stderr.isatty() else 30.0,
    )

    def show(state: Tally) -> None:
        counts = ", ".join(f"{n} {s}" for s, n in sorted(state.statuses.items()))
        bar.set_postfix_str(counts, refresh=False)
        bar.update(state.finished - bar.n)

    try:
        state = run(study, names, profile, show, bundle)
    except KeyboardInterrupt:
        bar.close()
        print(
            f"demcal {command}: interrupted; run the same command again to resume",
            file=sys.stderr,
        )
        return INTERRUPTED
    bar.close()
    archived = f"each is in the archive {study.archive}" if study.archive else "none archived"
    print(f"demcal {command}: {state.line()}; {archived}")
    if state.stopped:
        reason = state.reasons.most_common(1)[0][0] if state.reasons else "unknown"
        print(
            f"demcal {command}: stopped: the first {FAIL_FAST} simulations all failed "
            f"(commonest: {reason}); see {study.files.campaign_log} and the evaluations' logs",
            file=sys.stderr,
        )
        return 1
    if state.finished < state.total:
        print(
            f"demcal {command}: {state.total - state.finished} simulations did not finish; run "
            f"the same command again to resume (see {study.files.campaign_log})",
            file=sys.stderr,
        )
        return 1
    return 0
