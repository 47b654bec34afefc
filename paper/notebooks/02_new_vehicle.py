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
# # A new vehicle and a new scenario with the DSL
#
# A vehicle is one small class: its state and control names and its dynamics as SymPy
# expressions (here a subclass of the truck that changes only the dynamics). The
# transcription, the validator and the Pontryagin engine read it unchanged.
# Here: a car whose speed input drives the *front* wheels (the rear axle moves at u1 cos(phi)).

# %%
from dataclasses import dataclass

import sympy as sp

from model import OCP, Circle, Energy, Truck, Unicycle
from model.vehicles import sym


@dataclass
class FrontDriveCar(Truck):
    """Car-like robot driven at the front axle: speed u1 of the front wheels, steering rate u2.

    It reuses the truck's states, controls and wheelbase parameter; only the dynamics differ.
    """

    model = "front-drive car"

    def dynamics(self) -> dict[str, sp.Expr]:
        x, y, theta, phi = self.state_symbols()
        u1, u2 = self.control_symbols()
        d = sym("d")
        return {"x": u1 * sp.cos(phi) * sp.cos(theta), "y": u1 * sp.cos(phi) * sp.sin(theta),
                "theta": u1 * sp.sin(phi) / d, "phi": u2}


# %% [markdown]
# The same roundabout as the paper's Scenario 2 (obstacle, bounds, start and goal), a new vehicle.

# %%
roundabout = dict(
    cost=Energy(), final_time=2.0,
    bounds={"u1": (-1, 1), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)},
    obstacles=[Circle(center=(0.5, 0.03), radius=0.2, safety=0.05)],
    final=dict(x=1, y=0, theta=0), passing="ccw",
)
car = OCP(vehicle=FrontDriveCar(wheelbase=0.02), initial=dict(x=0, y=0, theta=0, phi=0),
          name="front-drive", **roundabout)
solution = car.solve(intervals=60)
print(f"front-drive car: ok={solution.ok} E={solution.energy:.4g} iterations={solution.iterations}")
assert solution.ok

# %% [markdown]
# The built-in unicycle (no steering angle) on the same roundabout, for comparison:

# %%
no_steering = {**roundabout, "bounds": {"u1": (-1, 1), "u2": (-3, 3)}}  # u2 is now the turn rate (rad/s)
uni = OCP(vehicle=Unicycle(), initial=dict(x=0, y=0, theta=0), name="unicycle", **no_steering)
uni_solution = uni.solve(intervals=60)
print(f"unicycle: ok={uni_solution.ok} E={uni_solution.energy:.4g}")
assert uni_solution.ok, uni_solution.status

# %% [markdown]
# Its Pontryagin system is derived from the same definition:

# %%
print(car.pmp().to_text())

# %%
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(6, 4))
for label, sol in (("front-drive car", solution), ("unicycle", uni_solution)):
    if sol.ok:
        ax.plot(sol.trajectory["x"], sol.trajectory["y"], label=label)
ax.add_patch(plt.Circle((0.5, 0.03), 0.2, color="0.75"))
ax.add_patch(plt.Circle((0.5, 0.03), 0.25, fill=False, linestyle="--"))
ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal")
ax.legend()
fig.savefig("new-vehicle-paths.png", dpi=100)
