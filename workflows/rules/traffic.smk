"""The truck in traffic (issue 20, item 6): vehicle x conflicting flow x driver among SUMO traffic.

One job per cell (workflows/scripts/traffic_cell.py: K seeded `roundabout traffic` runs of the
template workflows/scenarios/traffic/<vehicle>.toml with `rate` veh/h from every other leg), one job
drawing one run (the first vehicle's highest-rate autopilot cell, its first seed), one job for the
table, the critical gaps (the truck's and SUMO's cars' at every entry), the Adams and HCM comparisons and the
section. The grid is config traffic_study: small (the default, inside the rebuild's budget) or full (both
vehicles, every rate to 1200 veh/h, 20 seeds; its results are committed as benchmarks/traffic-study.md), or
management (the autopilot, cooperative and reservation drivers at 450 and 700 veh/h: rule traffic_management,
benchmarks/traffic-management.md).
"""

TR_STUDY = config.get("traffic_study", "small")
TR_GRIDS = config.get("traffic_studies", {})
TR_GRID = TR_GRIDS.get(TR_STUDY, {})
TR_DIR = f"results/studies/traffic/{TR_STUDY}"
TR_TEMPLATES = str(repo_path("workflows/scenarios/traffic"))
TR_CELLS = [f"{v}_q{float(q):g}_{d}" for v in TR_GRID.get("vehicles", []) for q in TR_GRID.get("rates", [])
            for d in TR_GRID.get("drivers", ["autopilot", "sumo"])]  # model.traffic.study.cell_name
TR_SHOWN = (f"{TR_GRID['vehicles'][0]}_q{float(max(TR_GRID['rates'])):g}_autopilot" if TR_CELLS else None)
TR_CELL_CODE = closure(SCRIPTS / "traffic_cell.py")
TR_TABLE_CODE = closure(SCRIPTS / "traffic_table.py")
TR_FIGURE_CODE = closure(SCRIPTS / "traffic_figures.py")

if TR_CELLS:
    PAPER_SECTIONS += ["results/sections/85-traffic.md"]
    PAPER_FIGURES += [f"{TR_DIR}/comparison.png", f"{TR_DIR}/run/time-space.png", f"{TR_DIR}/run/snapshots.png",
                      f"{TR_DIR}/run/traffic.gif"]


wildcard_constraints:
    tr_study="|".join(re.escape(s) for s in TR_GRIDS) or "NO_STUDY",
    tr_cell=r"[A-Za-z0-9-]+_q\d+(\.\d+)?_[a-z]+",


rule traffic_cell:
    input:
        template=lambda wc: f"{TR_TEMPLATES}/{wc.tr_cell.rsplit('_', 2)[0]}.toml",
        script=SCRIPTS / "traffic_cell.py",
        code=TR_CELL_CODE,
    output:
        json="results/studies/traffic/{tr_study}/cells/{tr_cell}.json",
        runs=directory("results/studies/traffic/{tr_study}/runs/{tr_cell}"),
    params:
        runs=lambda wc: TR_GRIDS[wc.tr_study].get("runs", 2),
        seed=lambda wc: TR_GRIDS[wc.tr_study].get("seed", 0),
    log:
        "results/logs/studies/traffic-{tr_study}/{tr_cell}.log",
    shell:
        "{PYTHON} {input.script} --template {input.template} --cell {wildcards.tr_cell} --runs {params.runs}"
        " --seed {params.seed} --keep {output.runs} --out {output.json} 2> {log}"


