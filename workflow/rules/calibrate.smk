# The whole calibration as one local job: the daemon (demcal run) proposes
# points and runs one child Snakemake per evaluation with the same profile,
# so the simulations go where the profile sends them (local cores, SLURM).
# Killed or interrupted, the same command resumes it. The output, finished.json,
# is written only when the calibration has ended (with its stop reason); the
# daemon watches this Snakemake's pid and ends when it is gone, so a killed
# Snakemake leaves no orphan that holds the study.


rule calibrate:
    input:
        # the study as this Snakemake froze it (the YAML is not read again)
        study=STUDY_FILE,
    output:
        str(FILES.finished),
    log:
        str(FILES.logs / "calibrate.log"),
    localrule: True
    params:
        python=sys.executable,
        profile=invocation_profile(sys.argv, os.environ),
        snakemake_pid=os.getpid(),
    shell:
        "{params.python:q} -m demcal.cli run {input.study:q} --frozen --profile {params.profile:q}"
        " --watch-pid {params.snakemake_pid} --log {log:q}"
