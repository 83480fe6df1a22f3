# Jobs of one evaluation. A scene replicate's simulate and extract form one group
# ("run"): under the slurm profile one SLURM job, so that its responses.json appears
# as soon as the simulation ends (the calibration daemon takes the result from it);
# locally the group has no effect. The objective and the release of staged
# simulations are cheap and run locally. Every job reads the frozen study
# (params.study_file), never the YAML.

from pathlib import Path

from demcal.jobs.steps import release_marker, response_paths, staged_inputs

EVAL = FILES.evaluation("{evaluation}")
REPLICATE = EVAL.replicate("{scene}", "{replicate}")
CENTRE = FILES.evaluation("centre")


wildcard_constraints:
    evaluation=r"[A-Za-z0-9][A-Za-z0-9_-]*",
    scene="|".join(STUDY.scenes),
    replicate=r"\d+",


localrules:
    centre_point,
    extract,
    objective,
    release,
    archive,


rule centre_point:
    output:
        str(CENTRE.params),
    log:
        str(CENTRE.job_log("centre_point")),
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/centre_point.py"


rule objective:
    input:
        lambda w: [str(path) for path in response_paths(STUDY, w.evaluation)],
    output:
        str(EVAL.objective),
    log:
        str(EVAL.job_log("objective")),
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/objective.py"


# The simulations of an evaluation go into the study's archive from this machine (an SQLite
# archive must not be written from several nodes).
rule archive:
    input:
        lambda w: [str(path) for path in response_paths(STUDY, w.evaluation)],
    output:
        str(EVAL.archived),
    log:
        str(EVAL.job_log("archive")),
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/archive.py"


# A finished simulation is extracted before the next one starts: with many
# evaluations under one Snakemake (demcal sample) the simulations would otherwise take every
# core first.
rule extract:
    input:
        str(REPLICATE.simulation),
    output:
        str(REPLICATE.responses),
    log:
        str(EVAL.job_log("extract", "{scene}", "{replicate}")),
    priority: 10
    group:
        "run"
    resources:
        runtime=5,  # minutes, added to the simulation's in the SLURM job of the group
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/extract.py"


# In a staged study a simulation waits for the first ones (study.staging): this job
# releases it once they have ended.
rule release:
    input:
        lambda w: [
            str(path) for path in staged_inputs(STUDY, w.evaluation, w.scene, int(w.replicate))
        ],
    output:
        str(REPLICATE.released),
    log:
        str(EVAL.job_log("release", "{scene}", "{replicate}")),
    run:
        Path(log[0]).write_text(f"released after {', '.join(input)}\n")
        Path(output[0]).touch()


rule simulate:
    input:
        evaluation_params,
        lambda w: [
            str(path) for path in release_marker(STUDY, w.evaluation, w.scene, int(w.replicate))
        ],
    output:
        str(REPLICATE.simulation),
    log:
        str(EVAL.job_log("simulate", "{scene}", "{replicate}")),
    group:
        "run"
    threads: 1
    resources:
        mem_mb=500,
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/simulate.py"
