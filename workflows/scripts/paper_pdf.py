"""Typeset the assembled paper (results/paper/paper.md) as a PDF without a system TeX: pandoc (from the
pypandoc_binary wheel) turns the Markdown and its TeX math into Typst markup, the typst package compiles it
with its embedded fonts, and pypdfium2 renders the first pages to PNG for a look.

The first `# ` heading becomes the title, `[TOC]` a table of contents, display equations are numbered, an
image alone in its paragraph becomes a figure captioned by its alt text, kept where the text puts it (no
floating into later sections or into a table).

Conventions the fragments share with workflows/scripts/paper_html.py (so HTML and PDF agree):

- Citations: ``[@key]``, ``[@a; @b]`` or ``[@key, p. 5]`` (pandoc's syntax) with keys of paper/references.bib;
  Typst numbers them in the order of first citation (IEEE style). A key the bibliography lacks is an error.
- ``[REFERENCES]``, a paragraph of its own, is where the bibliography goes (under the heading the Markdown
  gives it); without it the bibliography is appended with its own heading.
- Tables: a paragraph ``Table: caption`` right before a pipe table (a blank line between) captions it;
  it is numbered "Table N." above the table. A table without one gets no number. A ``Table:`` paragraph
  that no table follows is an error. A table whose longest words would not fit the text width at 8 pt
  is set smaller (down to 6 pt); one still wider needs fewer columns or shorter words.
- Headings: ``{.unnumbered}`` after a heading's text leaves it unnumbered; ``{.unnumbered .supplementary}``
  starts the supplementary material: the sections after it are numbered S1, S2, ...

Math that pandoc cannot convert, or that Typst rejects, stops the build with one line naming the TeX
expression; the PDF is written to a temporary file and renamed, so a failed build leaves no PDF behind.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import pypandoc
import pypdfium2 as pdfium
import typst
from PIL import Image

# Pandoc's Markdown, less what the HTML build (Python-Markdown) reads as plain text: TeX outside $...$,
# ^superscript^ and ~subscript~ (u1max^2+u2max^2 in a table header), @citations, YAML blocks; and no
# heading labels (nothing refers to them, and pandoc < 3.7 writes labels Typst rejects, e.g. with "²").
READER = (
    "markdown+tex_math_dollars-raw_tex-superscript-subscript-example_lists-yaml_metadata_block"
    "-auto_identifiers-implicit_header_references-table_captions"
)  # table_captions off: a caption after a table would be taken by it; prepare() attaches captions itself
BIB_KEY = re.compile(r"^\s*@\w+\s*\{\s*([^,\s]+)\s*,", re.M)  # the key of each BibTeX entry
CAPTION = "Table:"  # a paragraph starting with this, right before a table, is its caption
MARK_OPEN, MARK_CLOSE = "/*m{}<*/", "/*>m{}*/"  # Typst comments around each formula, to name it on errors
MARK = re.compile(r"/\*m(\d+)<\*/")
# a Str that Typst would read as a list, enum, term or heading marker at the start of a table cell
# (pandoc's Typst writer escapes these in paragraphs but not in cells: `[- +]` became a bullet list)
MARKER = re.compile(r"[-+=/]|\d+\.")
FIGURE_WIDTH = 0.88  # of the text width (A4, 2.3 cm margins: 16.4 cm)
TEXT_WIDTH_CM, MAX_FIGURE_HEIGHT_CM = 16.4, 16.0
TABLE_PT, TABLE_MIN_PT = 8.0, 6.0  # table text size, and the least a wide table is shrunk to
TEXT_WIDTH_PT, CELL_PAD_PT, CHAR_EM = 465.0, 7.5, 0.52  # 16.4 cm; a cell's insets; a character's mean width
TABLE_END = re.compile(r"\n  \)\]\n  , kind: table")  # how pandoc's Typst writer closes a table
LOCATION = re.compile(r"─ (?P<file>[^\s:]+):(?P<line>\d+):(?P<col>\d+)")

PREAMBLE = r"""#set document(title: {meta})
#set page(paper: "a4", margin: (x: 2.3cm, top: 2.5cm, bottom: 2.7cm), numbering: "1")
#set text(font: "New Computer Modern", size: 10.5pt, lang: "en")
#set par(justify: true, leading: 0.6em, spacing: 1.0em)
#show raw: set text(font: "DejaVu Sans Mono", size: 0.82em)
#set heading(numbering: (..n) => if n.pos().len() <= 2 {{ numbering("1.1", ..n) }})
#show heading: set block(above: 1.5em, below: 0.8em)
#show heading.where(level: 1): set text(size: 13pt)
#show heading.where(level: 2): set text(size: 11.5pt)
#show heading.where(level: 3): set text(size: 10.5pt)
#show heading.where(level: 4): set text(size: 10pt, style: "italic", weight: "regular")
#set math.equation(numbering: "(1)")
// a display equation wider than the text is scaled down to fit, its number kept at full size
#show math.equation.where(block: true): eq => layout(size => {{
  let body = math.equation(math.display(eq.body), block: false)
  let natural = measure(body).width
  let room = size.width - 4em.to-absolute()
  if natural <= room {{ eq }} else {{
    let f = room / natural * 100%
    block(grid(columns: (1fr, auto), align: (center + horizon, right + horizon),
      scale(x: f, y: f, reflow: true, body), counter(math.equation).display("(1)")))
  }}
}})
// figures stay where the text puts them (LaTeX's [H]): a float drifted into later sections, or split a table
#show figure.where(kind: image): set figure(placement: none)
#show heading: it => {{ place.flush(); it }}
#show figure.caption: set text(size: 9pt)
#show figure.where(kind: table): set text(size: 8pt)  // TABLE_PT; a wide table gets less (table_size)
#show figure.where(kind: table): set par(justify: false)
#show figure.where(kind: table): set block(breakable: true)
#show figure.where(kind: table): set figure.caption(position: top)
#show figure.where(kind: table): set align(left)
#show figure.where(kind: table): set figure(supplement: [Table])
// a table without a caption takes no number (else the captioned ones would skip numbers)
#show figure.where(kind: table, caption: none): set figure(numbering: none)
#set figure.caption(separator: [. ])
#set table(stroke: (x, y) => if y == 0 {{ (top: 0.8pt) }}, inset: (x: 3.5pt, y: 3pt))
#set table.hline(stroke: 0.5pt)
#show table: set align(left)
#show outline.entry.where(level: 1): set text(weight: "bold")
"""
TITLE = '#align(center, block(below: 1.5em, text(size: 17pt, weight: "bold")[{title}]))\n'

BIBLIOGRAPHY = '\n#bibliography(bytes({source}), title: {title}, style: "ieee")\n'
REFERENCES = "[REFERENCES]"  # a paragraph of its own: the bibliography goes here
REFERENCES_MARK = "/*references here*/"
# after the supplementary heading: the numbering starts again, as S1, S2, ...
SUPPLEMENT = (
    "#counter(heading).update(0)\n"
    '#set heading(numbering: (..n) => if n.pos().len() <= 2 { "S" + numbering("1.1", ..n) })'
)
TOC = '#outline(title: "Contents", depth: 2, indent: auto)'


class PaperError(RuntimeError):
    """The paper cannot be typeset faithfully; the message is one line naming the cause."""


def pandoc_binary() -> str:
    """The pandoc executable shipped in the pypandoc_binary wheel (else the one pypandoc finds)."""
    bundled = Path(pypandoc.__file__).parent / "files" / "pandoc"
    return str(bundled) if bundled.is_file() else pypandoc.get_pandoc_path()


def run_pandoc(text: str, reader: str, writer: str, extra: list[str] | None = None) -> tuple[str, list[dict]]:
    """Convert ``text`` with pandoc.

    Parameters
    ----------
    text : str
        The input document.
    reader, writer : str
        Pandoc input and output formats (e.g. ``"json"``, ``"typst"``).
    extra : list of str, optional
        Further pandoc options.

    Returns
    -------
    tuple of (str, list of dict)
        The converted text and pandoc's log messages (JSON objects with ``type`` and ``contents``).
    """
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.json"
        cmd = [pandoc_binary(), "-f", reader, "-t", writer, "--wrap=none", f"--log={log}", *(extra or [])]
        done = subprocess.run(cmd, input=text, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise PaperError(f"pandoc failed ({done.returncode}): {done.stderr.strip().splitlines()[-1:]}")
        messages = json.loads(log.read_text() or "[]") if log.exists() else []
    return done.stdout, messages


def walk(node: object, change: Callable[[dict], list[dict] | None]) -> None:
    """Apply ``change`` to every element (a dict with key ``t``) of a pandoc JSON tree, depth first.

    ``change`` returns the elements that replace the one it is given, or None to keep it.
    """
    if isinstance(node, dict):
        for value in node.values():
            walk(value, change)
    elif isinstance(node, list):
        out: list = []
        for item in node:
            walk(item, change)
            new = change(item) if isinstance(item, dict) and "t" in item else None
            out.extend([item] if new is None else new)
        node[:] = out


def plain_text(inlines: list[dict]) -> str:
    """The text of a list of pandoc inlines (for the PDF's title metadata)."""
    parts: list[str] = []

    def collect(el: dict) -> None:
        if el["t"] in ("Str", "Code", "Math", "RawInline"):
            parts.append(el["c"] if el["t"] == "Str" else el["c"][1])
        elif el["t"] in ("Space", "SoftBreak", "LineBreak"):
            parts.append(" ")

    walk(inlines, collect)
    return "".join(parts).strip()


def raw(text: str, block: bool = False) -> dict:
    """A pandoc raw Typst element."""
    return {"t": "RawBlock" if block else "RawInline", "c": ["typst", text]}


def take_title(ast: dict) -> list[dict]:
    """Remove the first level-1 heading and return its inlines; other headings move up one level."""
    blocks = ast["blocks"]
    first = next((i for i, b in enumerate(blocks) if b["t"] == "Header"), None)
    title = blocks.pop(first)["c"][2] if first is not None and blocks[first]["c"][0] == 1 else []

    def shift(el: dict) -> None:
        if el["t"] == "Header" and title:
            el["c"][0] = max(1, el["c"][0] - 1)

    walk(blocks, shift)
    return title


def prepare(ast: dict, root: Path) -> list[str]:
    """Rewrite the document for Typst in place and return its formulas (TeX) in order.

    Each formula is wrapped in Typst comment marks (to name it if Typst rejects it); ``[TOC]`` becomes
    an outline and ``[REFERENCES]`` the place of the bibliography; ``Table:`` paragraphs become the
    captions of the tables after them; the supplementary heading restarts the numbering as S1, S2, ...;
    image paths become root-relative and must exist; raw HTML other than comments stops the build, since
    the Typst writer would drop it.
    """
    formulas: list[str] = []
    attach_captions(ast["blocks"])

    def change(el: dict) -> list[dict] | None:
        kind = el["t"]
        if kind == "Math":
            formulas.append(el["c"][1])
            n = len(formulas) - 1
            return [raw(MARK_OPEN.format(n)), el, raw(MARK_CLOSE.format(n))]
        if kind == "Para" and [c.get("c") for c in el["c"]] == ["[TOC]"]:
            return [raw(TOC, block=True)]
        if kind == "Para" and [c.get("c") for c in el["c"]] == [REFERENCES]:
            return [raw(REFERENCES_MARK, block=True)]
        if kind == "Table" and (size := table_size(el)) < TABLE_PT:
            shrink = f"#show figure.where(kind: table): set text(size: {size:.2f}pt)"
            return [raw("#[", block=True), raw(shrink, block=True), el, raw("]", block=True)]
        if kind == "Header" and "supplementary" in el["c"][1][1]:
            return [raw("#pagebreak(weak: true)", block=True), el, raw(SUPPLEMENT, block=True)]
        if kind == "Image":
            el["c"][2][0] = image_path(el["c"][2][0], root)
            size_image(el, root)
        if kind in ("Plain", "Para") and el["c"] and el["c"][0]["t"] == "Str" and MARKER.fullmatch(el["c"][0]["c"]):
            mark = el["c"][0]["c"]
            el["c"][0] = raw("\\" + mark if mark in "-+=/" else mark[:-1] + "\\.")
        if kind in ("RawInline", "RawBlock") and el["c"][0] != "typst":
            if not el["c"][1].lstrip().startswith("<!--"):
                raise PaperError(f"raw {el['c'][0]} has no PDF rendering: {el['c'][1][:80]!r}")
            return []
        return None

    walk(ast["blocks"], change)
    return formulas


def table_size(table: dict) -> float:
    """The text size (pt) at which a table's columns fit the text width: each column as wide as its longest
    word (a word does not break, and one wider than its column overprints the next), plus the insets;
    ``TABLE_PT`` where that fits, never below ``TABLE_MIN_PT``."""
    _, _, colspecs, head, bodies, foot = table["c"]
    longest = [1] * len(colspecs)
    rows = head[1] + [r for body in bodies for r in body[2] + body[3]] + foot[1]
    for row in rows:
        for col, cell in enumerate(row[1][: len(colspecs)]):
            words = plain_text(cell[4]).split() or [""]
            longest[col] = max(longest[col], *(len(w) for w in words))
    room = TEXT_WIDTH_PT - CELL_PAD_PT * len(colspecs)
    natural = CHAR_EM * sum(longest)  # in units of the text size
    return max(TABLE_MIN_PT, min(TABLE_PT, room / natural)) if natural > 0 and room > 0 else TABLE_MIN_PT


def is_caption(block: dict) -> bool:
    """Whether a block is a ``Table: ...`` paragraph."""
    inlines = block["c"] if block.get("t") == "Para" else []
    return bool(inlines) and inlines[0].get("t") == "Str" and inlines[0]["c"] == CAPTION


def attach_captions(blocks: list) -> None:
    """Make each ``Table: caption`` paragraph the caption of the table right after it (in place, at every
    depth); a caption paragraph with no table after it is an error."""
    out: list = []
    for i, block in enumerate(blocks):
        if isinstance(block, list):
            attach_captions(block)
        elif isinstance(block, dict):
            for value in block.values():
                if isinstance(value, list):
                    attach_captions(value)
        if isinstance(block, dict) and is_caption(block):
            after = blocks[i + 1] if i + 1 < len(blocks) else None
            if not (isinstance(after, dict) and after.get("t") == "Table"):
                raise PaperError(f"a '{CAPTION}' caption with no table after it: {plain_text(block['c'])[:80]!r}")
            inlines = block["c"][1:]
            while inlines and inlines[0]["t"] in ("Space", "SoftBreak"):
                inlines = inlines[1:]
            after["c"][1] = [None, [{"t": "Plain", "c": inlines}]]
            continue
        out.append(block)
    blocks[:] = out


def cited_keys(ast: dict) -> list[str]:
    """The citation keys of a pandoc document, in order of first use."""
    keys: list[str] = []

    def collect(el: dict) -> None:
        if el["t"] == "Cite":
            keys.extend(c["citationId"] for c in el["c"][0] if c["citationId"] not in keys)

    walk(ast["blocks"], collect)
    return keys


def check_citations(keys: list[str], bibliography: str | None) -> None:
    """Every cited key must be an entry of the bibliography (Typst would stop on it less clearly)."""
    defined = set(BIB_KEY.findall(bibliography or ""))
    missing = [k for k in keys if k not in defined]
    if missing:
        where = "paper/references.bib" if bibliography else "the bibliography (none given)"
        raise PaperError(f"citation key(s) not in {where}: {', '.join(missing)}")


def image_path(src: str, root: Path) -> str:
    """The Typst path of an image given relative to ``root``; a missing file is an error."""
    if re.match(r"^[a-z]+://", src):
        raise PaperError(f"remote image cannot be embedded: {src}")
    if not (root / src).is_file():
        raise PaperError(f"image not found: {src} (relative to {root})")
    return "/" + Path(src).as_posix().lstrip("/")


def size_image(el: dict, root: Path) -> None:
    """Give an image without a size the figure width, or a height cap if it would be taller than that."""
    pairs = el["c"][0][2]
    if any(key in ("width", "height") for key, _ in pairs):
        return
    with Image.open(root / el["c"][2][0].lstrip("/")) as img:
        ratio = img.height / img.width
    if ratio * FIGURE_WIDTH * TEXT_WIDTH_CM > MAX_FIGURE_HEIGHT_CM:
        pairs.append(["height", f"{MAX_FIGURE_HEIGHT_CM}cm"])
    else:
        pairs.append(["width", f"{FIGURE_WIDTH:.0%}"])


def check_math_log(messages: list[dict]) -> None:
    """Fail on the first formula pandoc could not convert (it would print the TeX source instead)."""
    for msg in messages:
        if msg.get("type") == "CouldNotConvertTeXMath":
            reason = msg.get("message", "").strip().splitlines()
            hint = f" ({reason[-1].strip()})" if reason else ""
            raise PaperError(f"math not converted to Typst{hint}: ${msg.get('contents', '')}$")


def typst_string(text: str) -> str:
    """``text`` as a Typst string literal."""
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "")
    return f'"{escaped}"'


