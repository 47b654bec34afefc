"""The paper as a paper: its citations resolve both ways (every key used is in paper/references.bib and every
entry is cited), its sections come in the order of a paper (main part, discussion, limitations, references,
then the supplementary material), and tables are numbered and captioned alike in the HTML and the PDF."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from test_paper_pdf import pdf_text

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import paper_citations  # noqa: E402
import paper_html  # noqa: E402
import paper_pdf  # noqa: E402

BIB = ROOT / "paper" / "references.bib"
TEMPLATES = sorted((ROOT / "paper" / "sections").glob("*.md"))
RULES = sorted((ROOT / "workflows" / "rules").glob("*.smk"))
# the scripts that write fragments (the paper_* scripts only document the syntax, with made-up keys)
GENERATORS = sorted(p for p in (ROOT / "workflows" / "scripts").glob("*.py") if not p.name.startswith("paper_"))
FRAGMENT = re.compile(r"results/sections/([^\"'\s]+\.md)")


def entries() -> dict[str, paper_citations.Entry]:
    return paper_citations.parse_bib(BIB.read_text())


def test_every_citation_in_the_templates_and_generators_resolves():
    keys = set(entries())
    used = {f.name: paper_citations.cited_keys(f.read_text()) for f in TEMPLATES + GENERATORS}
    missing = {name: [k for k in ks if k not in keys] for name, ks in used.items()}
    missing = {n: m for n, m in missing.items() if m}
    assert not missing, f"citation keys not in paper/references.bib: {missing}"
    assert sum(map(len, used.values())) >= len(keys)  # the scan finds citations at all


def test_every_bibliography_entry_is_cited_by_the_templates():
    cited = {k for f in TEMPLATES for k in paper_citations.cited_keys(f.read_text())}
    uncited = sorted(set(entries()) - cited)
    assert not uncited, f"entries of paper/references.bib that no section template cites: {uncited}"


def test_bibliography_entries_are_complete():
    for key, entry in entries().items():
        assert re.fullmatch(r"[a-z0-9]+", key), key
        assert entry.fields.get("title"), key
        if key != "seed":  # the seed paper's text names no authors or year
            assert entry.fields.get("author") and re.fullmatch(r"\d{4}", entry.fields.get("year", "")), key


def test_sections_come_in_the_order_of_a_paper():
    names = {m for f in RULES for m in FRAGMENT.findall(f.read_text())} | {t.name for t in TEMPLATES}
    order = sorted(names)
    assert all(re.fullmatch(r"(\d\d|S\d)-[a-z0-9-]+\.md", n) for n in order), order
    main = [n for n in order if n[0].isdigit()]
    assert main[-3:] == ["95-discussion.md", "96-limitations.md", "97-references.md"]
    supplementary = order[len(main):]
    assert supplementary[0] == "S0-supplementary.md"
    for part in ("appendix-derivations", "convergence", "indirect", "reproduction-notes"):
        assert any(part in n for n in supplementary), f"{part} is not in the supplementary material"
    assert "[REFERENCES]" in (ROOT / "paper" / "sections" / "97-references.md").read_text()
    assert "{.unnumbered .supplementary}" in (ROOT / "paper" / "sections" / "S0-supplementary.md").read_text()


PAPER = """# A test paper

Solved by Ipopt [@ipopt] and CasADi [@casadi; @betts2010, Ch. 4]; Ipopt again [@ipopt]; `[@notakey]` is code.

| a | b |
| --- | --- |
| 1 | 2 |

Table: The first *captioned* table.

| c | d |
| --- | --- |
| 3 | 4 |

Table: The second.

| e | f |
| --- | --- |
| 5 | 6 |

## References {.unnumbered}

[REFERENCES]

## Supplementary material {.unnumbered .supplementary}

