# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Explore the derivations
#
# The Pontryagin system of a scenario, derived symbolically from the same problem definition
# the solver uses; the paper's claims and their verdicts; and a numerical confirmation that a
# solver's controls and costates satisfy the derived conditions.

# %%
from pathlib import Path


def repository_root() -> Path:
    here = Path(globals().get("__file__", Path.cwd() / "notebook.py")).resolve().parent
    return next(p for p in (here, *here.parents) if (p / "Snakefile").exists())


from derivations.numerics import confirm  # noqa: E402
from derivations.paper.claims_numbers import claims as section5_claims  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402

ocp = load_scenario(repository_root() / "workflows" / "scenarios" / "s1.toml").ocp

# %% [markdown]
# ## The Pontryagin system (maximisation, p0 = -1)

# %%
system = ocp.pmp()
print(system.to_text())

# %% [markdown]
# ## Claims of the paper's Section 5 and their verdicts
# (all sections: `python -m derivations.paper.report --out DIR`, or results/derivations/ after a build)

# %%
for claim in section5_claims():
    print(f"{claim.id:28} {claim.verdict[:70]}")

# %% [markdown]
# ## Do the solver's costates satisfy the derived conditions?

# %%
solution = ocp.solve(intervals=100)
check = confirm(solution.trajectory, ocp)
print(check.to_text())
# The costates are estimates from the trapezoid multipliers (O(h) accurate), so the check is
# made with tolerances of the grid's order; the derivation report discusses what it shows.
print("maximum condition and constant H within 1e-3:", check.agrees())
