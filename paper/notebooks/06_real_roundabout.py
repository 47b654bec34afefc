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
# # A real roundabout: a semitrailer through Kackertstrasse (Aachen), from a CommonRoad map and back
#
# The roundabouts of notebook 04 are drawn from a few numbers (ring, apron, legs). A real one comes
# as a *map*: the rounD dataset's roundabouts ship as CommonRoad lanelet networks (each lane a
# polygon between a left and a right bound, linked to its predecessors, successors and neighbours)
# in the BSD-licensed package `commonroad-dataset-converter`. This notebook
#
# 1. loads the map of the Kackertstrasse roundabout and looks at its lanelets by type,
# 2. finds its movements from the lanelet graph (where traffic comes in, where it leaves, and the ring),
# 3. picks a route by its lanelets and solves the EU 16.5 m tractor-semitrailer through it,
# 4. checks the answer the way the validation does (exact rectangles inside the corridor's polygon),
# 5. draws it to scale on the map's lanelets,
# 6. writes it back as a CommonRoad scenario, the manoeuvre as two moving rectangles, and reads that
#    file back with commonroad-io.
#
# Runs as a notebook (jupytext) or as `python 06_real_roundabout.py`; files are written to the current
# folder. It prints its own run time at the end.

# %%
import time
import tomllib
from collections import Counter
from pathlib import Path


def repository_root() -> Path:
    """The folder holding the Snakefile, found upwards from this file (or the notebook's folder)."""
    here = Path(globals().get("__file__", Path.cwd() / "notebook.py")).resolve().parent
    return next(p for p in (here, *here.parents) if (p / "Snakefile").exists())


ROOT = repository_root()

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402

from model.analysis.bodies import body_corners  # noqa: E402
from model.plotting.maps import draw_lanelets, draw_swept, map_limits  # noqa: E402
from model.plotting.roads import BODY_COLORS, draw_scale_bar  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.scene.lanelet_map import dataset_file, read_map  # noqa: E402
from model.studies.maps import apron_gap, entries_and_exits, movements, ring_lanelets  # noqa: E402

STARTED = time.perf_counter()

# %% [markdown]
# ## 1. The map
#
# `dataset_file` finds the map inside the installed data package (nothing is downloaded) and
# `read_map` reads it with commonroad-io. Lanelets have types: the roadway (`urban`, some of it
# `intersection`), `sidewalk`, `border` and lanes closed to motor traffic (`restricted`). Only lanes a
# motor vehicle may drive on take part in routes (docs/map-format.md); the apron, a mountable ring
# around the island, is the border lanelet 50, which a scenario may allow explicitly.

# %%
lanelet_map = read_map(dataset_file("rounD/DEU_Kackertstrasse-1"))
kinds = Counter(lanelet_map.kind(i) for i in lanelet_map.ids)
print(f"{lanelet_map.path.name}: {len(lanelet_map.ids)} lanelets")
for kind, count in kinds.most_common():
    print(f"  {count:3d} {kind}")
apron = lanelet_map.lanelet(50)
print(f"lanelet 50: {lanelet_map.kind(50)}, its own successor {apron.successor == [50]}, centre line "
      f"{lanelet_map.lengths[50]:.1f} m (a ring of radius ~{lanelet_map.lengths[50] / (2 * np.pi):.1f} m)")

# %% [markdown]
# ## 2. Its movements, read off the lanelet graph
#
# Traffic comes into the map on the drivable lanelets that have no drivable predecessor and leaves on
# those without a drivable successor. The circulating ring is the set of drivable lanelets that lie on
# a cycle of successors. A *movement* is an entry and an exit joined by a route through the ring
# (`model.studies.maps.movements`); the pipeline's map study runs every one of them for five design
# vehicles.

# %%
entries, exits = entries_and_exits(lanelet_map)
ring = ring_lanelets(lanelet_map)
found = movements(lanelet_map)
print("entries:", entries, " exits:", exits)
print("ring:", ring)
print(f"{len(found)} movements:", ", ".join(m.name for m in found))
bypass = [(a, b) for a in entries for b in exits if a != b and f"{a}-{b}" not in {m.name for m in found}]
print("entry x exit pairs that are not movements (no route, or one that bypasses the ring):", len(bypass))

