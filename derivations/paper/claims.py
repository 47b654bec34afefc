"""Every checked claim of the paper, in paper order (Sections 2-6)."""

from __future__ import annotations

from derivations.paper import claims_energy, claims_model, claims_numbers, claims_readings, claims_time
from derivations.paper.checking import Claim

MODULES = (claims_model, claims_time, claims_energy, claims_numbers, claims_readings)


def all_claims() -> list[Claim]:
    """Run every check from scratch and return the claims with their computed verdicts."""
    out: list[Claim] = []
    for module in MODULES:
        out.extend(module.claims())
    ids = [c.id for c in out]
    if len(ids) != len(set(ids)):
        raise ValueError("duplicate claim ids")
    return out
