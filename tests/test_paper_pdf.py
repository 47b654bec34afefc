"""The PDF paper (workflows/scripts/paper_pdf.py): a small synthetic Markdown paper is typeset with pandoc
and Typst, its first page rendered with pypdfium2 and read back; broken math stops the build with one line
naming the formula and leaves no PDF."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pypdfium2 as pdfium
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflows" / "scripts"))

import paper_pdf  # noqa: E402

BIB = ROOT / "paper" / "references.bib"
PAPER = r"""# Roundabout trajectories, a test paper

Some text with inline math $u_1^2 + u_2^2 \le 1$ and `code`, solved by Ipopt [@ipopt].

[TOC]

## Model

The energy is

$$J = \frac{1}{2}\int_0^{T_f} \left(u_1^2 + u_2^2\right)\,dt$$

and the dynamics are

$$\begin{aligned} \dot x &= u_1\cos\theta \\ \dot y &= u_1\sin\theta \end{aligned}$$

Table: Two scenarios.

| scenario | arcs | E |
| --- | --- | ---: |
| `s1` | - + | 0.2584 |
| `s2` | + | 0.4782 |

![A wobbly line drawn by the test](fig/line.png)

## References {.unnumbered}

[REFERENCES]
"""


def make_png(path: Path) -> None:
    """A small RGB PNG with a diagonal dark line on white."""
    pixels = np.full((60, 90, 3), 255, dtype=np.uint8)
    for i in range(60):
        pixels[i, int(i * 1.5)] = (20, 40, 160)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels).save(path)


def write_paper(folder: Path, text: str = PAPER) -> Path:
    make_png(folder / "fig" / "line.png")
    md = folder / "paper.md"
    md.write_text(text)
    return md


def pdf_text(pdf: Path) -> str:
    doc = pdfium.PdfDocument(str(pdf))
    try:
        return "\n".join(doc[i].get_textpage().get_text_range() for i in range(len(doc)))
    finally:
        doc.close()


def test_synthetic_paper_builds_a_readable_pdf(tmp_path):
    md = write_paper(tmp_path)
    out, png = tmp_path / "out" / "paper.pdf", tmp_path / "out" / "page1.png"
    paper_pdf.build(md, out, root=tmp_path, bibliography=BIB)
    pages = paper_pdf.render_pages(out, [png])
    assert pages >= 1
    pixels = np.asarray(Image.open(png).convert("L"), dtype=float)
    assert pixels.var() > 0, "page 1 rendered blank"
    text = pdf_text(out)
    assert "Roundabout trajectories" in text  # the title
    assert "(1)" in text and "(2)" in text  # numbered display equations
    assert re.search(r"Figure\s1\. A wobbly line drawn by the test", text)  # the alt text became the caption
    assert re.search(r"Table\s1\. Two scenarios", text)
    assert "Ipopt [1]" in text
    assert "0.4782" in text  # the table
    assert "•" not in text, "a table cell '- +' was typeset as a bullet list"
    assert "References" in text and "Interior-Point".lower() in text.lower()  # Ipopt's paper, the one cited
    assert "CasADi" not in text  # an entry nobody cites is not listed
    assert not list(out.parent.glob(".*.tmp"))


def test_unconvertible_math_stops_with_one_line_and_no_pdf(tmp_path, capsys):
    md = write_paper(tmp_path, PAPER.replace(r"\le 1$", r"\le \frac{1$"))
    out = tmp_path / "paper.pdf"
    with pytest.raises(SystemExit) as stop:
        paper_pdf.main(["--md", str(md), "--out", str(out), "--root", str(tmp_path)])
    message = str(stop.value)
    assert message.startswith("paper_pdf: error: math not converted") and "\n" not in message
    assert r"\frac{1" in message
    assert not out.exists() and not list(tmp_path.glob(".*.tmp"))


def test_formula_rejected_by_typst_is_named(tmp_path):
    source, formulas = paper_pdf.to_typst("# T\n\nText $a + b$ here.\n", tmp_path)
    assert formulas == ["a + b"]
    broken = source.replace("$a + b$", "$a + #no_such_thing$")
    assert broken != source
    with pytest.raises(paper_pdf.PaperError, match=r"formula 1 .*\$a \+ b\$"):
        paper_pdf.compile_pdf(broken, tmp_path, formulas)


def test_missing_image_is_an_error(tmp_path):
    md = tmp_path / "paper.md"
    md.write_text("# T\n\n![caption](nowhere.png)\n")
    with pytest.raises(paper_pdf.PaperError, match="image not found: nowhere.png"):
        paper_pdf.build(md, tmp_path / "paper.pdf", root=tmp_path)
    assert not (tmp_path / "paper.pdf").exists()
