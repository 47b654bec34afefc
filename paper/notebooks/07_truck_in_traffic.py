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
# # A truck through traffic in Eclipse SUMO
#
# An optimal trajectory through an empty roundabout is half the story: a real truck meets cars that
# circulate, it must wait at the give-way line for a gap long enough for its length, enter without
# making them brake hard and leave at its exit. SUMO (Eclipse's traffic simulator) moves the other
# vehicles; the project drives the truck. This notebook does what `roundabout traffic` does
# (docs/traffic-format.md, `model/traffic/`), step by step:
#
# 1. the scenario: a roundabout, a truck and its route, and the flows of other vehicles;
# 2. the SUMO network written from the scenario's geometry, and the flows as SUMO routes;
# 3. one run with the project's autopilot and one with SUMO's own driver on the same seed;
# 4. their metrics from exact geometry (rectangles, not SUMO's collision check);
# 5. the truck's gap acceptance at the entry, beside the traffic engineer's formulas;
# 6. the run drawn: the conflict zone in time and space, and snapshots with every vehicle to scale.
#
# Runs as a notebook (jupytext) or as `python 07_truck_in_traffic.py`; the files go to the current
# folder. It takes well under a minute and prints its own run time at the end.

# %%
import time
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path


def repository_root() -> Path:
    """The folder holding the Snakefile, found upwards from this file (or the notebook's folder)."""
    here = Path(globals().get("__file__", Path.cwd() / "notebook.py")).resolve().parent
    return next(p for p in (here, *here.parents) if (p / "Snakefile").exists())


ROOT = repository_root()

import matplotlib.pyplot as plt  # noqa: E402

from model.plotting.figures import save  # noqa: E402
from model.plotting.traffic import snapshots, time_space  # noqa: E402
from model.problem.scenario import parse_scenario  # noqa: E402
from model.traffic.cosim import write_sumo_files  # noqa: E402
from model.traffic.gaps import HCM_CRITICAL_GAP, adams_delay, hcm_capacity  # noqa: E402
from model.traffic.run import run_traffic  # noqa: E402
from model.traffic.study import conflicting_demand, read_columns, run_record  # noqa: E402
from model.traffic.sumo import find_sumo  # noqa: E402

STARTED = time.perf_counter()
OUT = Path.cwd() / "truck-in-traffic"

# %% [markdown]
# ## 1. The scenario
#
# `examples/traffic-roundabout.toml` is a road scenario (an 8 m rigid truck straight on through a
# four-leg 40 m roundabout, minimum time) with a `[traffic]` table: SUMO's seed, the warm-up before
# the truck appears, the step, the distance the autopilot keeps from every other vehicle, and one
# `[[traffic.flows]]` table per entering stream (a Poisson stream of `vehicles_per_hour`, each
# vehicle taking its n-th exit with probability `exits[n - 1]`). Here the flows are doubled to
# 600 veh/h on legs 1 and 3, so that the truck meets someone.

# %%
doc = tomllib.loads((ROOT / "examples" / "traffic-roundabout.toml").read_text())
for flow in doc["traffic"]["flows"]:
    flow["vehicles_per_hour"] = 600.0
scenario = parse_scenario(doc)
ocp, traffic = scenario.ocp, scenario.traffic
ring = ocp.road.roundabout
print(ocp.title)
print(f"ICD {ring.inscribed_diameter:g} m, ring {ring.circulatory_width:g} m, {len(ring.legs)} legs, "
      f"{ring.traffic}-hand traffic")
print(f"route: enter leg {ocp.road.route.enter}, exit {ocp.road.route.exit}; seed {traffic.seed}, "
      f"warm-up {traffic.warmup:g} s, step {traffic.step:g} s, safety distance {traffic.safety_distance:g} m")
for f in traffic.flows:
    print(f"  leg {f.leg}: {f.vehicles_per_hour:g} veh/h of {f.type}, exit shares {f.exits}")
print(f"conflicting flow at the truck's entry (the streams' vehicles that pass it): "
      f"{3600 * conflicting_demand(scenario):.0f} veh/h")

# %% [markdown]
# ## 2. The network and the routes
#
# The project writes the scenario's roundabout as a SUMO network (plain XML through `netconvert`,
# in the scenario's own metric coordinates): one ring edge between successive legs along the ring
# roadway's centre line, an entry and an exit edge per leg, the ring declared a `<roundabout>` so
# that entering vehicles yield. The flows become `<flow>` elements; the truck is the vehicle
# `truck`. `roundabout export-sumo` writes the same files with a `run.sumocfg` for `sumo-gui`.

