# Jobs of one evaluation. simulate is the expensive job (one SLURM job under
# the slurm profile); extract and objective are cheap and run locally.

EVAL = f"results/{STUDY.name}/evals/{{evaluation}}"
CENTRE = f"results/{STUDY.name}/evals/centre"


wildcard_constraints:
    evaluation=r"[A-Za-z0-9][A-Za-z0-9_-]*",
    scene="|".join(STUDY.scenes),
    replicate=r"\d+",


localrules:
    centre_point,
    extract,
    objective,


rule centre_point:
    output:
        CENTRE + "/params.json",
    log:
        CENTRE + "/logs/centre_point.log",
    script:
        "../../scripts/centre_point.py"


def replicate_responses(wildcards):
    return [
        f"results/{STUDY.name}/evals/{wildcards.evaluation}/{scene}/rep{r}/responses.json"
        for scene in STUDY.scenes
        for r in range(STUDY.replicates)
    ]


rule objective:
    input:
        replicate_responses,
    output:
        EVAL + "/objective.json",
    log:
        EVAL + "/logs/objective.log",
    script:
        "../../scripts/objective.py"


rule extract:
    input:
        EVAL + "/{scene}/rep{replicate}/simulation.json",
    output:
        EVAL + "/{scene}/rep{replicate}/responses.json",
    log:
        EVAL + "/logs/extract_{scene}_rep{replicate}.log",
    script:
        "../../scripts/extract.py"


rule simulate:
    input:
        EVAL + "/params.json",
    output:
        EVAL + "/{scene}/rep{replicate}/simulation.json",
    log:
        EVAL + "/logs/simulate_{scene}_rep{replicate}.log",
    threads: 1
    resources:
        mem_mb=500,
    script:
        "../../scripts/simulate.py"