## Notes
"""


def test_html_numbers_citations_and_tables():
    page = paper_html.to_html(PAPER, "", Path("."), BIB.read_text())
    body = page[page.index("<body>"):]
    assert re.search(r'Ipopt <a class="cite" href="#ref-ipopt">\[1\]</a>', body)
    assert '[2]</a>, <a class="cite" href="#ref-betts2010">[3, Ch. 4]</a>' in body
    assert "<code>[@notakey]</code>" in body
    assert "<strong>Table 1.</strong> The first <em>captioned</em> table." in body
    assert "<strong>Table 2.</strong> The second." in body and "Table 3." not in body
    assert body.count("<table") == 3 and body.count("<caption>") == 2
    refs, supplementary = body.index('id="ref-ipopt"'), body.index("Supplementary material</h2>")
    assert body.index("References</h2>") < refs < supplementary  # the list where [REFERENCES] is
    assert "{.unnumbered" not in body and "[REFERENCES]" not in body
    assert 'id="ref-casadi"><span class="ref-label">[2]</span> J. A. E. Andersson' in body
    assert body.count('<li id="ref-') == 3  # only the cited entries


def test_html_unknown_key_or_stray_caption_is_one_line(tmp_path):
    with pytest.raises(paper_citations.CitationError, match="nosuchkey"):
        paper_html.to_html("# T\n\nText [@nosuchkey].\n", "", Path("."), BIB.read_text())
    with pytest.raises(paper_citations.CitationError, match="no table after it"):
        paper_html.to_html("# T\n\nTable: lost caption\n\nText.\n", "", Path("."), BIB.read_text())
    md = tmp_path / "00-a.md"
    md.write_text("# T\n\nText [@nosuchkey].\n")
    css = tmp_path / "c.css"
    css.write_text("")
    out = tmp_path / "p.html"
    args = [str(md), "--css", str(css), "--bib", str(BIB), "--md", str(tmp_path / "p.md"), "--html", str(out)]
    with pytest.raises(SystemExit) as stop:
        paper_html.main(args)
    assert str(stop.value) == "paper_html: error: citation key(s) not in paper/references.bib: nosuchkey"
    assert not out.exists()


def test_pdf_numbers_citations_tables_and_supplementary_sections(tmp_path):
    md = tmp_path / "paper.md"
    md.write_text(PAPER + "\n## More\n")
    out = tmp_path / "paper.pdf"
    paper_pdf.build(md, out, root=tmp_path, bibliography=BIB)
    text = re.sub(r"[ \u00a0]+", " ", pdf_text(out))
    assert "Ipopt [1] and CasADi [2], [3, Ch. 4]; Ipopt again [1]" in text
    assert "Table 1. The first captioned table." in text and "Table 2. The second." in text
    assert "Table 3" not in text  # the uncaptioned table takes no number
    # the first caption sits above the second table, not under the first (pandoc would attach it there)
    assert text.index("1 2") < text.index("Table 1.") < text.index("3 4") < text.index("Table 2.") < text.index("5 6")
    assert text.index("References") < text.index("[3] J. T. Betts") < text.index("Supplementary material")
    assert "S1 Notes" in text and "S2 More" in text
    assert "[4]" not in text  # only the three cited entries are listed


def test_pdf_unknown_key_and_stray_caption_are_errors(tmp_path):
    with pytest.raises(paper_pdf.PaperError, match="citation key.*nosuchkey"):
        paper_pdf.to_typst("# T\n\nText [@nosuchkey].\n", tmp_path, BIB.read_text())
    with pytest.raises(paper_pdf.PaperError, match="no table after it: 'Table: lost caption'"):
        paper_pdf.to_typst("# T\n\nTable: lost caption\n\nText.\n", tmp_path, BIB.read_text())


def test_pdf_sets_a_wide_table_smaller_so_its_words_fit(tmp_path):
    narrow = "| a | b |\n| --- | --- |\n| 1 | 2 |\n"
    wide = "| " + " | ".join(f"conflicting{i}" for i in range(14)) + " |\n" + "| --- " * 14 + "|\n"
    wide += "| " + " | ".join("cooperative" for _ in range(14)) + " |\n"
    source, _ = paper_pdf.to_typst(f"# T\n\n{narrow}\n\n{wide}", tmp_path)
    sizes = [float(m) for m in re.findall(r"kind: table\): set text\(size: ([\d.]+)pt\)", source)]
    assert len(sizes) == 2 and sizes[0] == paper_pdf.TABLE_PT  # the preamble's size, then the wide table's
    assert paper_pdf.TABLE_MIN_PT <= sizes[1] < paper_pdf.TABLE_PT
    paper_pdf.compile_pdf(source, tmp_path, [])  # the shrunk table still compiles


def test_claims_table_of_the_derivation_report_is_captioned():
    import paper_sections  # noqa: PLC0415 - imports the model package, only this test needs it

    report = "# Checks\n\nText.\n\n| claim | section | verdict |\n| --- | --- | --- |\n| `a` | 2 | holds |\n\n## Part\n"
    ctx = paper_sections.Context({}, {}, [], {}, "", report, Path("f"))
    out = paper_sections.derivation_report(ctx)
    assert out.index("Table: Every claim") < out.index("| claim | section | verdict |")
    assert "### Part" in out and "# Checks" not in out
    page = paper_html.to_html(out, "", Path("."))
    assert "<strong>Table 1.</strong> Every claim" in page


def test_reversing_and_clockwise_runs_are_flagged_and_one_costate_figure_stays_in_the_main_part(tmp_path):
    import pandas as pd  # noqa: PLC0415
    import paper_sections  # noqa: PLC0415

    from model.plotting.results import Result  # noqa: PLC0415

    traj = pd.DataFrame({"t": [0.0, 0.5, 1.0], "u1": [-0.5, 0.2, 1.0], "u2": [0.0, 0.1, 0.0]})
    summary = {"status": "optimal", "valid": True, "final_time": 1.0, "energy": 0.3, "iterations": 5,
               "solve_seconds": 0.1, "intervals": 2, "pass": "cw", "swept_angle": -3.1, "min_clearance": 0.0,
               "min_clearance_dense": 0.0}
    back, ahead = Result("back", summary, traj), Result("ahead", {**summary, "pass": "ccw"}, traj.abs())
    notes = paper_sections.direction_notes(back)
    assert "**It reverses**: u1 < 0 on 1 of its 3 nodes" in notes and "clockwise" in notes
    assert paper_sections.direction_notes(ahead) == ""
    ctx = paper_sections.Context({"back": back, "ahead": ahead}, {}, ["ahead", "back"], {}, "", "", Path("f"),
                                 results_dir=tmp_path)
    main = paper_sections.scenario_sections(ctx)
    assert main.count("costates.png") == 1 and "f/ahead/costates.png" in main
    assert "were not checked under grid refinement" in main and "no transversality condition" in main
    assert "**It reverses**" in main
    supplementary = paper_sections.costate_figures(ctx)
    assert supplementary.count("costates.png") == 1 and "f/back/costates.png" in supplementary
