# Figures and tables of a finished calibration, flagged for `snakemake --report`.

PLOTS = FILES.plots


rule plots:
    input:
        str(FILES.finished),
    output:
        report(
            str(PLOTS / "best_point.csv"),
            caption="../report/best_point.rst",
            category="Best point",
        ),
        report(
            str(PLOTS / "objective_vs_evaluation.png"),
            caption="../report/objective_vs_evaluation.rst",
            category="Convergence",
        ),
        report(
            str(PLOTS / "objective_vs_time.png"),
            caption="../report/objective_vs_time.rst",
            category="Convergence",
        ),
        report(
            str(PLOTS / "parameter_traces.png"),
            caption="../report/parameter_traces.rst",
            category="Parameters and responses",
        ),
        report(
            str(PLOTS / "responses_vs_targets.png"),
            caption="../report/responses_vs_targets.rst",
            category="Parameters and responses",
        ),
        report(
            str(PLOTS / "parallel_coordinates.png"),
            caption="../report/parallel_coordinates.rst",
            category="Parameters and responses",
        ),
        report(
            str(PLOTS / "early_termination.png"),
            caption="../report/early_termination.rst",
            category="Convergence",
        ),
    log:
        str(FILES.logs / "plots.log"),
    localrule: True
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/plots.py"


# Only for studies whose scenes keep a time series (Scene.history; the transfer chute's
# flows): the answer's responses over simulated time.
rule answer_history:
    input:
        str(FILES.finished),
    output:
        report(
            str(PLOTS / "answer_over_time.png"),
            caption="../report/answer_over_time.rst",
            category="Best point",
        ),
    log:
        str(FILES.logs / "answer_history.log"),
    localrule: True
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/answer_history.py"


rule solutions:
    input:
        str(FILES.finished),
    output:
        report(
            str(PLOTS / "solution_space.png"),
            caption="../report/solution_space.rst",
            category="Solution space",
        ),
        report(
            str(PLOTS / "sensitivity.png"),
            caption="../report/sensitivity.rst",
            category="Solution space",
        ),
        report(
            str(PLOTS / "objective_slices.png"),
            caption="../report/objective_slices.rst",
            category="Solution space",
        ),
    log:
        str(FILES.logs / "solutions.log"),
    localrule: True
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/solutions.py"


rule evaluation_dag:
    input:
        str(FILES.finished),
    output:
        report(
            str(PLOTS / "evaluation_dag.svg"),
            caption="../report/evaluation_dag.rst",
            category="Evaluation DAG",
        ),
    log:
        str(FILES.logs / "evaluation_dag.log"),
    localrule: True
    params:
        study_file=STUDY_FILE,
    script:
        "../../scripts/evaluation_dag.py"
