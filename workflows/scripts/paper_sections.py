"""Render the paper's section templates (paper/sections/*.md) into Markdown fragments filled from results.

A template holds Markdown with placeholders ``{{ name args... }}``; every number comes from a
results file through one of them (an unknown placeholder is an error):

- ``{{ value SCENARIO KEY [FORMAT] }}``: a key of results/scenarios/SCENARIO/summary.json
- ``{{ count SCENARIOS|SOLVED|CLAIMS|HOLDS|FAILS|CORRECTED }}``: counts over the results
- ``{{ claim ID }}``: a derivation claim's id and verdict
- ``{{ json PATH KEY [FORMAT] }}``: a value of the JSON file results/PATH, KEY a dotted path of keys and
  list indices (``scenarios.0.final_time``); workflows/rules/paper.smk makes each such file an input
- ``{{ scenario_table }}``, ``{{ reproduction_notes }}``, ``{{ scenario_sections }}``, ``{{ costate_figures }}``,
  ``{{ comparison_figures }}``, ``{{ derivation_report }}``: generated blocks
"""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from model.plotting.figures import ENERGY_UNIT
from model.plotting.results import Result, comment_block, fmt, load_claims, load_result

PLACEHOLDER = re.compile(r"\{\{\s*([a-z_]+)((?:\s+[^\s}]+)*)\s*\}\}")


@dataclass
class Context:
    """Everything a template may refer to."""

    results: dict[str, Result]
    scenario_files: dict[str, Path]
    paper: list[str]
    claims: dict[str, dict]
    table_md: str
    report_md: str
    figures: Path
    results_dir: Path = Path("results")

    def figure(self, path: str, caption: str) -> str:
        return f"![{caption}]({self.figures / path})"


def value(ctx: Context, scenario: str, key: str, spec: str = ".4g") -> str:
    summary = ctx.results[scenario].summary
    if key not in summary:
        raise KeyError(f"{scenario}/summary.json has no key {key!r}")
    return format(summary[key], spec) if isinstance(summary[key], int | float) else str(summary[key])


def json_value(ctx: Context, path: str, key: str, spec: str = ".4g") -> str:
    """A value of a results JSON file, by a dotted path of keys and list indices."""
    node = json.loads((ctx.results_dir / path).read_text())
    for part in key.split("."):
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            raise KeyError(f"{path} has no key {key!r} (at {part!r})")
    if isinstance(node, bool) or not isinstance(node, int | float):
        return str(node)
    return format(node, spec)


def count(ctx: Context, what: str) -> str:
    verdicts = [c["verdict"] for c in ctx.claims.values()]
    counts = {
        "SCENARIOS": len(ctx.results),
        "SOLVED": sum(r.solved for r in ctx.results.values()),
        "CLAIMS": len(verdicts),
        "HOLDS": sum(v == "holds" for v in verdicts),
        "FAILS": sum(v == "fails" for v in verdicts),
        "CORRECTED": sum(v.startswith("holds after correction") for v in verdicts),
    }
    return str(counts[what])


def claim(ctx: Context, claim_id: str) -> str:
    """A claim id with its verdict's first word(s), e.g. "`hyp1.singular` (fails)"."""
    verdict = ctx.claims[claim_id]["verdict"].split(":")[0]
    return f"`{claim_id}` ({verdict})"


def reproduction_notes(ctx: Context) -> str:
    """The paper scenarios' assumption bullets: those shared by every file once, then each file's own."""
    notes = {name: comment_block(ctx.scenario_files[name]) for name in ctx.paper}
    shared = [n for n in next(iter(notes.values()), []) if all(n in v for v in notes.values())]
    lines = ["Shared by every scenario file:", ""] + [f"- {n}" for n in shared] + [""]
    for name, bullets in notes.items():
        own = [n for n in bullets if n not in shared]
        title = ctx.results[name].summary.get("title") or name
        lines += [f"Scenario `{name}` ({title}):", ""] + [f"- {n}" for n in own or ["no further assumption"]] + [""]
    return "\n".join(lines)


def scenario_paragraph(r: Result) -> str:
    s = r.summary
    if not r.solved:
        reason = s.get("failure") or s.get("solver_message") or ""
        return (f"**The solve failed** ({r.status_text}). {reason} "
                "The figures below show no solution: a failed solve is never plotted.")
    return (
        f"Solved and validated: $T_f = {fmt(s['final_time'])}$ s, $E = {fmt(s['energy'])}$ ({ENERGY_UNIT}), "
        f"{s['iterations']} Ipopt iterations in {fmt(s['solve_seconds'], 2)} s on N = {s['intervals']} intervals. "
        f"The path passes the obstacle {s.get('pass')} (swept angle {fmt(s.get('swept_angle'), 3)} rad); "
        f"its smallest clearance beyond the safety distance is {fmt(s.get('min_clearance'), 3)} m at the nodes "
        f"and {fmt(s.get('min_clearance_dense'), 3)} m between them."
    )