def to_typst(markdown: str, root: Path, bibliography: str | None = None) -> tuple[str, list[str]]:
    """Typst source of a Markdown paper.

    Parameters
    ----------
    markdown : str
        The paper: Markdown with TeX math in ``$...$`` and ``$$...$$``.
    root : Path
        Folder that the image paths are relative to (it becomes the Typst root).
    bibliography : str, optional
        BibTeX source of the cited entries, listed at the `[REFERENCES]` mark (else at the end).

    Returns
    -------
    tuple of (str, list of str)
        The Typst source and its formulas (TeX), numbered as in the marks of the source.

    Raises
    ------
    PaperError
        If a formula cannot be converted, an image is missing, or raw HTML would be dropped.
    """
    tree, _ = run_pandoc(markdown, READER, "json", ["--columns=10000"])  # tables: columns sized by content
    ast = json.loads(tree)
    title = take_title(ast)
    formulas = prepare(ast, root)
    body, messages = run_pandoc(json.dumps(ast), "json", "typst")
    check_math_log(messages)
    check_citations(cited_keys(ast), bibliography)
    body = TABLE_END.sub(r"\n    table.hline(stroke: 0.8pt),\g<0>", body)  # a bottom rule under each table
    head = PREAMBLE.format(meta=typst_string(plain_text(title)) if title else "none")
    head += TITLE.format(title=inline_typst(ast, title)) if title else ""
    return head + "\n" + place_bibliography(body, bibliography), formulas


