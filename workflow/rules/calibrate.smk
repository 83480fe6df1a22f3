# The whole calibration as one local job: the daemon (demcal run) proposes
# points and runs one child Snakemake per evaluation with the same profile,
# so the simulations go where the profile sends them (local cores, SLURM).
# Killed or interrupted, the same command resumes it. The output, finished.json,
# is written only when the calibration has ended (with its stop reason); the
# daemon watches this Snakemake's pid and ends when it is gone, so a killed
# Snakemake leaves no orphan that holds the study.
#
# A graph (--dag, --rulegraph) draws the jobs of one evaluation, "each", as the
# calibration's inputs: the daemon runs them for every evaluation it starts, in
# a child Snakemake. They are never jobs of this Snakemake.

SHOWN = FILES.evaluation(SHOWN_ID)


rule calibrate:
    input:
        # the study as this Snakemake froze it (the YAML is not read again)
        study=STUDY_INPUT,
        each_evaluation=[str(SHOWN.objective), str(SHOWN.archived)] if GRAPH else [],
    output:
        str(FILES.finished),
    log:
        str(FILES.logs / "calibrate.log"),
    localrule: True
    params:
        python=sys.executable,
        profile=invocation_profile(sys.argv, os.environ),
        snakemake_pid=os.getpid(),
    message:
        calibration_plan(STUDY)
    shell:
        "{params.python:q} -m demcal.cli run {input.study:q} --frozen --profile {params.profile:q}"
        " --watch-pid {params.snakemake_pid} --log {log:q}"
