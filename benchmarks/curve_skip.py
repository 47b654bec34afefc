"""Would skipping the smooth routes lose optima? A rule checked on kept robustness outputs (issue 22, point 3).

Usage: python benchmarks/curve_skip.py DIR [--rel 1e-6]

DIR is the ``out`` folder of ``bench_robustness.py --keep`` (one ``roundabout solve`` folder per scenario). The
rule: skip the smooth-route search (``model.search.multistart._curve_search``: 18 screening starts at N = 40 and
their refinements) where the cold starts before it agree, i.e. at least two distinct routes converged to the
best validated cold-start objective within ``rel`` (relative). For each scenario whose search ran the smooth
routes, the summary's ``attempts`` say whether the rule fires and whether the smooth routes found a validated
answer better than the best cold start (by more than 1e-6 relative): a scenario where both hold is an optimum
the rule would lose.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

CURVES = ("hermite-", "reverse-first", "reverse-into", "all-reverse", "sides-")  # model.search.curves' routes
NOT_COLD = ("screening", "refined", "N=")  # screened, refined and accuracy attempts
BETTER = 1e-6  # relative: the smooth routes' answer counts as better below (1 - this) x the best cold start


def outcome(attempts: list[dict], rel: float) -> dict | None:
    """The rule on one search's ``attempts``: None where no smooth route ran or no cold start validated; else
    ``agree`` (distinct cold-start routes at the best validated cold objective), ``fires``, ``gain`` (relative
    change of the best validated smooth-route answer against the best cold start; None: none validated),
    ``lost`` (fires and the smooth routes found better)."""
    first = next((i for i, a in enumerate(attempts) if a["route"].startswith(NOT_COLD[0]) and
                  any(c in a["route"] for c in CURVES)), None)  # fmt: skip
    if first is None:
        return None
    cold = [a for a in attempts[:first] if not a["route"].startswith(NOT_COLD)]
    valid = [a["objective"] for a in cold if a["valid"]]
    if not valid:
        return None
    best = min(valid)
    agree = {a["route"] for a in cold if a["status"] in ("optimal", "acceptable") and a["objective"] is not None
             and abs(a["objective"] - best) <= rel * abs(best)}  # fmt: skip
    found = [a["objective"] for a in attempts[first:] if a["route"].startswith("refined") and a["valid"]]
    gain = (min(found) - best) / abs(best) if found else None
    fires = len(agree) >= 2
    return {"agree": len(agree), "fires": fires, "gain": gain,
            "lost": fires and gain is not None and gain < -BETTER}  # fmt: skip


def study(folder: Path, rel: float = 1e-6) -> dict:
    """``outcome`` for every scenario folder of ``folder``: counts and the scenarios whose optimum is lost."""
    rows = {}
    for summary in sorted(folder.glob("*/summary.json")):
        o = outcome(json.loads(summary.read_text()).get("attempts") or [], rel)
        if o is not None:
            rows[summary.parent.name] = o
    lost = {k: round(o["gain"], 5) for k, o in rows.items() if o["lost"]}
    better = {k: round(o["gain"], 5) for k, o in rows.items() if o["gain"] is not None and o["gain"] < -BETTER}
    return {"scenarios": len(list(folder.glob("*/summary.json"))), "smooth_routes_ran": len(rows),
            "fires": sum(o["fires"] for o in rows.values()), "smooth_routes_better": better, "lost": lost}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--rel", type=float, default=1e-6)
    args = ap.parse_args(argv)
    print(json.dumps(study(args.folder, args.rel), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
