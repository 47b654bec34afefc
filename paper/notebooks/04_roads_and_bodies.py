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
# # Roads and bodies: a design vehicle through a roundabout, and a ring that is too tight
#
# The paper's vehicle is a point that keeps out of a disc. A roundabout designer asks a different
# question: does a *design vehicle* (a standard truck, with its real length, width and overhangs)
# fit through *this* roundabout, and which area does it sweep? This notebook
#
# 1. loads a scenario with a real roundabout (ring, apron, island, four legs) and a design vehicle
#    taken from a preset (the EU 16.5 m tractor-semitrailer of Directive 96/53/EC),
# 2. solves the minimum-time left turn and draws it to scale with the area each body sweeps,
# 3. reads the independent check of the answer: the exact rectangles of the bodies against the exact
#    edges of the road, at the grid nodes and between them,
# 4. narrows the ring until a rigid truck (the AASHTO SU-30 preset) no longer fits, and reads the
#    diagnosis the solver gives instead of an answer: which body crosses which edge, by how much.
#
# Runs as a notebook (jupytext) or as `python 04_roads_and_bodies.py`; figures are written to the
# current folder. It runs in well under a minute and prints its own run time at the end.

# %%
import copy
import math
import time
import tomllib
from pathlib import Path


def repository_root() -> Path:
    """The folder holding the Snakefile, found upwards from this file (or the notebook's folder)."""
    here = Path(globals().get("__file__", Path.cwd() / "notebook.py")).resolve().parent
    return next(p for p in (here, *here.parents) if (p / "Snakefile").exists())


ROOT = repository_root()

import matplotlib.pyplot as plt  # noqa: E402
import shapely  # noqa: E402
from shapely.geometry import shape  # noqa: E402

from model.plotting.roads import draw_roundabout, draw_scale_bar, road_figure  # noqa: E402
from model.problem.scenario import load_scenario, parse_scenario  # noqa: E402
from model.vehicles.presets import preset  # noqa: E402

STARTED = time.perf_counter()

# %% [markdown]
# ## 1. The scenario: a roundabout and a design vehicle
#
# `examples/roundabout-semitrailer.toml` describes the road in a few numbers (see
# docs/roundabout-format.md): a roundabout of 40 m inscribed circle diameter, a 6 m ring roadway,
# a 1.5 m mountable truck apron inside it that only the trailer may use, four legs with 4 m lanes,
# and a route: come in from the west leg (leg 0) and take the third exit, a left turn to the north.
# The vehicle is one line, `[vehicle] preset = "EU-semitrailer"`: the preset fills in the model
# (tractor + semitrailer), the wheelbases, the hitch and the two body rectangles, and says where
# each number comes from and which ones are assumed.

# %%
scenario = load_scenario(ROOT / "examples" / "roundabout-semitrailer.toml")
ocp = scenario.ocp
rb = ocp.road.roundabout
print(ocp.title)
print(f"roundabout: ICD {rb.inscribed_diameter:g} m (outer curb radius Ro = {rb.outer_radius:g} m), ring "
      f"{rb.circulatory_width:g} m, apron {rb.apron_width:g} m (used by: {rb.apron_use}), island radius "
      f"{rb.island_radius:g} m, {len(rb.legs)} legs, {rb.traffic}-hand traffic")
print(f"route: from leg {ocp.road.route.enter}, exit number {ocp.road.route.exit}; objective: {ocp.cost.objective}")

eu = preset("EU-semitrailer")
print("\npreset source:", eu["source"])
print("assumed (not fixed by the directive):", ", ".join(eu["assumed"]))
print("vehicle model:", ocp.vehicle)
for name, body in ocp.bodies.items():
    print(f"  {name:8s} body: {body.length:.2f} m long, {body.width:.2f} m wide, "
          f"{body.rear_overhang:.2f} m behind its axle")
print("bounds:", {k: tuple(round(b, 3) for b in v) for k, v in ocp.bounds.items()})

# %% [markdown]
# ## 2. Solve the manoeuvre
#
# The file asks for N = 200 intervals and the default search (several starting guesses, and a
# re-solve on a grid twice as fine when the controls, integrated exactly, drift from the goal).
# To keep this notebook short we solve on N = 40 intervals with the quick search (one starting
# guess per direction) and without the accuracy re-solve. `ocp.solve` returns a `Solution`;
# `solution.ok` is True only if Ipopt converged *and* the independent validation passed.

# %%
INTERVALS = 40
t0 = time.perf_counter()
solution = ocp.solve(intervals=INTERVALS, search="quick", accuracy=None)
design_seconds = time.perf_counter() - t0
summary = solution.summary()
print(f"ok = {solution.ok}, status = {solution.status}, minimum time Tf = {solution.final_time:.2f} s, "
      f"exit taken = {summary['exit_taken']}, {solution.iterations} Ipopt iterations, solved in {design_seconds:.1f} s")