def place_bibliography(body: str, bibliography: str | None) -> str:
    """The body with the bibliography at its ``[REFERENCES]`` mark (untitled: the Markdown has the
    heading), else appended under its own heading "References"; without a bibliography the mark is dropped."""
    if not bibliography:
        return body.replace(REFERENCES_MARK, "")
    source = typst_string(bibliography)
    if REFERENCES_MARK in body:
        return body.replace(REFERENCES_MARK, BIBLIOGRAPHY.format(source=source, title="none"), 1)
    return body + BIBLIOGRAPHY.format(source=source, title='"References"')


def inline_typst(ast: dict, inlines: list[dict]) -> str:
    """Typst markup of a list of pandoc inlines (the title)."""
    doc = {**ast, "blocks": [{"t": "Plain", "c": inlines}]}
    text, messages = run_pandoc(json.dumps(doc), "json", "typst")
    check_math_log(messages)
    return text.strip()


def compile_pdf(source: str, root: Path, formulas: list[str]) -> bytes:
    """Compile Typst source to PDF bytes with the fonts embedded in the typst package.

    Parameters
    ----------
    source : str
        Typst markup (as made by :func:`to_typst`).
    root : Path
        The Typst project root: image paths in ``source`` are relative to it.
    formulas : list of str
        The TeX of the marked formulas, to name the one an error lies in.

    Returns
    -------
    bytes
        The PDF.

    Raises
    ------
    PaperError
        If Typst reports an error; the message names the formula it lies in, if any.
    """
    stamp = os.environ.get("SOURCE_DATE_EPOCH")  # a reproducible creation date, if asked for
    extra = {"timestamp": int(stamp)} if stamp else {}
    try:
        pdf, warnings = typst.compile_with_warnings(
            source.encode(), root=str(root), format="pdf", ignore_system_fonts=True, **extra
        )
    except typst.TypstError as err:
        raise PaperError(describe_error(err, source, formulas)) from None
    for warning in warnings:
        print(f"paper_pdf: typst warning: {getattr(warning, 'message', warning)}", file=sys.stderr)
    return pdf