# %% [markdown]
# ## 3. A route by its lanelets, and the semitrailer through it
#
# `examples/map-kackertstrasse-semitrailer.toml` names the route by two lanelet ids: from lanelet 90
# (the east entry) to lanelet 102 (the south exit), the third exit, a left turn. The start lies 20 m
# along the route from the start of lanelet 90 (the trailer reaches about 12 m behind the tractor's
# rear axle), the goal 12 m before the end of lanelet 102. The corridor, the only area a body may
# cover, is every lanelet on some route from 90 to 102: the entry, the whole ring, the exit; the apron
# lanelet is added for the trailer only (`apron_use = "trailer"`).
#
# The solve is a sequence of corridor strip solves (docs/map-corridor.md): the route's curvilinear
# frame gives each body a strip of the corridor to stay in, the strips are re-projected from the last
# answer until they move less than 5 cm. N = 100 intervals (on coarser grids the rectangles cut the
# corners of the corridor between nodes, and a map solve judges them there too).

# %%
doc = tomllib.loads((ROOT / "examples" / "map-kackertstrasse-semitrailer.toml").read_text())
ocp = parse_scenario(doc, path=ROOT / "examples" / "map-kackertstrasse-semitrailer.toml").ocp
route = ocp.map_route
print(ocp.title)
print("route lanelets:", " ".join(map(str, route.lanelets)))
print(f"centre line {route.line.length:.1f} m, start {route.start_offset:g} m along it, goal at "
      f"{route.goal_s:.1f} m; it turns {np.degrees(route.turn()):.0f} degrees")
print(f"corridor: {len(route.corridor_lanelets)} lanelets, {route.lanes.area:.1f} m^2 "
      f"({route.with_apron.area:.1f} m^2 with the apron, for the trailer)")

INTERVALS = doc["problem"]["intervals"]
t0 = time.perf_counter()
solution = ocp.solve(intervals=INTERVALS)
solve_seconds = time.perf_counter() - t0
summary = solution.summary()
print(f"ok = {solution.ok}, status = {solution.status}, minimum time Tf = {solution.final_time:.2f} s, "
      f"{len(solution.search['solves'])} strip solves, {solve_seconds:.1f} s")
for k, s in enumerate(solution.search["solves"]):
    print(f"  solve {k + 1}: {s['status']}, Tf {s['final_time']:.3f} s, projections moved {s['moved']:.3f} m")

# %% [markdown]
# ## 4. The check that does not trust the strips
#
# The strips are what Ipopt can differentiate. The validation forgets them and puts each body's exact
# rectangle into the corridor's polygon (shapely) at every node and on 4 sub-steps between nodes;
# both must be >= 0 for a map solve to pass. `lanelets_used` lists every lanelet of the map that the
# bodies cover (the rounD lanelets overlap at the ring's entries, so it can list lanelets outside
# the corridor while the bodies stay inside it).

# %%
for check in ("body_clearance", "body_clearance_dense"):
    result = summary["validation"][check]
    print(f"{check:>22}: {result['value']:.3g} (tolerance {result['tolerance']:.3g}) passed={result['passed']}")
print(f"least clearance: {100 * summary['min_clearance']:.1f} cm at the nodes, "
      f"{100 * summary['min_clearance_dense']:.1f} cm between them")
print("lanelets used:", " ".join(map(str, summary["lanelets_used"])))
print("outside the corridor among them:", sorted(set(summary["lanelets_used"]) - set(route.corridor_lanelets)))

# %% [markdown]
# ## 5. To scale, on the map
#
# `model.plotting.maps.draw_lanelets` fills every lanelet by its type and outlines the corridor;
# over it the area each body sweeps (exact rectangles at the nodes and sub-steps) and the two bodies
# every few seconds.

# %%
swept = solution.swept_path()
polygons = {f["properties"]["body"]: shapely.geometry.shape(f["geometry"]) for f in swept["features"]}
fig, ax = plt.subplots(figsize=(9, 7), layout="constrained")
handles = draw_lanelets(ax, lanelet_map, corridor=route.corridor_lanelets)
for name, polygon in polygons.items():
    draw_swept(ax, [polygon], BODY_COLORS[name], f"swept by the {name} body")
states = {k: np.asarray(solution.columns[k]) for k in ("t", *ocp.vehicle.states)}
nodes = np.linspace(0, INTERVALS, 7).round().astype(int)
for name, corners in body_corners(ocp, states).items():
    for k in nodes:
        ax.fill(*corners[k].T, facecolor="none", edgecolor=BODY_COLORS[name], lw=0.8, zorder=5)