# %% [markdown]
# ## 3. The check that does not trust the solver
#
# Inside the optimisation each body rectangle is covered by a few discs, and the road is a smooth
# union of its pieces: that is what Ipopt can differentiate, and it is slightly conservative.
# The validation then forgets the discs and measures the *exact* rectangles against the *exact*
# road edges (lines and circles). The clearance is the signed distance from a body to the edge of
# the area it may use (positive inside). At the grid nodes it must be >= 0 for the answer to be
# accepted; between the nodes the states are interpolated and the worst clearance is reported, not
# judged (a coarse grid can cut a corner between two nodes).

# %%
measures = solution.validation["measures"]
for check, result in summary["validation"].items():
    print(f"{check:>20}: {result['value']:.3g} (tolerance {result['tolerance']:.3g}) passed={result['passed']}")
print(f"\nleast clearance at the nodes:      {100 * measures['min_clearance']:6.1f} cm "
      f"({measures['min_clearance_body']}, node {measures['min_clearance_node']} of {INTERVALS})")
for body, value in measures["body_clearance"].items():
    print(f"  least clearance of the {body:8s}  {100 * value:6.1f} cm")
print(f"least clearance between the nodes: {100 * measures['min_clearance_dense']:6.1f} cm")

# %% [markdown]
# ## 4. The drawing to scale and the swept path
#
# `model.plotting.roads.road_figure` draws what a designer draws: the carriageway with its curbs,
# the hatched apron, the island, the body outlines at a few poses, the envelope each body sweeps
# and the tracks of the axles; on the right the speed, the steering rate, the steering angle and
# the articulation angle against their bounds (dashed). The steering rate jumps between its bounds
# from node to node: in a minimum-time problem it enters the Hamiltonian linearly, so the optimum
# is bang-bang or singular, and a coarse grid shows a singular arc as this chatter; the steering
# angle, its integral, stays smooth.

# %%
note = (f"N = {INTERVALS}: Tf = {solution.final_time:.2f} s, least exact clearance "
        f"{100 * measures['min_clearance']:.1f} cm at the nodes, "
        f"{100 * measures['min_clearance_dense']:.1f} cm between")
fig = road_figure(ocp, solution.columns, note=note)
fig.savefig(Path.cwd() / "roads-semitrailer.png", dpi=110)
print("wrote", Path.cwd() / "roads-semitrailer.png")

# %% [markdown]
# The swept path is also data: `solution.swept_path()` is the GeoJSON that `roundabout solve`
# writes as `swept_path.geojson` (one polygon per body, in the scenario's metres), ready for a
# GIS or CAD tool. From it: the area each body sweeps, and how close to the centre it comes. The
# tractor must stay on the ring roadway (outside the apron's outer edge, radius Ri), the trailer
# may ride over the apron but not onto the island.

# %%
swept = solution.swept_path()
centre = shapely.Point(rb.center)
closest = {}
for feature in swept["features"]:
    body, polygon = feature["properties"]["body"], shape(feature["geometry"])
    closest[body] = centre.distance(polygon)
    print(f"{body:8s}: swept area {polygon.area:7.1f} m2, closest to the centre {closest[body]:.2f} m")
print(f"apron outer edge Ri = {rb.inner_radius:g} m, island radius = {rb.island_radius:g} m: the trailer rides "
      f"{rb.inner_radius - closest['trailer']:.2f} m onto the {rb.apron_width:g} m apron")

# %% [markdown]
# ## 5. A ring that is too tight: the solver says why
#
# Now a rigid truck, the AASHTO SU-30 preset (a 9.1 m single-unit truck), on the four-leg
# roundabout of `examples/roundabout-truck.toml`, going straight on. We build the scenario in code
# from that file: the ring roadway narrowed from 6 m to 3.2 m, no apron, and an energy-optimal
# drive in a fixed 20 s (so the truck cannot creep through in a stop-and-steer manoeuvre). The
# preset's own steering limit (derived from its published turning radius) replaces the file's.
#
# When no start gives a valid answer, the solver tries once more with the rectangles' corners in
# the road, and then solves a *minimal-violation* problem: the body constraints get slack
# variables and their sum is minimised. The deepest exact encroachment of that trajectory is the
# diagnosis: which body, which edge, how many metres, when and where. It comes from a local solve,
# so it is an upper bound on what must give way, not a proof that less is impossible. In the
# solution's `attempts` the last record, "minimal violation", stands for both of these tries.

