"""Studies (issue 5): time-optimal arcs, time-energy trade-off, wheelbase sweep, grid convergence, shooting."""

STUDY_CODE = closure(*sorted(p for p in SCRIPTS.glob("studies_*.py") if not p.name.startswith("studies_roads_")))
TIME_STUDY = [s for s in SCENARIOS if s.startswith("time-")]
PAPER_ENERGY = [s for s in ("s1", "s2-case1", "s2-case2", "s2-case3", "s3") if s in SCENARIO_FILES]
# N = 100..800 for s2-case1, 100..400 elsewhere: the CPU budget of the rebuild (time-s2 at N = 800 alone costs ~20 s)
CONVERGENCE = ["s2-case1:100,200,400,800", "time-s2:100,200,400", "s1:100,200,400", "s3:100,200,400"]

PAPER_SECTIONS += [
    "results/sections/60-time-optimal.md",
    "results/sections/61-pareto.md",
    "results/sections/S6-wheelbase.md",
    "results/sections/S2-convergence.md",
    "results/sections/S3-indirect.md",
]
PAPER_FIGURES += [
    "results/studies/time/controls.png",
    "results/studies/pareto/pareto.png",
    "results/studies/wheelbase/wheelbase.png",
]


rule study_time:
    input:
        solves=expand("results/scenarios/{s}/{f}", s=TIME_STUDY, f=["summary.json", "trajectory.csv"]),
        script=SCRIPTS / "studies_time.py",
        code=STUDY_CODE,
    output:
        json="results/studies/time/time.json",
        fig="results/studies/time/controls.png",
        section="results/sections/60-time-optimal.md",
    params:
        regularise=[s for s in ("time-s2", "time-real-s2") if s in TIME_STUDY],
    log:
        "results/logs/studies/time.log",
    shell:
        "{PYTHON} {input.script} --results results --scenarios {TIME_STUDY} --regularise {params.regularise}"
        " --out results/studies/time --section {output.section} 2> {log}"


rule study_pareto:
    input:
        solves=expand("results/scenarios/{s}/{f}", s=["time-s1", "time-s2", "time-s3", *PAPER_ENERGY],
                      f=["summary.json", "trajectory.csv"]),
        script=SCRIPTS / "studies_pareto.py",
        code=STUDY_CODE,
    output:
        csv="results/studies/pareto/pareto.csv",
        fig="results/studies/pareto/pareto.png",
        section="results/sections/61-pareto.md",
    log:
        "results/logs/studies/pareto.log",
    shell:
        "{PYTHON} {input.script} --results results --out results/studies/pareto --section {output.section} 2> {log}"


rule study_wheelbase:
    input:
        script=SCRIPTS / "studies_wheelbase.py",
        code=STUDY_CODE,
        scenarios=[SCENARIO_FILES[s] for s in ("time-s2", "s2-case2", "time-s3", "s3", "time-real-s2")],
    output:
        csv="results/studies/wheelbase/wheelbase.csv",
        fig="results/studies/wheelbase/wheelbase.png",
        section="results/sections/S6-wheelbase.md",
    log:
        "results/logs/studies/wheelbase.log",
    shell:
        "{PYTHON} {input.script} --out results/studies/wheelbase --section {output.section} 2> {log}"


rule study_convergence:
    input:
        script=SCRIPTS / "studies_convergence.py",
        code=STUDY_CODE,
        scenarios=[SCENARIO_FILES[c.split(":")[0]] for c in CONVERGENCE],
    output:
        csv="results/studies/convergence/convergence.csv",
        json="results/studies/convergence/convergence.json",
        section="results/sections/S2-convergence.md",
    log:
        "results/logs/studies/convergence.log",
    shell:
        "{PYTHON} {input.script} --scenarios {CONVERGENCE} --out results/studies/convergence"
        " --section {output.section} 2> {log}"


rule study_indirect:
    input:
        script=SCRIPTS / "studies_indirect.py",
        code=STUDY_CODE,
    output:
        json="results/studies/indirect/indirect.json",
        section="results/sections/S3-indirect.md",
    log:
        "results/logs/studies/indirect.log",
    shell:
        "{PYTHON} {input.script} --out results/studies/indirect --section {output.section} 2> {log}"