# %%
sumo = find_sumo()
print(f"SUMO {sumo.version}")
net_dir = OUT / "export"
write_sumo_files(scenario, net_dir, sumo, traffic.seed)
print(sorted(p.name for p in net_dir.iterdir()))
net = ET.parse(net_dir / "net.net.xml").getroot()
edges = [e for e in net.iter("edge") if e.get("function") != "internal"]
print("edges:", ", ".join(e.get("id") for e in edges))
print("roundabout edges:", net.find("roundabout").get("edges"))
routes = ET.parse(net_dir / "routes.rou.xml").getroot()
for flow in list(routes.iter("flow"))[:3]:
    edges = flow.get("route") or flow.find("route").get("edges")
    print(f"flow {flow.get('id')}: period {flow.get('period')}, route {edges}")

# %% [markdown]
# ## 3. One run with each driver
#
# `autopilot`: the project solves the truck's optimal trajectory once, then drives along its path
# and chooses, at every step, the fastest progress along it whose bodies keep the safety distance from
# every other vehicle predicted ahead (docs/traffic-format.md names the strategy). `sumo`: SUMO's own
# driver model drives a vehicle of the truck's length on the same route (the baseline; SUMO has no
# trailers). Same seed, so the same cars.

# %%
results = {}
for driver in ("autopilot", "sumo"):
    folder = OUT / driver
    folder.mkdir(parents=True, exist_ok=True)
    results[driver] = run_traffic(scenario, sumo, folder, driver, 1)
    s = results[driver]
    print(f"{driver:9s}: arrived {s['arrived']}, travel {s['travel_time']:.1f} s (alone {s['free_flow_time']:.1f} s), "
          f"delay {s['delay']:.1f} s, stood {s['entry_wait']:.1f} s at the line")

# %% [markdown]
# ## 4. The metrics, from exact geometry
#
# Every distance is shapely's between the truck's body rectangles (from its states) and every other
# vehicle's rectangle (from `traffic.csv`): the least distance, the steps with an overlap (collisions),
# the hardest braking of a vehicle within 50 m of the truck (and the same without the truck: the
# cars brake at 4.5 m/s^2 before the ring anyway), the road clearance of the truck's bodies, and the
# time the others lose with and without the truck on the same seed.

# %%
keys = ("collisions", "min_distance", "max_braking_caused", "max_braking_without_truck", "min_clearance",
        "others_time_loss", "others_time_loss_without_truck", "realtime_factor")
for key in keys:
    print(f"{key:31s}" + "".join(f"{results[d].get(key, float('nan')):>12.3f}" for d in results))

# %% [markdown]
# ## 5. Gap acceptance at the entry
#
# The conflicting stream is measured where the truck enters: the times at which circulating vehicles
# cross the ray along its entry leg's axis. The headway that contains the truck's entry is the gap it
# accepted; complete headways between its arrival (10 m before the curb) and its entry are gaps it
# rejected. Over many runs these give its effective critical gap t_c (Raff's method; the study in the
# paper pools them), and with it Adams' mean wait and the entry capacity, beside the HCM's (whose
# formula is Siegloch's with t_c = 4.98 s for passenger cars).

# %%
records = {d: run_record(scenario, OUT / d) for d in results}
for d, r in records.items():
    print(f"{d:9s}: arrived at the line {r['arrival']:.1f} s, entered {r['entry']:.1f} s, entry cleared "
          f"{r['cleared']:.1f} s; accepted gap {r['accepted_gap']:.1f} s, rejected {r['rejected_gaps']}")
q = 3600 * conflicting_demand(scenario)
print(f"at {q:.0f} veh/h: Adams' mean wait with the HCM's t_c {adams_delay(q / 3600, HCM_CRITICAL_GAP):.2f} s; "
      f"HCM entry capacity {hcm_capacity(q):.0f} pc/h")

# %% [markdown]
# ## 6. The run drawn
#
# The time-space diagram shows the conflict zone: every vehicle on the ring by its position along the
# ring from the truck's entry line, against time, with the truck's front bumper and rear; the
# snapshots show the scene at the truck's arrival at the line, its entry, its entry cleared and its
# arrival, every vehicle to scale.

# %%
trajectory = read_columns(OUT / "autopilot" / "trajectory.csv")
others = read_columns(OUT / "autopilot" / "traffic.csv")
paths = save(time_space(ocp, others, trajectory, records["autopilot"]), OUT / "time-space", formats=("png",))
paths += save(snapshots(ocp, others, trajectory, records["autopilot"]), OUT / "snapshots", formats=("png",))
print("wrote", ", ".join(p.name for p in paths))
plt.close("all")
print(f"run time {time.perf_counter() - STARTED:.1f} s")
