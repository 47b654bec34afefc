"""Citations of the HTML paper: pandoc's ``[@key]`` syntax numbered in the order of first citation and the
cited entries of paper/references.bib listed in IEEE style, as Typst does for the PDF (paper_pdf.py).

Only the BibTeX this project writes is read: ``@type{key,`` then ``field = {value},`` lines, values in
braces with LaTeX accents (``{\\"a}``, ``{\\v{C}}``, ``{\\ss}``), ``--`` and ``\\&``.
"""

from __future__ import annotations

import html
import re
import unicodedata
from dataclasses import dataclass, field

ENTRY = re.compile(r"^@(\w+)\s*\{\s*([^,\s]+)\s*,", re.M)
FIELD = re.compile(r"(\w+)\s*=\s*\{")
# [@key], [@a; @b], [@key, p. 5]: keys of letters, digits, '_', '-', ':' and '.' inside
GROUP = re.compile(r"\[((?:\s*@[\w:.-]+[^;\]\[]*;?)+)\]")
ONE = re.compile(r"@([\w:.-]*\w)\s*(?:,\s*([^;]*))?")
ACCENTS = {'"': "\u0308", "'": "\u0301", "`": "\u0300", "^": "\u0302", "~": "\u0303", "v": "\u030c",
           "c": "\u0327", "=": "\u0304", "u": "\u0306", "H": "\u030b", ".": "\u0307"}  # fmt: skip
ACCENT = re.compile(r"\\([\"'`^~=.vcuH])\s*\{?\s*([A-Za-z]|\\i)\s*\}?")
MAX_AUTHORS = 6  # more than this: the first and "et al." (as Typst's IEEE style)


class CitationError(ValueError):
    """A citation that does not resolve, or a bibliography entry that cannot be read."""


@dataclass
class Entry:
    """One BibTeX entry: its type, key and fields (plain Unicode text)."""

    kind: str
    key: str
    fields: dict[str, str] = field(default_factory=dict)


def latex_text(value: str) -> str:
    """Plain Unicode of a BibTeX value: accents resolved, braces dropped, ``--`` an en dash."""
    text = ACCENT.sub(lambda m: ("i" if m[2] == "\\i" else m[2]) + ACCENTS[m[1]], value)
    text = text.replace("{\\ss}", "ß").replace("\\ss", "ß").replace("\\&", "&").replace("--", "–")
    text = re.sub(r"\s+", " ", text.replace("{", "").replace("}", "")).strip()
    return unicodedata.normalize("NFC", text)


def braced(text: str, start: int) -> tuple[str, int]:
    """The text inside the braces that open at ``start - 1``, and the index after the closing brace."""
    depth, i = 1, start
    while depth:
        if i >= len(text):
            raise CitationError(f"unbalanced braces in the bibliography after {text[start - 20:start]!r}")
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    return text[start : i - 1], i


def parse_bib(source: str) -> dict[str, Entry]:
    """The entries of a BibTeX source by key, in file order."""
    entries: dict[str, Entry] = {}
    heads = list(ENTRY.finditer(source))
    for head, after in zip(heads, heads[1:] + [None], strict=True):
        body = source[head.end() : after.start() if after else len(source)]
        entry = Entry(head[1].lower(), head[2])
        pos = 0
        while m := FIELD.search(body, pos):
            value, pos = braced(body, m.end())
            entry.fields[m[1].lower()] = value
        if entry.key in entries:
            raise CitationError(f"bibliography key defined twice: {entry.key}")
        entries[entry.key] = entry
    return entries


def cited_keys(text: str) -> list[str]:
    """Every key cited in ``text`` (code spans and math left out), in order of first citation."""
    keys: list[str] = []
    for group in GROUP.finditer(strip_code(text)):
        for m in ONE.finditer(group[1]):
            if m[1] not in keys:
                keys.append(m[1])
    return keys


def strip_code(text: str) -> str:
    """``text`` without fenced code, inline code spans and math (where @ is not a citation)."""
    return re.sub(r"```.*?```|`[^`\n]+`|\$\$.+?\$\$|\$[^$\n]+\$", " ", text, flags=re.S)