# %%
truck_doc = tomllib.loads((ROOT / "examples" / "roundabout-truck.toml").read_text())
tight = copy.deepcopy(truck_doc)
tight["vehicle"] = {"preset": "SU-30"}
del tight["bounds"]["phi"]  # the preset's steering limit
tight["roundabout"].update(circulatory_width=3.2, apron_width=0.0)
tight["problem"] = {"objective": "energy", "final_time": 20.0, "intervals": 30}
tight_ocp = parse_scenario(tight).ocp
su30 = tight_ocp.bodies["vehicle"]
print(f"SU-30: wheelbase {tight_ocp.vehicle.wheelbase:.3f} m, body {su30.length:.3f} x {su30.width:.3f} m, "
      f"steering limit {tight_ocp.bounds['phi'][1]:.3f} rad; ring {tight_ocp.road.roundabout.circulatory_width:g} m")

t0 = time.perf_counter()
refused = tight_ocp.solve(intervals=30, search="quick", accuracy=None)
refused_seconds = time.perf_counter() - t0
diagnosis = refused.diagnosis
print(f"ok = {refused.ok}, status = {refused.status} ({refused_seconds:.1f} s); attempts recorded: "
      + ", ".join(f"{a['route']} ({a['status']})" for a in refused.attempts))
print("diagnosis:", diagnosis["message"])
print(f"  body {diagnosis['body']!r}, edge {diagnosis['edge']!r}, {diagnosis['encroachment_m']:.2f} m at "
      f"t = {diagnosis['at_time_s']:.2f} s, point ({diagnosis['at_point'][0]:.1f}, {diagnosis['at_point'][1]:.1f}) m")

# %% [markdown]
# A hand check of the order of magnitude. A rigid truck circling steadily turns about a centre on
# its rear axle line: the point of its inner side closest to the centre is beside the rear axle,
# the farthest point is the outer front corner. With the inner side just on the inner edge of the
# ring (radius Ri) the rear axle runs at R = Ri + w/2, and the outer front corner at
# sqrt((R + w/2)^2 + (d + front overhang)^2). If that is beyond Ro, no steady circulation fits.

# %%
ring = tight_ocp.road.roundabout
front = su30.length - su30.rear_overhang  # rear axle to the front bumper
axle_radius = ring.inner_radius + su30.width / 2
corner_radius = math.hypot(axle_radius + su30.width / 2, front)
steady_excess = corner_radius - ring.outer_radius
print(f"Ri = {ring.inner_radius:g} m: rear axle at {axle_radius:.2f} m, outer front corner at {corner_radius:.2f} m, "
      f"{steady_excess:.2f} m beyond the outer curb (Ro = {ring.outer_radius:g} m)")
print(f"steady-state width needed {corner_radius - ring.inner_radius:.2f} m, ring {ring.circulatory_width:g} m; "
      f"the diagnosis: {diagnosis['encroachment_m']:.2f} m over the {diagnosis['edge']}")

# %% [markdown]
# Where the diagnosis puts the encroachment, on the plan of the narrow roundabout (the dashed
# circle: where the outer front corner of a steadily circling SU-30 would run):

# %%
fig, ax = plt.subplots(figsize=(5.5, 5.5), layout="constrained")
draw_roundabout(ax, tight_ocp)
ax.add_patch(plt.Circle(ring.center, corner_radius, fill=False, ls="--", lw=0.8, color="C3",
                        label="steady-state outer front corner"))
px, py = diagnosis["at_point"]
where = f"{diagnosis['encroachment_m']:.2f} m over the {diagnosis['edge']}"
ax.plot(px, py, "x", color="C3", ms=10, mew=2, label=where)
reach = ring.outer_radius + 12
ax.set(xlim=(-reach, reach), ylim=(-reach, reach), aspect="equal", xticks=[], yticks=[])
draw_scale_bar(ax)
ax.legend(loc="upper left", fontsize=7)
ax.set_title(f"SU-30, ring {ring.circulatory_width:g} m, no apron: refused", fontsize=9)
fig.savefig(Path.cwd() / "roads-too-tight.png", dpi=110)
print("wrote", Path.cwd() / "roads-too-tight.png")

# %% [markdown]
# ## What this notebook established
#
# The assertions below fail if the notebook's story stops being true: the design vehicle's solve
# is valid, with every exact rectangle inside the road at the nodes and the exit asked for taken;
# the swept path has one polygon per body, the trailer's reaching over the apron; the tight ring
# is refused with a diagnosis that names a body and an edge and a positive encroachment; the hand
# check agrees that steady circulation does not fit.

# %%
assert solution.ok, (solution.status, summary["validation"])
assert measures["min_clearance"] >= 0 and summary["exit_taken"] == ocp.road.route.exit
assert set(closest) == {"vehicle", "trailer"} and closest["trailer"] < rb.inner_radius  # the trailer uses the apron
assert not refused.ok and diagnosis is not None and diagnosis["kind"] == "minimal violation"
assert diagnosis["body"] == "vehicle" and diagnosis["edge"] and diagnosis["encroachment_m"] > 0.05
assert steady_excess > 0
print(f"all checks passed; notebook ran in {time.perf_counter() - STARTED:.1f} s")
