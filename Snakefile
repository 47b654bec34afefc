"""Rebuild every solve, figure, table and the paper: `snakemake -c2` (see workflows/README.md)."""

from pathlib import Path

configfile: str(Path(workflow.basedir) / "workflows" / "config.yaml")

# Rule files append to these: Markdown fragments (sorted by file name into the paper)
# and the figure files those fragments link to (so the paper waits for them).
PAPER_SECTIONS = []
PAPER_FIGURES = []

include: "workflows/rules/common.smk"

for _rule_file in sorted(Path(workflow.basedir, "workflows", "rules").glob("*.smk")):
    if _rule_file.name != "common.smk":
        include: str(_rule_file)


rule all:
    default_target: True
    input:
        "results/paper/paper.html",
        "results/tables/scenarios.csv",
        "results/tables/scenarios.md",
        PAPER_SECTIONS,
        PAPER_FIGURES,
        OPTIONAL_TARGETS,
