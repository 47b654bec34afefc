"""Assemble the paper: Markdown fragments (in file-name order) into results/paper/paper.md and one
self-contained HTML file (MathML for the math, figures embedded as base64 PNG; no network needed).

The conventions shared with the PDF (workflows/scripts/paper_pdf.py's docstring has them all):
``[@key]`` citations numbered in order of first citation and listed at the ``[REFERENCES]`` paragraph;
a ``Table: caption`` paragraph right before a pipe table captions it as "Table N." (uncaptioned tables take
no number); ``{.unnumbered}`` / ``{.unnumbered .supplementary}`` after a heading's text are dropped here
(HTML headings carry no numbers).
"""

from __future__ import annotations

import argparse
import base64
import html
import re
import sys
from pathlib import Path

import markdown
from latex2mathml.converter import convert as latex_to_mathml
from paper_citations import CitationError, check, cited_keys, link_citations, parse_bib, references_html

# fenced code | inline code | display math | inline math (a lone $ or an escaped \$ is text)
TOKENS = re.compile(r"(```.*?```|`[^`\n]+`|\$\$.+?\$\$|(?<![\\$])\$(?!\s)[^$\n]+?(?<![\s\\])\$(?!\$))", re.S)
IMAGE = re.compile(r'<p>\s*<img alt="([^"]*)" src="([^"]+)"\s*/?>\s*</p>')
LONG_INLINE = 100  # characters of LaTeX above which inline math gets its own scroll box
EXTENSIONS = ["tables", "fenced_code", "toc", "sane_lists"]
CODE = re.compile(r"(```.*?```|`[^`\n]+`)", re.S)
HEADING_ATTRIBUTES = re.compile(r"^(#{1,6} .*?)\s*\{(?:\s*[.#][\w-]+)+\s*\}\s*$", re.M)
CAPTIONED = re.compile(r"<p>Table: (.*?)</p>\s*(<table>|.{0,40})", re.S)
CITE_TOKEN = "ZZCITE{}ZZ"
CITE = re.compile(r"ZZCITE(\d+)ZZ")
REFERENCES = "<p>[REFERENCES]</p>"


def assemble(fragments: list[Path]) -> str:
    """The fragments' text in the order of their file names."""
    ordered = sorted(fragments, key=lambda p: p.name)
    return "\n\n".join(p.read_text().strip() + "\n" for p in ordered)


def protect_math(text: str) -> tuple[str, list[tuple[str, bool]]]:
    """Replace each $...$ / $$...$$ (outside code) by a token Markdown leaves alone."""
    maths: list[tuple[str, bool]] = []

    def swap(m: re.Match) -> str:
        token = m.group(0)
        if token.startswith("`"):
            return token
        display = token.startswith("$$")
        maths.append((token[2:-2] if display else token[1:-1], display))
        return f"\n\nZZMATH{len(maths) - 1}ZZ\n\n" if display else f"ZZMATH{len(maths) - 1}ZZ"

    return TOKENS.sub(swap, text), maths


def mathml(tex: str, display: bool) -> str:
    """MathML for one formula; ``aligned`` becomes an ``array{rl}`` (latex2mathml lacks it)."""
    tex = re.sub(r"\\begin\{(aligned|align\*?)\}", r"\\begin{array}{rl}", tex.strip())
    tex = re.sub(r"\\end\{(aligned|align\*?)\}", r"\\end{array}", tex)
    try:
        if display:
            return f'<div class="display-math">{latex_to_mathml(tex, display="block")}</div>'
        inline = latex_to_mathml(tex, display="inline")
        return f'<span class="long-math">{inline}</span>' if len(tex) > LONG_INLINE else inline
    except Exception as err:  # noqa: BLE001 - any converter failure shows the source instead
        print(f"paper_html: math not converted ({err}): {tex[:80]}", file=sys.stderr)
        return f'<code class="math-error">{html.escape(tex)}</code>'


def restore_math(body: str, maths: list[tuple[str, bool]]) -> str:
    def put(m: re.Match) -> str:
        tex, display = maths[int(m.group(1))]
        return mathml(tex, display)

    body = re.sub(r"<p>ZZMATH(\d+)ZZ</p>", put, body)
    return re.sub(r"ZZMATH(\d+)ZZ", put, body)


