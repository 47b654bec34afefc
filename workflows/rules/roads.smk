"""Road scenarios: a roundabout, a route and vehicle bodies; one solve, one figure each, one paper section.

A road <name>-design.toml is the route <name> at a design speed (u1 bounded, [bounds] lateral_acceleration,
[problem] steering_weight): the section sets it beside the time-optimal <name>."""

_road_globs = [config.get("roads", "workflows/roads/*.toml")]
ROAD_FILES = {Path(f).stem: f for g in _road_globs for f in sorted(glob(str(repo_path(g))))}
ROADS = sorted(ROAD_FILES)
ROAD_FIGURE_CODE = closure(SCRIPTS / "roads_figure.py")
ROAD_ANIMATION_CODE = closure(SCRIPTS / "roads_animation.py")
ROAD_SECTION_CODE = closure(SCRIPTS / "roads_section.py")
# The one road animated in the paper (config key road_animation; none if it is not among ROADS).
ROAD_ANIMATION = config.get("road_animation", "semitrailer-left-turn")
ROAD_ANIMATIONS = [f"results/figures/roads/{ROAD_ANIMATION}.gif"] if ROAD_ANIMATION in ROAD_FILES else []

if ROADS:
    PAPER_SECTIONS += ["results/sections/70-roads.md", "results/sections/S9-road-figures.md"]
    PAPER_FIGURES += expand("results/figures/roads/{road}.png", road=ROADS) + ROAD_ANIMATIONS


rule road_solve:
    input:
        scenario=lambda wc: ROAD_FILES[wc.road],
        wrapper=SCRIPTS / "solve.py",
        code=SOLVE_CODE,
    output:
        summary="results/roads/{road}/summary.json",
        trajectory="results/roads/{road}/trajectory.csv",
    log:
        "results/logs/roads/{road}.log",
    shell:
        "{PYTHON} {input.wrapper} {input.scenario} --out results/roads/{wildcards.road} > {log} 2>&1"


rule road_figure:
    input:
        scenario=lambda wc: ROAD_FILES[wc.road],
        summary="results/roads/{road}/summary.json",
        trajectory="results/roads/{road}/trajectory.csv",
        script=SCRIPTS / "roads_figure.py",
        code=ROAD_FIGURE_CODE,
    output:
        expand("results/figures/roads/{{road}}.{ext}", ext=FORMATS),
    shell:
        "{PYTHON} {input.script} {input.scenario} --result results/roads/{wildcards.road}"
        " --out results/figures/roads/{wildcards.road} --formats {FORMATS}"


rule road_animation:
    input:
        scenario=lambda wc: ROAD_FILES[wc.road],
        summary="results/roads/{road}/summary.json",
        trajectory="results/roads/{road}/trajectory.csv",
        script=SCRIPTS / "roads_animation.py",
        code=ROAD_ANIMATION_CODE,
    output:
        "results/figures/roads/{road}.gif",
    shell:
        "{PYTHON} {input.script} {input.scenario} --result results/roads/{wildcards.road} --out {output}"


rule road_section:
    input:
        summaries=expand("results/roads/{road}/summary.json", road=ROADS),
        trajectories=expand("results/roads/{road}/trajectory.csv", road=ROADS),
        scenarios=[ROAD_FILES[r] for r in ROADS],
        script=SCRIPTS / "roads_section.py",
        code=ROAD_SECTION_CODE,
    params:
        animation=" ".join(f"--animation {a}" for a in ROAD_ANIMATIONS),
    output:
        main="results/sections/70-roads.md",
        supplementary="results/sections/S9-road-figures.md",
    shell:
        "{PYTHON} {input.script} --scenarios {input.scenarios} --results results/roads {params.animation}"
        " --out {output.main} --supplementary {output.supplementary}"