(x0, x1), (y0, y1) = map_limits(polygons.values())
ax.set(xlim=(x0, x1), ylim=(y0, y1), aspect="equal", xticks=[], yticks=[])
draw_scale_bar(ax)
ax.legend(handles=[*handles, *ax.get_legend_handles_labels()[0]], fontsize=7, loc="upper left",
          bbox_to_anchor=(1.01, 1.0))
ax.set_title(f"EU-semitrailer 90 -> 102, Tf = {solution.final_time:.2f} s (corridor outlined)", fontsize=9)
fig.savefig(Path.cwd() / "real-roundabout.png", dpi=110)
print("wrote", Path.cwd() / "real-roundabout.png")
for name, polygon in polygons.items():
    print(f"{name:8s}: swept area {polygon.area:6.1f} m^2")

# %% [markdown]
# The trailer may use the apron, yet its swept path keeps off it. The drawing shows why: on this map
# the border lanelet 50 is a narrow ring well inside the ring roadway's inner edge, and no lanelet
# covers the strip between them, which no body may cross. `model.studies.maps.apron_gap` measures it;
# the map study reports it with every cell.

# %%
gap = apron_gap(route)
print(f"the apron lanelets lie {gap:.2f} m inside the lanes; the trailer's least distance to them: "
      f"{polygons['trailer'].distance(lanelet_map.polygon(50)):.2f} m")

# %% [markdown]
# ## 6. Back to CommonRoad
#
# `solution.commonroad_xml()` is the file `roundabout solve` writes as `commonroad.xml`: a copy of the
# map's scenario with each body as a `DynamicObstacle` (type truck, a rectangle of the body's length
# and width, its centre and orientation every `dt` = 0.1 s of the scenario). Any CommonRoad tool reads
# it; here commonroad-io itself reads it back.

# %%
from commonroad.common.file_reader import CommonRoadFileReader  # noqa: E402

xml = Path.cwd() / "kackertstrasse-semitrailer.xml"
xml.write_bytes(solution.commonroad_xml())
scenario, _ = CommonRoadFileReader(str(xml)).open()
obstacles = scenario.dynamic_obstacles
print(f"wrote {xml.name} ({xml.stat().st_size / 1e3:.0f} kB): {len(scenario.lanelet_network.lanelets)} lanelets, "
      f"{len(obstacles)} dynamic obstacles, dt = {scenario.dt} s")
for obstacle, (name, body) in zip(obstacles, ocp.bodies.items(), strict=True):
    states_out = obstacle.prediction.trajectory.state_list
    print(f"  obstacle {obstacle.obstacle_id} ({obstacle.obstacle_type.value}): {obstacle.obstacle_shape.length:.2f} x "
          f"{obstacle.obstacle_shape.width:.2f} m ({name} body {body.length:.2f} x {body.width:.2f} m), "
          f"{len(states_out) + 1} states to t = {states_out[-1].time_step * scenario.dt:.1f} s")

# %% [markdown]
# ## What this notebook established
#
# The assertions below fail if the story stops being true: the map has its closed ring of 8 lanelets
# and 20 movements from 4 entries to 5 exits; the semitrailer's solve passes with every exact
# rectangle inside the corridor at and between the nodes; the swept paths have one polygon per body;
# the CommonRoad file read back holds the map and one moving rectangle per body, of the body's size,
# that lasts as long as the manoeuvre.

# %%
assert len(ring) == 8 and len(entries) >= 4 and len(found) == 20
assert "90-102" in {m.name for m in found}
assert solution.ok, (solution.status, summary.get("diagnosis"))
assert summary["min_clearance"] >= 0 and summary["min_clearance_dense"] >= 0
assert set(polygons) == set(ocp.bodies)
assert gap > 1.0 and polygons["trailer"].distance(lanelet_map.polygon(50)) >= gap - 1e-6  # the apron is out of reach
assert len(scenario.lanelet_network.lanelets) == len(lanelet_map.ids) and len(obstacles) == len(ocp.bodies)
for obstacle, body in zip(obstacles, ocp.bodies.values(), strict=True):
    assert abs(obstacle.obstacle_shape.length - body.length) < 1e-9
    last = obstacle.prediction.trajectory.state_list[-1].time_step * scenario.dt
    assert abs(last - solution.final_time) <= scenario.dt
print(f"all checks passed; notebook ran in {time.perf_counter() - STARTED:.1f} s")
