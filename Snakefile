# demcal: calibration of DEM simulations as a Snakemake workflow.
# The workflow lives in workflow/Snakefile (rules in workflow/rules/, their job
# scripts in scripts/); this file lets `snakemake` run it from the project folder.
#
#   snakemake --profile profiles/local           # calibrate config/config.yaml
#   snakemake --profile profiles/slurm           # the same, simulations as SLURM jobs
#   snakemake --profile profiles/local evaluate_centre          # one point, centre of the bounds
#   snakemake --profile profiles/local results/<study>/evals/<id>/objective.json  # a given params.json
#   snakemake --configfile=config/examples/<x>.yaml ...         # another study


include: "workflow/Snakefile"


# An included file's default target does not carry over; name it here.
rule default:
    default_target: True
    input:
        rules.all.input,
    localrule: True
