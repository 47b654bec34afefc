"""Closed-loop study (issue 13, item 5): MPC versus the Pontryagin optimum, a Monte Carlo over disturbance levels.

One job per geometry x disturbance level (its controllers, plus the config's extra settings):
workflows/scripts/closed_loop_runs.py solves the geometry's open-loop optimum once and runs K seeded
closed loops of each controller (docs/closed-loop-format.md). The geometries are workflows/scenarios/closed-loop/*.toml
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


def cl_groups(settings) -> dict[tuple[str, str], list[str]]:
    """The settings grouped by (geometry, level): one job solves the optimum once and runs each controller."""
    groups = {}
    for g, lv, c in settings:
        groups.setdefault((g, lv), []).append(c)
    return groups


for (_geometry, _level), _controllers in cl_groups(CL_SETTINGS).items():

    rule:
        name:
            f"closed_loop_{re.sub(r'[^0-9A-Za-z]', '_', _geometry)}_level{_level.replace('.', '_')}"
        input:
            scenario=f"{CL_SCENARIO_DIR}/{_geometry}.toml",
            script=SCRIPTS / "closed_loop_runs.py",
            code=CL_RUNS_CODE,
        output:
            [f"{CL_DIR}/{_geometry}/level{_level}/{c}/row.json" for c in _controllers],
        params:
            geometry=_geometry,
            level=_level,
            controllers=" ".join(_controllers),
            runs=CL_GRID.get("runs", 3),
            out=f"{CL_DIR}/{_geometry}/level{_level}" if len(_controllers) > 1 else f"{CL_DIR}/{_geometry}/level{_level}/{_controllers[0]}",
        log:
            f"results/logs/closed-loop/{CL_STUDY}/{_geometry}-level{_level}.log",
        shell:
            "{PYTHON} {input.script} --scenario {input.scenario} --geometry {params.geometry}"
            " --level {params.level} --controller {params.controllers} --runs {params.runs}"
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