def describe_error(err: typst.TypstError, source: str, formulas: list[str]) -> str:
    """One line for a Typst error: its message and the TeX formula it lies in, else the source line."""
    message = getattr(err, "message", None) or str(err)
    where = LOCATION.search(getattr(err, "diagnostic", "") or "")
    if not where:
        return f"typst: {message}"
    lines = source.splitlines(keepends=True)
    line = int(where["line"])
    offset = sum(len(s) for s in lines[: line - 1]) + int(where["col"]) - 1
    opened = [m for m in MARK.finditer(source) if m.start() <= offset]
    if opened:
        n = int(opened[-1][1])
        if source.find(MARK_CLOSE.format(n), opened[-1].end()) >= offset:
            return f"typst rejects formula {n + 1} ({message}): ${formulas[n]}$"
    text = lines[line - 1].strip() if line <= len(lines) else ""
    return f"typst: {message} at line {line}: {text[:120]}"


def write_atomically(data: bytes, out: Path) -> None:
    """Write ``data`` to ``out`` through a temporary file in the same folder and a rename."""
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's file is private; the PDF gets the usual permissions
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def render_pages(pdf: Path, pngs: list[Path], scale: float = 1.5) -> int:
    """Render the first pages of ``pdf`` to ``pngs`` (page i to the i-th file) and return the page count.

    Parameters
    ----------
    pdf : Path
        The PDF file.
    pngs : list of Path
        Output PNG files, one per page from the first; a page the PDF lacks is an error.
    scale : float
        Pixels per PDF point (1.5 is 108 dpi).

    Returns
    -------
    int
        Number of pages in the PDF.
    """
    doc = pdfium.PdfDocument(str(pdf))
    try:
        if len(pngs) > len(doc):
            raise PaperError(f"{pdf} has {len(doc)} page(s), {len(pngs)} PNG(s) asked for")
        for i, png in enumerate(pngs):
            png.parent.mkdir(parents=True, exist_ok=True)
            doc[i].render(scale=scale).to_pil().save(png)
        return len(doc)
    finally:
        doc.close()


