# Functions of the rules, apart from the rules (snakemake --lint: no rules and
# functions in one file).

from demcal.resources import PROFILES_DIR


def invocation_profile():
    """The --profile this Snakemake was started with (or $SNAKEMAKE_PROFILE), else local."""
    args = sys.argv
    for i, arg in enumerate(args):
        if arg == "--profile" and i + 1 < len(args):
            return os.path.abspath(args[i + 1])
        if arg.startswith("--profile="):
            return os.path.abspath(arg.split("=", 1)[1])
    return os.path.abspath(os.environ.get("SNAKEMAKE_PROFILE", PROFILES_DIR / "local"))
