"""The paper: section templates (paper/sections/*.md) rendered from results into Markdown
fragments, then every fragment in PAPER_SECTIONS assembled (sorted by file name) into one
self-contained HTML file, and into a PDF when pandoc and a LaTeX engine are installed."""

from pathlib import Path

SECTION_TEMPLATES = sorted(glob(str(ROOT / "paper" / "sections" / "*.md")))
OWN_SECTIONS = [f"results/sections/{Path(t).name}" for t in SECTION_TEMPLATES]
PAPER_SECTIONS += OWN_SECTIONS
PAPER_FIGURES += FIGURES


rule paper_sections:
    input:
        templates=SECTION_TEMPLATES,
        scenarios=[SCENARIO_FILES[s] for s in SCENARIOS],
        solves=solve_outputs(SCENARIOS),
        claims="results/derivations/claims.json",
        report="results/derivations/report.md",
        table="results/tables/scenarios.md",
        script=SCRIPTS / "paper_sections.py",
        helpers=closure(SCRIPTS / "paper_sections.py"),
    output:
        OWN_SECTIONS,
    shell:
        "{PYTHON} {input.script} --templates {input.templates} --scenarios {input.scenarios}"
        " --paper-scenarios {PAPER_SCENARIOS} --results results --out results/sections"


def paper_sections(wildcards):
    """Every fragment any rule file registered, in the order they appear in the paper."""
    return sorted(PAPER_SECTIONS, key=lambda p: Path(p).name)


rule paper_html:
    input:
        sections=paper_sections,
        figures=lambda wildcards: PAPER_FIGURES,
        css=ROOT / "paper" / "paper.css",
        script=SCRIPTS / "paper_html.py",
    output:
        md="results/paper/paper.md",
        html="results/paper/paper.html",
    shell:
        "{PYTHON} {input.script} {input.sections} --css {input.css} --md {output.md} --html {output.html}"


if shutil.which("pandoc") and any(shutil.which(e) for e in ("xelatex", "lualatex", "pdflatex")):
    OPTIONAL_TARGETS.append("results/paper/paper.pdf")

    rule paper_pdf:
        input:
            md="results/paper/paper.md",
            figures=lambda wildcards: PAPER_FIGURES,
        output:
            "results/paper/paper.pdf",
        shell:
            "pandoc {input.md} --from markdown+tex_math_dollars --resource-path=. -o {output}"
