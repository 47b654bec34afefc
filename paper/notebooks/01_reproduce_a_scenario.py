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
# # Reproduce one of the paper's scenarios
#
# Load a scenario file, solve it (trapezoid collocation, Ipopt), check the answer and draw the
# paper's four panels with the pipeline's own plotting code. Runs as a notebook (jupytext) or as
# `python 01_reproduce_a_scenario.py`; figures are written to the current folder.

# %%
from pathlib import Path


def repository_root() -> Path:
    """The folder holding the Snakefile, found upwards from this file (or the notebook's folder)."""
    here = Path(globals().get("__file__", Path.cwd() / "notebook.py")).resolve().parent
    return next(p for p in (here, *here.parents) if (p / "Snakefile").exists())


ROOT = repository_root()

from model.plotting import figures as plotting  # noqa: E402  (the pipeline's figure style and plots)
from model.plotting.results import Result  # noqa: E402
from model.problem.scenario import load_scenario  # noqa: E402

# %% [markdown]
# The scenario file holds the problem and, in its comment block, why its parameters differ from
# the printed ones.

# %%
scenario = load_scenario(ROOT / "workflows" / "scenarios" / "s2-case1.toml")
ocp = scenario.ocp
print(ocp.title)
print("bounds:", ocp.bounds, "| obstacle:", ocp.obstacles[0])

# %%
solution = ocp.solve(intervals=scenario.intervals)
summary = solution.summary()
print(f"ok={solution.ok} status={summary['status']} Tf={summary['final_time']:.4g} s "
      f"E={summary['energy']:.4g} iterations={summary['iterations']}")
assert solution.ok, summary["status"]

# %% [markdown]
# The independent validation (defects, bounds, boundary conditions, clearance):

# %%
for check, result in summary["validation"].items():
    print(f"{check:>20}: {result['value']:.3g} (tolerance {result['tolerance']:.3g}) passed={result['passed']}")

# %%
plotting.apply_style()
result = Result(ocp.name, {**summary, "exit_code": 0}, solution.trajectory)
fig = plotting.solution_figure(result, ocp)
plotting.save(fig, Path.cwd() / f"{ocp.name}-solution", ["png"])
print("wrote", Path.cwd() / f"{ocp.name}-solution.png")

# %% [markdown]
# The controls, states and costates at the nodes are a DataFrame:

# %%
solution.trajectory[["t", "x", "y", "u1", "u2", "psi_u1", "psi_u2", "H"]].head()