def build(md: Path, out: Path, root: Path, bibliography: Path | None = None, typ: Path | None = None) -> None:
    """Typeset the Markdown paper ``md`` as the PDF ``out`` (see the module docstring).

    Parameters
    ----------
    md : Path
        The Markdown paper.
    out : Path
        The PDF to write (atomically: nothing is written if the build fails).
    root : Path
        Folder that the image paths in ``md`` are relative to.
    bibliography : Path, optional
        BibTeX file whose entries are listed as References.
    typ : Path, optional
        Where to save the Typst source as well (for inspection).
    """
    bib = bibliography.read_text() if bibliography else None
    source, formulas = to_typst(md.read_text(), root, bib)
    if typ:
        typ.parent.mkdir(parents=True, exist_ok=True)
        typ.write_text(source)
    write_atomically(compile_pdf(source, root, formulas), out)


def main(argv: list[str] | None = None) -> None:
    """Command line: build the PDF and render its first pages; a failure exits with one error line."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--md", type=Path, required=True, help="the assembled Markdown paper")
    ap.add_argument("--out", type=Path, required=True, help="the PDF to write")
    ap.add_argument("--root", type=Path, default=Path("."), help="folder that image paths are relative to")
    ap.add_argument("--bib", type=Path, help="BibTeX file of the References")
    ap.add_argument("--typ", type=Path, help="also save the Typst source here")
    ap.add_argument("--png", type=Path, nargs="*", default=[], help="render pages 1, 2, ... to these PNG files")
    args = ap.parse_args(argv)
    try:
        build(args.md, args.out, args.root, args.bib, args.typ)
        pages = render_pages(args.out, args.png)
    except PaperError as err:
        sys.exit(f"paper_pdf: error: {err}")
    print(f"paper_pdf: {args.out} ({pages} pages)")


if __name__ == "__main__":
    main()
