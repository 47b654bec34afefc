"""Map study (issue 21, item 7): every movement of a real roundabout (a CommonRoad map) x design vehicles x apron."""

MAP_STUDY = config.get("map_study", "small")
MAP_GRID = config["map_studies"][MAP_STUDY]
MAP_TEMPLATE = repo_path(config.get("map_study_template", "workflows/scenarios/maps/kackertstrasse.toml"))
MAP_STUDY_DIR = "results/studies/map"
MAP_OPERATIONAL = "--operational" if config.get("map_study_operational", True) else "--no-operational"


def map_movements(grid: dict) -> list[str]:
    """The grid's movements: a list of "<entry>-<exit>", or "all" (enumerated from the template's map graph)."""
    if grid["movements"] != "all":
        return list(grid["movements"])
    import tomllib

    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from model.problem.maps import map_of
    from model.studies.maps import movements

    return [m.name for m in movements(map_of(tomllib.loads(MAP_TEMPLATE.read_text()), MAP_TEMPLATE.parent))]


MAP_MOVEMENTS = map_movements(MAP_GRID)
MAP_CELLS = [f"{v}_{m}_{'apron' if a else 'noapron'}" for v in MAP_GRID["vehicles"] for m in MAP_MOVEMENTS
             for a in MAP_GRID["apron"]]  # model.studies.maps.cell_name

PAPER_SECTIONS += ["results/sections/78-map-study.md"]
PAPER_FIGURES += [f"{MAP_STUDY_DIR}/{MAP_STUDY}/{v}.png" for v in MAP_GRID["vehicles"]]


wildcard_constraints:
    map_cell="|".join(re.escape(c) for c in MAP_CELLS) or "NO_CELL",
    map_grid="small|full",


rule map_study_cell:
    input:
        template=MAP_TEMPLATE,
        script=SCRIPTS / "map_study_cell.py",
        code=closure(SCRIPTS / "map_study_cell.py"),
    output:
        f"{MAP_STUDY_DIR}/{{map_grid}}/cells/{{map_cell}}.json",
    params:
        intervals=lambda wc: config["map_studies"][wc.map_grid]["intervals"],
    log:
        "results/logs/studies/map-{map_grid}/{map_cell}.log",
    shell:
        "{PYTHON} {input.script} --template {input.template} --cell {wildcards.map_cell}"
        " --intervals {params.intervals} {MAP_OPERATIONAL} --out {output} 2> {log}"


rule map_study_table:
    input:
        cells=expand(f"{MAP_STUDY_DIR}/{MAP_STUDY}/cells/{{cell}}.json", cell=MAP_CELLS),
        template=MAP_TEMPLATE,
        script=SCRIPTS / "map_study_table.py",
        code=closure(SCRIPTS / "map_study_table.py"),
    output:
        csv=f"{MAP_STUDY_DIR}/{MAP_STUDY}/table.csv",
        md=f"{MAP_STUDY_DIR}/{MAP_STUDY}/table.md",
        figures=expand(f"{MAP_STUDY_DIR}/{MAP_STUDY}/{{vehicle}}.{{ext}}", vehicle=MAP_GRID["vehicles"], ext=FORMATS),
        section="results/sections/78-map-study.md",
    params:
        vehicles=MAP_GRID["vehicles"],
        movements=MAP_MOVEMENTS,
        apron=[str(bool(a)).lower() for a in MAP_GRID["apron"]],
        intervals=MAP_GRID["intervals"],
    log:
        "results/logs/studies/map-table.log",
    shell:
        "{PYTHON} {input.script} --cells {input.cells} --template {input.template} --mode {MAP_STUDY}"
        " --vehicles {params.vehicles} --movements {params.movements} --apron {params.apron}"
        " --intervals {params.intervals} --out {MAP_STUDY_DIR}/{MAP_STUDY} --section {output.section}"
        " --formats {FORMATS} 2> {log}"
