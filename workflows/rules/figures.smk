"""Figures: per scenario (the paper's Figs. 4-7 and the Pontryagin quantities), and across scenarios."""

FIGURE_CODE = closure(SCRIPTS / "figures_scenario.py", SCRIPTS / "figures_compare.py")


def solve_outputs(names):
    return expand("results/scenarios/{scenario}/{file}", scenario=names, file=["summary.json", "trajectory.csv"])


rule scenario_figures:
    input:
        scenario=scenario_file,
        summary="results/scenarios/{scenario}/summary.json",
        trajectory="results/scenarios/{scenario}/trajectory.csv",
        script=SCRIPTS / "figures_scenario.py",
        code=FIGURE_CODE,
    output:
        expand("results/figures/{{scenario}}/{name}.{ext}", name=["solution", "costates"], ext=FORMATS),
    shell:
        "{PYTHON} {input.script} {input.scenario} --result results/scenarios/{wildcards.scenario}"
        " --out results/figures/{wildcards.scenario} --formats {FORMATS}"


def compare_rule_params(names):
    return {"scenarios": [SCENARIO_FILES[s] for s in names], "dirs": [f"results/scenarios/{s}" for s in names]}


COMPARISONS = (("phase-rate", "phase-rate", "phase_rate"), ("paths", "paths", "compare_paths"),
               ("cases", "s2-cases", "compare_cases"))

for _kind, _stem, _key in COMPARISONS:
    _names = chosen(_key)

    rule:
        name:
            f"figure_{_stem.replace('-', '_')}"
        input:
            scenarios=[SCENARIO_FILES[s] for s in _names],
            solves=solve_outputs(_names),
            script=SCRIPTS / "figures_compare.py",
            code=FIGURE_CODE,
        output:
            expand("results/figures/{stem}.{ext}", stem=_stem, ext=FORMATS),
        params:
            kind=_kind,
            dirs=[f"results/scenarios/{s}" for s in _names],
            stem=f"results/figures/{_stem}",
        shell:
            "{PYTHON} {input.script} {params.kind} --scenarios {input.scenarios} --results {params.dirs}"
            " --order {SCENARIOS} --out {params.stem} --formats {FORMATS}"


FIGURES = expand("results/figures/{scenario}/{name}.png", scenario=PAPER_SCENARIOS, name=["solution", "costates"]) + [
    "results/figures/phase-rate.png",
    "results/figures/paths.png",
    "results/figures/s2-cases.png",
]
OPTIONAL_TARGETS += expand("results/figures/{scenario}/{name}.{ext}", scenario=SCENARIOS,
                           name=["solution", "costates"], ext=FORMATS)
OPTIONAL_TARGETS += expand("results/figures/{stem}.{ext}", stem=["phase-rate", "paths", "s2-cases"], ext=FORMATS)
