"""The paper: section templates (paper/sections/*.md) rendered from results into Markdown
fragments, then every fragment in PAPER_SECTIONS assembled (sorted by file name) into one
self-contained HTML file, and typeset as a PDF (pandoc and Typst from PyPI wheels, no LaTeX)."""

import re
from pathlib import Path

SECTION_TEMPLATES = sorted(glob(str(ROOT / "paper" / "sections" / "*.md")))
OWN_SECTIONS = [f"results/sections/{Path(t).name}" for t in SECTION_TEMPLATES]
# the results JSON files the templates read with {{ json PATH KEY }} (the abstract's numbers)
TEMPLATE_JSON = sorted({f"results/{m}" for t in SECTION_TEMPLATES
                        for m in re.findall(r"\{\{\s*json\s+(\S+)", Path(t).read_text())})
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
        json=TEMPLATE_JSON,
        convergence="results/studies/convergence/convergence.json",  # the costate captions
        script=SCRIPTS / "paper_sections.py",
        helpers=closure(SCRIPTS / "paper_sections.py"),
    output:
        OWN_SECTIONS,
    shell:
        "{PYTHON} {input.script} --templates {input.templates} --scenarios {input.scenarios}"
        " --paper-scenarios {PAPER_SCENARIOS} --results results --out results/sections"


def paper_sections(wildcards):
    """Every fragment any rule file registered, in the order they appear in the paper: sorted by file name.

    The main part is ``00-`` to ``96-`` (96-limitations last), ``97-references`` holds the References, and
    the supplementary material follows as ``S0-supplementary`` (its heading), ``S1-...``, ``S2-...`` (digits
    sort before capitals). A rule file puts a fragment in the supplementary material by its name alone.
    """
    return sorted(PAPER_SECTIONS, key=lambda p: Path(p).name)


rule paper_html:
    input:
        sections=paper_sections,
        figures=lambda wildcards: PAPER_FIGURES,
        css=ROOT / "paper" / "paper.css",
        bib=ROOT / "paper" / "references.bib",
        script=SCRIPTS / "paper_html.py",
        helpers=SCRIPTS / "paper_citations.py",
    output:
        md="results/paper/paper.md",
        html="results/paper/paper.html",
    shell:
        "{PYTHON} {input.script} {input.sections} --css {input.css} --bib {input.bib} --md {output.md}"
        " --html {output.html}"


OPTIONAL_TARGETS.append("results/paper/paper.pdf")  # the default target builds the PDF too


rule paper_pdf:
    input:
        md="results/paper/paper.md",
        figures=lambda wildcards: PAPER_FIGURES,
        bib=ROOT / "paper" / "references.bib",
        script=SCRIPTS / "paper_pdf.py",
    output:
        pdf="results/paper/paper.pdf",
        pages=["results/paper/paper-page1.png", "results/paper/paper-page2.png"],
    shell:
        "{PYTHON} {input.script} --md {input.md} --out {output.pdf} --root . --bib {input.bib}"
        " --png {output.pages}"