def name(author: str) -> str:
    """``Family, Given`` or ``Given Family`` as ``G. Family``; ``{Literal}`` as it is."""
    author = author.strip()
    if author.startswith("{") and author.endswith("}"):
        return latex_text(author)
    text = latex_text(author)
    family, _, given = text.partition(", ") if ", " in text else (text.rsplit(" ", 1)[-1], "", text.rsplit(" ", 1)[0])
    initials = " ".join(p[0] + "." if not p.endswith(".") else p for p in re.split(r"\s+", given) if p)
    initials = re.sub(r"(\w)\w*-(\w)\w*\.?", r"\1.-\2.", initials)
    return f"{initials} {family}".strip()


def authors(entry: Entry) -> str:
    raw = re.split(r"\s+and\s+", entry.fields.get("author", "")) if entry.fields.get("author") else []
    others = bool(raw) and raw[-1].strip() == "others"
    names = [name(a) for a in raw if a.strip() != "others"]
    if not names:
        return ""
    if others or len(names) > MAX_AUTHORS:
        return f"{names[0]} et al."
    if len(names) == 1:
        return names[0]
    return ", ".join(names[:-1]) + ("," if len(names) > 2 else "") + " and " + names[-1]


def entry_html(entry: Entry) -> str:
    """One reference in IEEE style (HTML-escaped, titles as written in the bibliography)."""
    f = {k: html.escape(latex_text(v)) for k, v in entry.fields.items()}
    parts = [authors(entry) and html.escape(authors(entry))]
    book = entry.kind in ("book",)
    parts.append(f"<em>{f['title']}</em>" if book else f"“{f.get('title', '')},”")
    if entry.kind == "article":
        parts.append(f"<em>{f.get('journal', '')}</em>")
        parts += [f"vol. {f['volume']}" if "volume" in f else "", f"no. {f['number']}" if "number" in f else ""]
        pages = f.get("pages", "")
        parts.append(("pp. " if "–" in pages else "p. ") + pages if pages else "")
    elif entry.kind == "inproceedings":
        parts.append(f"in <em>{f.get('booktitle', '')}</em>")
    if book:
        parts += [f"{f['edition']} ed." if "edition" in f else "",
                  f"{f['series']} {f.get('number', f.get('volume', ''))}".strip() if "series" in f else ""]  # fmt: skip
        parts.append(": ".join(x for x in (f.get("address"), f.get("publisher")) if x))
    elif entry.kind != "article":
        parts.append(f.get("publisher", ""))
        parts.append(f"technical report {f['number']}" if entry.kind == "techreport" and "number" in f else "")
        parts.append(f"pp. {f['pages']}" if "pages" in f and entry.kind != "inproceedings" else "")
    parts.append(f.get("year", ""))
    if entry.kind == "inproceedings" and "pages" in f:
        parts.append(f"pp. {f['pages']}")
    text = ", ".join(p for p in parts if p).replace(",”,", ",”")
    if "doi" in f:
        text += f', doi: <a href="https://doi.org/{f["doi"]}">{f["doi"]}</a>'
    return text + "."


def check(keys: list[str], entries: dict[str, Entry]) -> None:
    missing = [k for k in keys if k not in entries]
    if missing:
        raise CitationError(f"citation key(s) not in paper/references.bib: {', '.join(missing)}")


def link_citations(text: str, numbers: dict[str, int], token: str, groups: list[str]) -> str:
    """Replace each citation group (outside code and math, which the caller has protected) by ``token``
    formatted with its index in ``groups``, to which the group's HTML ("[1], [2, Ch. 4]") is appended."""

    def one(m: re.Match) -> str:
        cites = []
        for c in ONE.finditer(m[1]):
            locator = f", {html.escape(c[2].strip())}" if c[2] and c[2].strip() else ""
            cites.append(f'<a class="cite" href="#ref-{c[1]}">[{numbers[c[1]]}{locator}]</a>')
        groups.append(", ".join(cites))
        return token.format(len(groups) - 1)

    return GROUP.sub(one, text)


def references_html(keys: list[str], entries: dict[str, Entry]) -> str:
    """The cited entries, numbered in order of first citation."""
    rows = [f'<li id="ref-{k}"><span class="ref-label">[{i}]</span> {entry_html(entries[k])}</li>'
            for i, k in enumerate(keys, 1)]  # fmt: skip
    return '<ol class="references">\n' + "\n".join(rows) + "\n</ol>"
