"""One parallel job per scenario: `roundabout solve`, with a solver failure recorded, not fatal."""


rule solve:
    input:
        scenario=scenario_file,
        wrapper=SCRIPTS / "solve.py",
        code=SOLVE_CODE,
    output:
        summary="results/scenarios/{scenario}/summary.json",
        trajectory="results/scenarios/{scenario}/trajectory.csv",
    params:
        intervals_arg=f"--intervals {config['intervals']}" if config.get("intervals") else "",
    log:
        "results/logs/solve/{scenario}.log",
    shell:
        "{PYTHON} {input.wrapper} {input.scenario} --out results/scenarios/{wildcards.scenario}"
        " {params.intervals_arg} > {log} 2>&1"
