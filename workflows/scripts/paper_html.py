"""Assemble the paper: Markdown fragments (in file-name order) into results/paper/paper.md and one
self-contained HTML file (MathML for the math, figures embedded as base64 PNG; no network needed)."""

from __future__ import annotations

import argparse
import base64
import html
import re
import sys
from pathlib import Path

import markdown
from latex2mathml.converter import convert as latex_to_mathml

# fenced code | inline code | display math | inline math (a lone $ or an escaped \$ is text)
TOKENS = re.compile(r"(```.*?```|`[^`\n]+`|\$\$.+?\$\$|(?<![\\$])\$(?!\s)[^$\n]+?(?<![\s\\])\$(?!\$))", re.S)
IMAGE = re.compile(r'<p>\s*<img alt="([^"]*)" src="([^"]+)"\s*/?>\s*</p>')
LONG_INLINE = 100  # characters of LaTeX above which inline math gets its own scroll box
EXTENSIONS = ["tables", "fenced_code", "toc", "sane_lists"]


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


def to_html(text: str, css: str, base: Path) -> str:
    protected, maths = protect_math(text)
    md = markdown.Markdown(extensions=EXTENSIONS, extension_configs={"toc": {"title": "Contents", "toc_depth": "2-3"}})
    body = embed_figures(restore_math(md.convert(protected), maths), base)
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
    args = ap.parse_args(argv)
    text = assemble(args.fragments)
    args.md.parent.mkdir(parents=True, exist_ok=True)
    args.md.write_text(text)
    args.html.write_text(to_html(text, args.css.read_text(), args.base))


if __name__ == "__main__":
    main()
