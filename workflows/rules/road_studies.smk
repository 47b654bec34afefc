"""Road studies (issue 11, item 8): the EU turning circle, design vehicles x roundabout sizes, energy vs time on a roundabout."""

ROAD_STUDY = config.get("road_studies", "small")
ROAD_GRID = config["road_studies_grids"][ROAD_STUDY]
ROAD_TEMPLATE = repo_path("workflows/scenarios/roads/left-turn.toml")
ROAD_CELLS = [f"{v}_icd{float(i):g}_apron{float(a):g}" for v in ROAD_GRID["vehicles"] for i in ROAD_GRID["icd"]
              for a in ROAD_GRID["apron"]]  # model.studies.roads.cell_name
ROAD_TRADEOFF = config.get("road_tradeoff", {})
ROAD_TRADEOFF_SCENARIO = repo_path(ROAD_TRADEOFF.get("scenario", "workflows/scenarios/roads/su30-left-turn.toml"))
ROAD_ENERGY_RATIO = config.get("road_studies_energy_ratio", 1.2)
ROAD_STUDY_DIR = "results/studies/roads"
ROAD_OPERATIONAL = "--operational" if config.get("road_studies_operational", True) else "--no-operational"

PAPER_SECTIONS += [
    "results/sections/S7-turning-circle.md",
    "results/sections/74-design-vehicles.md",
    "results/sections/S8-road-tradeoff.md",
]
PAPER_FIGURES += [
    f"{ROAD_STUDY_DIR}/turning/turning.png",
    f"{ROAD_STUDY_DIR}/table/{ROAD_STUDY}/table.png",
    f"{ROAD_STUDY_DIR}/tradeoff/tradeoff.png",
]


wildcard_constraints:
    road_vehicle="|".join(re.escape(v) for v in ROAD_GRID["vehicles"]) or "NO_VEHICLE",
    road_apron="|".join(re.escape(f"{float(a):g}") for a in ROAD_GRID["apron"]) or "NO_APRON",


rule road_study_turning:
    input:
        script=SCRIPTS / "studies_roads_turning.py",
        code=closure(SCRIPTS / "studies_roads_turning.py"),
    output:
        json=f"{ROAD_STUDY_DIR}/turning/turning.json",
        figures=expand(f"{ROAD_STUDY_DIR}/turning/turning.{{ext}}", ext=FORMATS),
        section="results/sections/S7-turning-circle.md",
    log:
        "results/logs/studies/roads-turning.log",
    shell:
        "{PYTHON} {input.script} --out {ROAD_STUDY_DIR}/turning --section {output.section} --formats {FORMATS}"
        " 2> {log}"


def road_row_cells(vehicle: str, apron: str) -> list[str]:
    """The cells of one row of the grid (one vehicle and apron, every ICD), in the ICD's order."""
    return [c for c in ROAD_CELLS if c.startswith(f"{vehicle}_icd") and c.endswith(f"_apron{apron}")]


# One job per row, not per cell: the row's cells are solved in turn in one process (each with its own budget,
# written when done), so the full grid's 84 cells pay the solve path's imports (about 2 s of CPU) 12 times.
# The grid lists vehicles from small to large and the large ones' rows take longest (full grid: 47-60 s of
# CPU for P and SU-30, 105-249 s for the articulated ones): started first, the two cores finish together
rule road_study_row:
    priority: lambda wc: ROAD_GRID["vehicles"].index(wc.road_vehicle)
    input:
        template=ROAD_TEMPLATE,
        script=SCRIPTS / "studies_roads_cell.py",
        code=closure(SCRIPTS / "studies_roads_cell.py"),
    output:
        [f"{ROAD_STUDY_DIR}/table/{ROAD_STUDY}/cells/{{road_vehicle}}_icd{float(i):g}_apron{{road_apron}}.json"
         for i in ROAD_GRID["icd"]],
    params:
        cells=lambda wc: " ".join(road_row_cells(wc.road_vehicle, wc.road_apron)),
        intervals=ROAD_GRID["intervals"],
        time_limit=(lambda g: f"--time-limit {g['time_limit']} --clock {g.get('time_limit_clock', 'wall')}"
                    + (f" --energy-time-limit {g['energy_time_limit']}" if g.get("energy_time_limit") else "")
                    if g.get("time_limit") else "")(ROAD_GRID),
    log:
        f"results/logs/studies/roads-{ROAD_STUDY}/{{road_vehicle}}_apron{{road_apron}}.log",
    shell:
        "{PYTHON} {input.script} --template {input.template} --cell {params.cells}"
        " --intervals {params.intervals} {params.time_limit} --energy-ratio {ROAD_ENERGY_RATIO} {ROAD_OPERATIONAL}"
        " --out {output}"
        " 2> {log}"


rule road_study_table:
    input:
        cells=expand(f"{ROAD_STUDY_DIR}/table/{ROAD_STUDY}/cells/{{cell}}.json", cell=ROAD_CELLS),
        template=ROAD_TEMPLATE,
        script=SCRIPTS / "studies_roads_table.py",
        code=closure(SCRIPTS / "studies_roads_table.py"),
    output:
        csv=f"{ROAD_STUDY_DIR}/table/{ROAD_STUDY}/table.csv",
        figures=expand(f"{ROAD_STUDY_DIR}/table/{ROAD_STUDY}/table.{{ext}}", ext=FORMATS),
        section="results/sections/74-design-vehicles.md",
    params:
        vehicles=ROAD_GRID["vehicles"],
        icd=ROAD_GRID["icd"],
        apron=ROAD_GRID["apron"],
        intervals=ROAD_GRID["intervals"],
    log:
        "results/logs/studies/roads-table.log",
    shell:
        "{PYTHON} {input.script} --cells {input.cells} --template {input.template} --mode {ROAD_STUDY}"
        " --vehicles {params.vehicles} --icd {params.icd} --apron {params.apron} --intervals {params.intervals}"
        " --energy-ratio {ROAD_ENERGY_RATIO} --out {ROAD_STUDY_DIR}/table/{ROAD_STUDY} --section {output.section}"
        " --formats {FORMATS} 2> {log}"


rule road_study_tradeoff:
    input:
        scenario=ROAD_TRADEOFF_SCENARIO,
        script=SCRIPTS / "studies_roads_tradeoff.py",
        code=closure(SCRIPTS / "studies_roads_tradeoff.py"),
    output:
        csv=f"{ROAD_STUDY_DIR}/tradeoff/tradeoff.csv",
        figures=expand(f"{ROAD_STUDY_DIR}/tradeoff/tradeoff.{{ext}}", ext=FORMATS),
        section="results/sections/S8-road-tradeoff.md",
    params:
        ratios=ROAD_TRADEOFF.get("ratios", [1.1, 1.25, 1.5, 2.0]),
    log:
        "results/logs/studies/roads-tradeoff.log",
    shell:
        "{PYTHON} {input.script} --scenario {input.scenario} --ratios {params.ratios} --out {ROAD_STUDY_DIR}/tradeoff"
        " --section {output.section} --formats {FORMATS} 2> {log}"
