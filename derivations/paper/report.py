"""`python -m derivations.paper.report --out DIR`: claims.json and report.md (Markdown with LaTeX)."""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

from derivations.paper.checking import Claim
from derivations.paper.claims import all_claims
from derivations.paper.problems import eetppco, toctpco
from derivations.pmp import render_pmp

CONVENTIONS = (
    "Conventions: maximisation, $H = p_0 L + p\\cdot f + \\mu c$ with $p_0 = -1$ (normal) or $0$ "
    "(abnormal); the obstacle constraint $c = \\sqrt{(x-x_{obs})^2 + (y-y_{obs})^2} - R \\ge 0$ is "
    "adjoined directly with a multiplier density $\\mu \\ge 0$, $\\mu c = 0$, and $\\dot p = -\\partial H/"
    "\\partial x$. The paper's $(5)$-$(6)$ write $+\\mu(R - \\mathrm{dist})$: the same with "
    "$\\mu_{paper} = -\\mu \\le 0$. Every verdict below is computed by SymPy (symbolic simplification "
    "plus a numeric spot check at random points) or by explicit extremals checked against every PMP "
    "condition; none is typed."
)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def verdict_table(claims: list[Claim]) -> str:
    rows = ["| claim | section | verdict |", "| --- | --- | --- |"]
    rows += [f"| `{c.id}` | {c.section} | {_cell(c.verdict)} |" for c in claims]
    return "\n".join(rows)


def markdown(claims: list[Claim]) -> str:
    """The full report: summary, verdict table, one section per paper section, PMP systems."""
    counts = Counter(c.status for c in claims)
    parts = ["# Checks of the seed paper's mathematics (Sections 2-6)", "", CONVENTIONS, "",
             f"{len(claims)} claims: " + ", ".join(f"{n} {k}" for k, n in sorted(counts.items())), "",
             verdict_table(claims), ""]
    for section in dict.fromkeys(c.section for c in claims):
        parts.append(f"## {section}")
        for c in (c for c in claims if c.section == section):
            parts += [f"### `{c.id}` — {c.verdict}", "", f"**Statement.** {c.statement}", "",
                      f"**Evidence.** {c.evidence}", ""]
    parts.append("## Derived PMP systems")
    for ocp in (toctpco(), eetppco()):
        parts += [render_pmp(ocp, "latex"), ""]
    return "\n".join(parts)


def write(out: Path) -> list[Claim]:
    out.mkdir(parents=True, exist_ok=True)
    claims = all_claims()
    (out / "claims.json").write_text(json.dumps([c.to_dict() for c in claims], indent=2, ensure_ascii=False))
    (out / "report.md").write_text(markdown(claims))
    return claims


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m derivations.paper.report", description=__doc__)
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    args = parser.parse_args(argv)
    claims = write(args.out)
    print(f"wrote {args.out / 'claims.json'} and {args.out / 'report.md'} ({len(claims)} claims)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
