# Figures and tables of a finished calibration, flagged for `snakemake --report`.

PLOTS = f"results/{STUDY.name}/plots"


rule plots:
    input:
        f"results/{STUDY.name}/finished.json",
    output:
        report(f"{PLOTS}/best_point.csv", caption="../report/best_point.rst",
               category="Best point"),
        report(f"{PLOTS}/objective_vs_evaluation.png",
               caption="../report/objective_vs_evaluation.rst", category="Convergence"),
        report(f"{PLOTS}/objective_vs_time.png", caption="../report/objective_vs_time.rst",
               category="Convergence"),
        report(f"{PLOTS}/parameter_traces.png", caption="../report/parameter_traces.rst",
               category="Parameters and responses"),
        report(f"{PLOTS}/responses_vs_targets.png",
               caption="../report/responses_vs_targets.rst",
               category="Parameters and responses"),
    log:
        f"results/{STUDY.name}/logs/plots.log",
    localrule: True
    script:
        "../../scripts/plots.py"


rule evaluation_dag:
    input:
        f"results/{STUDY.name}/finished.json",
    output:
        report(f"{PLOTS}/evaluation_dag.svg", caption="../report/evaluation_dag.rst",
               category="Workflow"),
    log:
        f"results/{STUDY.name}/logs/evaluation_dag.log",
    localrule: True
    params:
        snakefile=workflow.main_snakefile,
        config=workflow.configfiles[0],
        target=f"results/{STUDY.name}/evals/e0000/objective.json",
    script:
        "../../scripts/evaluation_dag.py"
