"""Plant study (issue 43, item 5): where the kinematic plan holds.

Each manoeuvre (a vehicle's template in workflows/scenarios/plant-study/<vehicle>.toml and a route exit) is
planned with the kinematic model at rising bounds of the lateral acceleration and driven by the tracking
controller on the kinematic and on the dynamic single-track plant (model/studies/plant_gap.py). One job per
manoeuvre runs its levels in turn (workflows/scripts/plant_study_cells.py); the section's job writes the table,
the figure and results/sections/82-plant-study.md. The grid (config plant_study: small, the default, or full)
is named in the section.
"""

PLANT_STUDY = config.get("plant_study", "small")
PLANT_GRID = config.get("plant_studies", {}).get(PLANT_STUDY, {})
PLANT_TEMPLATES = str(repo_path("workflows/scenarios/plant-study"))
PLANT_DIR = f"results/studies/plant/{PLANT_STUDY}"
PLANT_MANOEUVRES = [f"{v}-exit{e}" for v in PLANT_GRID.get("vehicles", []) for e in PLANT_GRID.get("exits", [])]

if PLANT_MANOEUVRES:
    PAPER_SECTIONS += ["results/sections/82-plant-study.md"]
    PAPER_FIGURES += [f"{PLANT_DIR}/plant-gap.png"]


wildcard_constraints:
    plant_vehicle="|".join(re.escape(v) for v in PLANT_GRID.get("vehicles", [])) or "NO_VEHICLE",
    plant_exit=r"\d+",


rule plant_study_manoeuvre:
    input:
        template=f"{PLANT_TEMPLATES}/{{plant_vehicle}}.toml",
        script=SCRIPTS / "plant_study_cells.py",
        code=closure(SCRIPTS / "plant_study_cells.py", "model.search.multistart"),
    output:
        f"{PLANT_DIR}/cells/{{plant_vehicle}}-exit{{plant_exit}}.json",
    params:
        levels=PLANT_GRID.get("lateral_acceleration", []),
        intervals=PLANT_GRID.get("intervals", 40),
        time_limit=PLANT_GRID.get("time_limit", 60),
    log:
        f"results/logs/studies/plant-{PLANT_STUDY}/{{plant_vehicle}}-exit{{plant_exit}}.log",
    shell:
        "{PYTHON} {input.script} --template {input.template} --vehicle {wildcards.plant_vehicle}"
        " --exit {wildcards.plant_exit} --levels {params.levels} --intervals {params.intervals}"
        " --time-limit {params.time_limit} --out {output} 2> {log}"


rule plant_study_section:
    input:
        cells=expand(f"{PLANT_DIR}/cells/{{m}}.json", m=PLANT_MANOEUVRES),
        script=SCRIPTS / "plant_study_section.py",
        code=closure(SCRIPTS / "plant_study_section.py"),
    output:
        csv=f"{PLANT_DIR}/table.csv",
        md=f"{PLANT_DIR}/table.md",
        figures=expand(f"{PLANT_DIR}/plant-gap.{{ext}}", ext=FORMATS),
        section="results/sections/82-plant-study.md",
    log:
        f"results/logs/studies/plant-{PLANT_STUDY}/section.log",
    shell:
        "{PYTHON} {input.script} --cells {input.cells} --study {PLANT_STUDY} --out {PLANT_DIR}"
        " --figure-link {PLANT_DIR}/plant-gap.png --formats {FORMATS} --section {output.section} 2> {log}"