def direction_notes(r: Result) -> str:
    """Flags for a solved run that reverses (u1 < 0 at some node) or passes the obstacle clockwise."""
    notes = []
    traj = r.trajectory
    if "u1" in traj and (traj["u1"] < 0).any():
        back = traj[traj["u1"] < 0]
        notes.append(f"**It reverses**: u1 < 0 on {len(back)} of its {len(traj)} nodes (t from "
                     f"{fmt(back['t'].min(), 3)} to {fmt(back['t'].max(), 3)} s, least u1 "
                     f"{fmt(traj['u1'].min(), 3)} m/s); the problem bounds |u1| and allows both directions.")
    if r.summary.get("pass") == "cw":
        notes.append("**It passes the island clockwise**, against the counter-clockwise circulation of a "
                     "right-hand-traffic roundabout: the seed paper's problem has an obstacle, no direction "
                     "of traffic.")
    return " ".join(notes)


def geometry_of(name: str) -> str:
    """The scenario a case belongs to (``s2-case3`` -> ``s2``): the cases of one geometry differ in Tf only."""
    return name.split("-case")[0]


def later_cases(paper: list[str]) -> list[str]:
    """The paper scenarios that are a later case of an earlier one's geometry (their solution figures, close
    to the first case's, go to the supplementary material)."""
    return [n for i, n in enumerate(paper) if geometry_of(n) in {geometry_of(m) for m in paper[:i]}]


def solution_figure(ctx: Context, name: str) -> str:
    return ctx.figure(f"{name}/solution.png", f"`{name}`: (a) controls with their bounds dashed, (b) states, "
                      "(c) path with the obstacle, its safety circle and the start and goal poses, "
                      "(d) cumulative energy (the paper's Figures 4-7).")


def scenario_sections(ctx: Context) -> str:
    """Each paper scenario's paragraph and solution figure (a later case of a geometry: its figure in the
    supplementary material); the costate figure of the first one only (the others are in the supplementary
    material, ``{{ costate_figures }}``)."""
    blocks, later = [], later_cases(ctx.paper)
    for i, name in enumerate(ctx.paper):
        r = ctx.results[name]
        title = r.summary.get("title") or name
        first = next(m for m in ctx.paper if geometry_of(m) == geometry_of(name))
        figure = (solution_figure(ctx, name) if name not in later else
                  f"Its solution figure, close to `{first}`'s (the same geometry, a longer final time), is in the "
                  "supplementary material (S5).")  # fmt: skip
        blocks += [
            f"### {title}",
            "",
            scenario_paragraph(r) + (f" {direction_notes(r)}" if r.solved and direction_notes(r) else ""),
            "",
            figure,
            "",
        ]
        if name in later and name == [n for n in ctx.paper if geometry_of(n) == geometry_of(name)][-1]:
            cases = [n for n in ctx.paper if geometry_of(n) == geometry_of(name)]
            blocks += [ctx.figure(f"{geometry_of(name)}-cases.png", f"The cases {', '.join(cases)} overlaid: "
                                  "speed, steering rate, path and energy (their paths differ by millimetres; "
                                  "each case's own figure is in S5)."), ""]  # fmt: skip
        if i == 0:
            blocks += [costate_figure(ctx, name), ""]
            if len(ctx.paper) > 1:
                others = ", ".join(f"`{n}`" for n in ctx.paper[1:])
                blocks += [f"The costate figures of {others} are in the supplementary material (S5).", ""]
    return "\n".join(blocks + [other_scenarios(ctx)])


def costate_change(ctx: Context, name: str) -> str:
    """What the grid-convergence study says of a scenario's costates (results/studies/convergence)."""
    path = ctx.results_dir / "studies" / "convergence" / "convergence.json"
    rows = json.loads(path.read_text()).get("rows", []) if path.is_file() else []
    row = next((r for r in rows if r.get("scenario") == name), None)
    if row is None:
        return "Its costates were not checked under grid refinement."
    return (f"Under grid refinement (N = {row['grids']}, supplementary S2) its costates change by up to "
            f"{fmt(row['costate_change'], 3)} between the two finest grids (observed orders {row['order_p']}).")


def transversality(r: Result) -> str:
    """The certificate's transversality residual of a run, or why there is none."""
    item = ((r.summary.get("certificate") or {}).get("items") or {}).get("transversality") or {}
    if "value" not in item:
        return "No state is free at Tf, so there is no transversality condition to check."
    states = ", ".join(item.get("states") or [])
    return (f"Transversality (p = 0 at Tf for the free final state(s) {states}): residual {item['value']:.1e} "
            f"(tolerance {item.get('tolerance', float('nan')):.0e}) for the certificate's end-node estimate "
            "carried the half step to Tf; the plotted last-node estimate need not vanish.")