rule traffic_run_figures:
    input:
        cell=f"{TR_DIR}/cells/{TR_SHOWN}.json",
        runs=f"{TR_DIR}/runs/{TR_SHOWN}",
        script=SCRIPTS / "traffic_figures.py",
        code=TR_FIGURE_CODE,
    output:
        figures=expand(f"{TR_DIR}/run/{{name}}.{{ext}}", name=["time-space", "snapshots"], ext=["png", "pdf"]),
        gif=f"{TR_DIR}/run/traffic.gif",
        fragment=f"{TR_DIR}/run/fragment.md",
    params:
        run=lambda wc, input: input.runs if TR_GRID.get("runs", 2) == 1 else f"{input.runs}/run-0",
    log:
        f"results/logs/studies/traffic-{TR_STUDY}/figures.log",
    shell:
        "{PYTHON} {input.script} --cell-json {input.cell} --run {params.run} --out {TR_DIR}/run"
        " --link {TR_DIR}/run --fragment {output.fragment} 2> {log}"


rule traffic_table:
    input:
        cells=expand(f"{TR_DIR}/cells/{{cell}}.json", cell=TR_CELLS),
        fragment=f"{TR_DIR}/run/fragment.md",
        script=SCRIPTS / "traffic_table.py",
        code=TR_TABLE_CODE,
    output:
        csv=f"{TR_DIR}/table.csv",
        measures=f"{TR_DIR}/measures.json",
        figures=expand(f"{TR_DIR}/comparison.{{ext}}", ext=["png", "pdf"]),
        section="results/sections/85-traffic.md",
    params:
        vehicles=TR_GRID.get("vehicles", []),
        rates=TR_GRID.get("rates", []),
        runs=TR_GRID.get("runs", 2),
        seed=TR_GRID.get("seed", 0),
        drivers=TR_GRID.get("drivers", ["autopilot", "sumo"]),
    log:
        f"results/logs/studies/traffic-{TR_STUDY}/table.log",
    shell:
        "{PYTHON} {input.script} --cells {input.cells} --mode {TR_STUDY} --vehicles {params.vehicles}"
        " --rates {params.rates} --drivers {params.drivers} --runs {params.runs} --seed {params.seed} --out {TR_DIR}"
        " --figure-link {TR_DIR}/comparison.png --extra {input.fragment} --section {output.section} 2> {log}"


# The grid's results as a committed benchmark (run on demand, never by the default build), e.g. the full grid:
#   snakemake -c2 --config traffic_study=full -- benchmarks/traffic-study.md
# writes benchmarks/traffic-study.md (the section's tables, headed by the grid, commit and CPU seconds)
# and benchmarks/traffic-study.csv (the per-cell table), from results/studies/traffic/<grid>/.
rule traffic_benchmark:
    input:
        section="results/sections/85-traffic.md",
        csv=f"{TR_DIR}/table.csv",
        measures=f"{TR_DIR}/measures.json",
        cells=expand(f"{TR_DIR}/cells/{{cell}}.json", cell=TR_CELLS),
    output:
        md="benchmarks/traffic-study.md",
        csv="benchmarks/traffic-study.csv",
    params:
        study=TR_STUDY,
    shell:
        "{PYTHON} {SCRIPTS}/traffic_benchmark.py --study {params.study} --section {input.section}"
        " --table {input.csv} --cells {input.cells} --md {output.md} --csv {output.csv}"


# Roundabout management on everyone's delay (issue 45, point 5), on demand, never by the default build:
#   snakemake -c2 --config traffic_study=management -- benchmarks/traffic-management.md
# writes benchmarks/traffic-management.md (per cell the truck's, the others' and everyone's delay, safety, the
# vehicles held; per seed everyone's delay of each driver) from the grid's cells and their runs' commands.csv.
rule traffic_management:
    input:
        cells=expand(f"{TR_DIR}/cells/{{cell}}.json", cell=TR_CELLS),
        runs=expand(f"{TR_DIR}/runs/{{cell}}", cell=TR_CELLS),
        script=SCRIPTS / "traffic_management.py",
    output:
        md="benchmarks/traffic-management.md",
    params:
        study=TR_STUDY,
    shell:
        "{PYTHON} {input.script} --study {params.study} --cells {input.cells} --runs-root {TR_DIR}/runs"
        " --md {output.md}"