def embed_figures(body: str, base: Path) -> str:
    """Each paragraph holding only an image becomes a numbered <figure> with the PNG inlined."""
    number = 0

    def figure(m: re.Match) -> str:
        nonlocal number
        number += 1
        alt, src = html.unescape(m.group(1)), m.group(2)
        data = base64.b64encode((base / src).read_bytes()).decode()
        kind = "gif" if src.lower().endswith(".gif") else "png"
        caption = markdown.markdown(alt)[3:-4]  # inline Markdown (code spans) in the caption
        return (f'<figure id="figure-{number}"><img alt="{html.escape(alt)}" src="data:image/{kind};base64,{data}">'
                f"<figcaption><strong>Figure {number}.</strong> {caption}</figcaption></figure>")

    return IMAGE.sub(figure, body)


def caption_tables(body: str) -> str:
    """Each ``Table: caption`` paragraph before a table becomes that table's numbered caption."""
    number = 0

    def caption(m: re.Match) -> str:
        nonlocal number
        if m.group(2) != "<table>":
            raise CitationError(f"a 'Table:' caption with no table after it: {m.group(1)[:80]!r}")
        number += 1
        return f'<table id="table-{number}">\n<caption><strong>Table {number}.</strong> {m.group(1)}</caption>'

    return CAPTIONED.sub(caption, body)


def cite(text: str, bibliography: str | None) -> tuple[str, list[str], list[str]]:
    """The text with each citation group (outside code) replaced by a token, the groups' HTML and the
    cited keys in order of first citation; a key the bibliography lacks is an error."""
    keys = cited_keys(text)
    if not keys:
        return text, [], []
    entries = parse_bib(bibliography or "")
    check(keys, entries)
    numbers = {k: i for i, k in enumerate(keys, 1)}
    groups: list[str] = []
    parts = CODE.split(text)
    for i in range(0, len(parts), 2):  # the even parts are outside code
        parts[i] = link_citations(parts[i], numbers, CITE_TOKEN, groups)
    return "".join(parts), groups, keys


def restore_citations(body: str, groups: list[str]) -> str:
    """Citation links in the body; in attributes (an image's alt text) the plain labels."""
    body = re.sub(r'(alt|title)="[^"]*"', lambda m: CITE.sub(lambda c: re.sub(r"<[^>]+>", "", groups[int(c[1])]),
                                                              m.group(0)), body)  # fmt: skip
    return CITE.sub(lambda m: groups[int(m[1])], body)


def place_references(body: str, keys: list[str], bibliography: str | None) -> str:
    """The reference list at the ``[REFERENCES]`` paragraph (else appended under its own heading)."""
    if not keys:
        return body.replace(REFERENCES, "")
    listing = references_html(keys, parse_bib(bibliography or ""))
    if REFERENCES in body:
        return body.replace(REFERENCES, listing, 1)
    return body + '\n<h2 id="references">References</h2>\n' + listing


def to_html(text: str, css: str, base: Path, bibliography: str | None = None) -> str:
    """The paper as one self-contained HTML page.

    Parameters
    ----------
    text : str
        The assembled Markdown paper.
    css : str
        Style sheet inlined in the page.
    base : Path
        Folder that the image paths are relative to.
    bibliography : str, optional
        BibTeX source of the cited entries.

    Raises
    ------
    CitationError
        If a citation key is not in the bibliography, or a ``Table:`` caption has no table after it.
    """
    text = HEADING_ATTRIBUTES.sub(r"\1", text)
    protected, maths = protect_math(text)
    protected, groups, keys = cite(protected, bibliography)
    md = markdown.Markdown(extensions=EXTENSIONS, extension_configs={"toc": {"title": "Contents", "toc_depth": "2-3"}})
    body = caption_tables(md.convert(protected))
    body = embed_figures(restore_math(body, maths), base)
    body = place_references(restore_citations(body, groups), keys, bibliography)
    title = next((ln[2:].strip() for ln in text.splitlines() if ln.startswith("# ")), "Paper")
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>{html.escape(title)}</title>\n<style>\n{css}</style>\n</head>\n<body>\n{body}\n</body>\n</html>\n"
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("fragments", nargs="+", type=Path)
    ap.add_argument("--css", type=Path, required=True)
    ap.add_argument("--md", type=Path, required=True, help="the assembled Markdown")
    ap.add_argument("--html", type=Path, required=True)
    ap.add_argument("--base", type=Path, default=Path("."), help="folder that image paths are relative to")
    ap.add_argument("--bib", type=Path, help="BibTeX file of the cited references")
    args = ap.parse_args(argv)
    text = assemble(args.fragments)
    try:
        page = to_html(text, args.css.read_text(), args.base, args.bib.read_text() if args.bib else None)
    except CitationError as err:
        sys.exit(f"paper_html: error: {err}")
    args.md.parent.mkdir(parents=True, exist_ok=True)
    args.md.write_text(text)
    args.html.write_text(page)


if __name__ == "__main__":
    main()