def costate_figure(ctx: Context, name: str) -> str:
    r = ctx.results[name]
    return ctx.figure(f"{name}/costates.png", f"`{name}`: costate estimates from the NLP multipliers, the "
                      "switching functions beside the controls they select, the Hamiltonian and the obstacle "
                      f"multiplier. {costate_change(ctx, name)} {transversality(r)}")


def costate_figures(ctx: Context) -> str:
    """The solution figures of the later cases and the costate figures of the paper scenarios after the first
    (the supplementary material)."""
    figures = [solution_figure(ctx, name) for name in later_cases(ctx.paper)]
    figures += [costate_figure(ctx, name) for name in ctx.paper[1:]]
    return "\n\n".join(figures) or "No further paper scenario."


def other_scenarios(ctx: Context) -> str:
    """The solved scenario files that are not the paper's, linked to their figures."""
    others = [n for n in ctx.results if n not in ctx.paper]
    if not others:
        return ""
    lines = ["### Further scenario files", "",
             "Also solved (rows in the table above); their figures are beside this paper's folder:", ""]
    for name in others:
        r = ctx.results[name]
        links = ", ".join(f"[{k}](../figures/{name}/{k}.png)" for k in ("solution", "costates"))
        lines.append(f"- `{name}`: {r.summary.get('title') or name}; {r.status_text}; figures: {links}")
    return "\n".join(lines) + "\n"


def comparison_figures(ctx: Context) -> str:
    return "\n\n".join([
        ctx.figure("phase-rate.png", "Phase of the control vector and its rate (the paper's Figure 8, "
                   "Hypothesis 1), by finite differences on the nodes; symmetric-log scale."),
        ctx.figure("paths.png", f"Paths of {', '.join(f'`{n}`' for n in ctx.paper)} around the same obstacle, "
                   "the direction of travel, start and goal marked (the paper's Figure 9 shows s2-case1, s2-case2 "
                   "and s3)."),
    ])


CLAIMS_TABLE = "| claim | section | verdict |"
CLAIMS_CAPTION = ("Table: Every claim of the seed paper's Sections 2-6 checked symbolically: its id, the paper's "
                  "section and the verdict (holds, holds after the correction given, or fails); the evidence "
                  "for each follows below.")


def derivation_report(ctx: Context) -> str:
    """report.md with its title dropped, every heading one level deeper (it sits under a section) and its
    claims table captioned."""
    lines = ctx.report_md.splitlines()
    if lines and lines[0].startswith("# "):
        lines = lines[1:]
    out: list[str] = []
    for ln in lines:
        if ln.strip() == CLAIMS_TABLE and not any(o.startswith("Table: ") for o in out):
            out += [CLAIMS_CAPTION, ""]
        out.append("#" + ln if re.match(r"#{1,5} ", ln) else ln)
    return "\n".join(out)


BLOCKS: dict[str, Callable[[Context], str]] = {
    "scenario_table": lambda ctx: ctx.table_md,
    "reproduction_notes": reproduction_notes,
    "scenario_sections": scenario_sections,
    "costate_figures": costate_figures,
    "comparison_figures": comparison_figures,
    "derivation_report": derivation_report,
}


def render(template: str, ctx: Context) -> str:
    def fill(match: re.Match) -> str:
        name, args = match.group(1), match.group(2).split()
        if name == "value":
            return value(ctx, *args)
        if name == "count":
            return count(ctx, *args)
        if name == "claim":
            return claim(ctx, *args)
        if name == "json":
            return json_value(ctx, *args)
        if name in BLOCKS and not args:
            return BLOCKS[name](ctx)
        raise KeyError(f"unknown placeholder {match.group(0)!r}")

    return PLACEHOLDER.sub(fill, template)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--templates", nargs="+", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True, help="folder for the fragments")
    ap.add_argument("--scenarios", nargs="+", type=Path, required=True, help="scenario files")
    ap.add_argument("--paper-scenarios", nargs="*", default=[], help="the seed paper's scenarios, in order")
    ap.add_argument("--results", type=Path, default=Path("results"))
    args = ap.parse_args(argv)
    res = args.results
    ctx = Context(
        results={f.stem: load_result(res / "scenarios" / f.stem, name=f.stem) for f in args.scenarios},
        scenario_files={f.stem: f for f in args.scenarios},
        paper=[n for n in args.paper_scenarios if n in {f.stem for f in args.scenarios}],
        claims=load_claims(res / "derivations" / "claims.json"),
        table_md=(res / "tables" / "scenarios.md").read_text(),
        report_md=(res / "derivations" / "report.md").read_text(),
        figures=res / "figures",
        results_dir=res,
    )
    args.out.mkdir(parents=True, exist_ok=True)
    for template in args.templates:
        (args.out / template.name).write_text(render(template.read_text(), ctx))


if __name__ == "__main__":
    main()
