# Functions of the rules, apart from the rules (snakemake --lint: no rules and
# functions in one file).

from demcal.workflow import invocation_profile  # the --profile of this Snakemake
