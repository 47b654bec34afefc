"""Closed-loop study (issue 13, item 5): MPC versus the Pontryagin optimum, a Monte Carlo over disturbance levels.

One job per setting (geometry x disturbance level x controller, plus the config's extra settings):
workflows/scripts/closed_loop_runs.py solves the geometry's open-loop optimum and runs K seeded
closed loops (docs/closed-loop-format.md). The geometries are workflows/scenarios/closed-loop/*.toml
(a sub-folder: the `scenarios` glob of config.yaml does not reach it); each file's [disturbance] is
level 1. The study (config closed_loop_study: small, the default inside the rebuild's budget, or
full) names the grid; the paper's section says which one was run.
"""

CL_STUDY = config.get("closed_loop_study", "small")
CL_GRIDS = config.get("closed_loop_studies", {})
CL_GRID = CL_GRIDS.get(CL_STUDY, {})
CL_SCENARIO_DIR = str(repo_path("workflows/scenarios/closed-loop"))
CL_DIR = f"results/closed-loop/{CL_STUDY}"
CL_CONTROLLERS = ("open-loop", "tracking", "mpc")
CL_RUNS_CODE = closure(SCRIPTS / "closed_loop_runs.py", "model.search.multistart")
CL_SECTION_CODE = closure(SCRIPTS / "closed_loop_section.py")


def cl_level(level) -> str:
    """A disturbance level as it appears in paths (0, 0.5, 1, 2)."""
    return f"{float(level):g}"


def cl_settings(grid: dict) -> list[tuple[str, str, str]]:
    """(geometry, level, controller) of every setting: the full grid, then the extra ones ("geometry:level:controller")."""
    full = [(g, cl_level(lv), c) for g in grid.get("geometries", []) for lv in grid.get("levels", [])
            for c in grid.get("controllers", CL_CONTROLLERS)]
    extra = [tuple(e.split(":")) for e in grid.get("extra", [])]
    return full + [(g, cl_level(lv), c) for g, lv, c in extra]


CL_GEOMETRIES = sorted(Path(f).stem for f in glob(str(Path(CL_SCENARIO_DIR) / "*.toml")))
CL_SETTINGS = cl_settings(CL_GRID)
CL_ROWS = [f"{CL_DIR}/{g}/level{lv}/{c}/row.json" for g, lv, c in CL_SETTINGS]
CL_FIGURES = [f"{CL_DIR}/{name}.png" for name in ("errors", "paths")]

if CL_SETTINGS:
    PAPER_SECTIONS += ["results/sections/80-closed-loop.md"]
    PAPER_FIGURES += CL_FIGURES


wildcard_constraints:
    cl_study="|".join(re.escape(s) for s in CL_GRIDS) or "NO_STUDY",
    cl_geometry="|".join(re.escape(g) for g in CL_GEOMETRIES) or "NO_GEOMETRY",
    cl_level=r"\d+(\.\d+)?",
    cl_controller="|".join(CL_CONTROLLERS),


rule closed_loop_setting:
    input:
        scenario=f"{CL_SCENARIO_DIR}/{{cl_geometry}}.toml",
        script=SCRIPTS / "closed_loop_runs.py",
        code=CL_RUNS_CODE,
    output:
        "results/closed-loop/{cl_study}/{cl_geometry}/level{cl_level}/{cl_controller}/row.json",
    params:
        runs=lambda wc: CL_GRIDS[wc.cl_study].get("runs", 3),
        out=lambda wc, output: str(Path(output[0]).parent),
    log:
        "results/logs/closed-loop/{cl_study}/{cl_geometry}-level{cl_level}-{cl_controller}.log",
    shell:
        "{PYTHON} {input.script} --scenario {input.scenario} --geometry {wildcards.cl_geometry}"
        " --level {wildcards.cl_level} --controller {wildcards.cl_controller} --runs {params.runs}"
        " --out {params.out} 2> {log}"


rule closed_loop_section:
    input:
        rows=CL_ROWS,
        scenarios=sorted({f"{CL_SCENARIO_DIR}/{g}.toml" for g, _, _ in CL_SETTINGS}),
        script=SCRIPTS / "closed_loop_section.py",
        code=CL_SECTION_CODE,
    output:
        section="results/sections/80-closed-loop.md",
        figures=expand(f"{CL_DIR}/{{name}}.{{ext}}", name=["errors", "paths"], ext=FORMATS),
    log:
        "results/logs/closed-loop/section.log",
    shell:
        "{PYTHON} {input.script} --rows {input.rows} --scenario-dir {CL_SCENARIO_DIR} --study {CL_STUDY}"
        " --figures {CL_DIR} --formats {FORMATS} --out {output.section} 2> {log}"
