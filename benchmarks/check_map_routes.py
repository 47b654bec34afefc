"""Routes through the real rounD maps, solved by the CLI and checked apart from the project's corridor code.

Usage: python benchmarks/check_map_routes.py --out DIR [--maps Kackertstrasse Thiergarten]
       [--vehicles SU-30 EU-semitrailer] [--seed 0] [--intervals 100] [--time-limit 120] [--json F]

For every map, vehicle and kind of movement (right: the first exit, straight on, left, U-turn: by the
heading change from the entry lanelet to the exit lanelet) one movement of that kind is drawn with the
seed from the map's lanelet graph, with and without the map's apron (the non-drivable lanelet at the
ring's centre), posed as the map study poses a cell (``model.studies.maps.cell_document``: start and
goal on the route's centre line where the vehicle stands inside the corridor), written as a scenario
file and solved as a user would: ``roundabout solve FILE --out DIR --time-limit T`` in its own process
(the default search). Each answer with exit 0 is then checked here:

- *corridor*: rebuilt from docs/map-format.md's rule with commonroad-io and shapely alone (the
  lanelets reachable from ``from_lanelet`` by successors that still reach ``to_lanelet``; a lanelet's
  polygon its left bound followed by the reversed right bound; the apron lanelets for the bodies
  ``apron_use`` allows), not ``model.scene.lanelet_map``; its lanelets compared with ``route_lanelets``;
- *rectangles*: every body's exact rectangle (the vehicle's body poses, ``Body.corners``) inside that
  corridor at the nodes and, on the trajectory re-integrated from the node controls (scipy's DOP853
  with the controls linear between nodes, as the trapezoid rule takes them), at 8 sub-steps per
  interval; the re-integration's largest position drift at the nodes is reported;
- *commonroad.xml*: read back with commonroad-io: one ``DynamicObstacle`` per body whose rectangle has
  the body's length and width and whose centre follows the body's centre along the trajectory
  (largest distance at the file's time steps);
- *drivability checker*: commonroad-drivability-checker's road boundary of the written map
  (``create_road_boundary_obstacle``, aligned triangulation): no body rectangle, shrunk by 1 cm,
  collides with it at the nodes (the lateral links of a lanelet mapped twice, Neuweiler's 180 and 181,
  are cut first: the checker's walk along them never ends; ``lateral_cycles_cut``).

An exit 1 is a refusal: its ``summary.json`` diagnosis is reported (which body leaves the corridor,
by how much). Exit 2 (the pose cannot be posed) and other codes are reported as they are.
"""

from __future__ import annotations

import argparse
import json
import random
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import shapely

ROOT = Path(__file__).resolve().parents[1]
# Neuweiler last: the movements are drawn from one random sequence in this order (seeds 0 and 1 draw
# the same Kackertstrasse and Thiergarten routes as before Neuweiler was added)
MAPS = {"Kackertstrasse": "rounD/DEU_Kackertstrasse-1", "Thiergarten": "rounD/DEU_Thiergarten-1",
        "Neuweiler": "rounD/DEU_Neuweiler-1"}
TEMPLATE = ROOT / "workflows" / "scenarios" / "maps" / "kackertstrasse.toml"
KINDS = ("right", "straight", "left", "U-turn")
SUBSTEPS = 8
LEFT = 225.0  # degrees about the ring's centre: the least sweep of a left turn
CRACK = 1e-3  # m: docs/map-format.md closes cracks up to this width between lanelet polygons


def sweep(lanelet_map, movement, centre) -> float:
    """Degrees the route's centre line turns about the ring's centre (unwrapped, signed)."""
    line = np.vstack([lanelet_map.lanelet(i).center_vertices for i in movement.lanelets])
    angles = np.unwrap(np.arctan2(line[:, 1] - centre.y, line[:, 0] - centre.x))
    return float(np.degrees(angles[-1] - angles[0]))


def kinds(lanelet_map, found: list) -> dict[str, str]:
    """The kind of every movement by its exit's order around the ring from its entry: the exits of one
    entry sorted by the angle the route sweeps about the ring's centre (exits within 20 degrees are one
    leg), the first leg a right turn, the last a left turn, those between straight on, and a leg the
    route sweeps more than 300 degrees to (back to its own leg) a U-turn; the last leg is a left turn only
    if the route sweeps at least 225 degrees to it (Neuweiler's open ring leaves some entries two exits,
    the second of them straight across, 171-174 degrees). In left-hand traffic the
    names of right and left swap; the rounD maps are right-hand."""
    from model.studies.maps import ring_lanelets

    centre = shapely.union_all([lanelet_map.polygon(i) for i in ring_lanelets(lanelet_map)]).centroid
    out: dict[str, str] = {}
    for entry in sorted({m.entry for m in found}):
        swept = sorted((abs(sweep(lanelet_map, m, centre)), m.name) for m in found if m.entry == entry)
        legs: list[list[tuple[float, str]]] = []
        for angle, name in swept:
            if legs and angle - legs[-1][-1][0] < 20.0:
                legs[-1].append((angle, name))
            else:
                legs.append([(angle, name)])
        others = [leg for leg in legs if leg[0][0] <= 300.0]
        for leg in legs:
            if leg[0][0] > 300.0:
                kind = "U-turn"
            else:
                last = leg is others[-1] and leg[0][0] >= LEFT
                kind = "right" if leg is others[0] else ("left" if last else "straight")
            out |= {name: kind for _, name in leg}
    return out


def apron_lanelets(lanelet_map) -> list[int]:
    """The non-drivable lanelets whose centroid lies within 2 m of the ring's centroid (the central apron)."""
    from model.studies.maps import ring_lanelets

    centre = shapely.union_all([lanelet_map.polygon(i) for i in ring_lanelets(lanelet_map)]).centroid
    near = [i for i in lanelet_map.ids if lanelet_map.polygon(i).centroid.distance(centre) < 2.0]
    return sorted(i for i in near if not lanelet_map.drivable(i))


def cases(names: list[str], vehicles: list[str], seed: int) -> list[dict]:
    """One movement per map x kind (drawn with ``seed``), for each vehicle, with and without the apron."""
    from model.scene.lanelet_map import dataset_file, read_map
    from model.studies.maps import movements

    rng, out = random.Random(seed), []
    for name in names:
        lanelet_map = read_map(dataset_file(MAPS[name]))
        found, by_kind = movements(lanelet_map), {}
        named = kinds(lanelet_map, found)
        for m in found:
            by_kind.setdefault(named[m.name], []).append(m)
        aprons = apron_lanelets(lanelet_map)
        for kind in KINDS:
            if not by_kind.get(kind):
                continue
            movement = rng.choice(by_kind[kind])
            for vehicle in vehicles:
                for apron in (True, False):
                    out.append({"map": name, "dataset": MAPS[name], "kind": kind, "movement": movement.name,
                                "vehicle": vehicle, "apron": apron, "apron_lanelets": aprons})  # fmt: skip
    return out


def write_scenario(case: dict, folder: Path, intervals: int) -> Path | str:
    """The case's scenario file (the map study's cell), or the one-line reason it cannot be posed."""
    from model.errors import InputError
    from model.problem.tables import toml_text
    from model.scene.lanelet_map import dataset_file, read_map
    from model.studies.maps import cell_document

    template = tomllib.loads(TEMPLATE.read_text())
    template["map"] = {"dataset": case["dataset"]}
    template["route"] = {"apron_lanelets": case["apron_lanelets"]}
    lanelet_map = read_map(dataset_file(case["dataset"]))
    try:
        doc = cell_document(template, lanelet_map, case["vehicle"], case["movement"], case["apron"], intervals)
    except InputError as exc:
        return str(exc)
    doc["name"] = f"{case['map']}_{doc['name']}"
    path = folder / f"{doc['name']}.toml"
    path.write_text(toml_text(doc))
    return path


# --------------------------------------------------------------------------- the independent checks


def lanelet_polygon(lanelet) -> shapely.Polygon:
    """A commonroad-io lanelet's polygon: its left bound, then its right bound reversed (made valid)."""
    return shapely.make_valid(shapely.Polygon(np.vstack([lanelet.left_vertices, lanelet.right_vertices[::-1]])))


def contract_corridor(xml: Path, route: dict, bodies: list[str], apron_use: str):
    """docs/map-format.md's corridor per body, from the map file with commonroad-io and shapely only."""
    from commonroad.common.file_reader import CommonRoadFileReader

    scenario, _ = CommonRoadFileReader(str(xml)).open()
    net = scenario.lanelet_network
    lanelets = {la.lanelet_id: la for la in net.lanelets}

    def reach(start: int, step) -> set[int]:
        seen, stack = {start}, [start]
        while stack:
            for j in step(lanelets[stack.pop()]):
                if j in lanelets and j not in seen:
                    seen.add(j)
                    stack.append(j)
        return seen

    forward = reach(route["from_lanelet"], lambda la: la.successor)
    backward = reach(route["to_lanelet"], lambda la: la.predecessor)
    ids = sorted(forward & backward)

    def united(polygons):  # docs/map-format.md: cracks narrower than 1 mm between lanelets closed
        merged = shapely.union_all(polygons)
        return merged.buffer(CRACK / 2, join_style="mitre").buffer(-CRACK / 2, join_style="mitre")

    lanes = united([lanelet_polygon(lanelets[i]) for i in ids])
    apron = united([lanes] + [lanelet_polygon(lanelets[i]) for i in route.get("apron_lanelets", [])])
    allowed = {"all": set(bodies), "none": set(), "trailer": {b for b in bodies if b != bodies[0]}}[apron_use]
    return ids, {b: (apron if b in allowed else lanes) for b in bodies}


def reintegrated(ocp, traj, substeps: int = SUBSTEPS) -> tuple[dict[str, np.ndarray], float]:
    """The states at ``substeps`` points per interval, each interval integrated from its first node's state
    with the controls linear between the nodes, and the largest position gap (m) at the interval's end
    to the next node of the trajectory."""
    from scipy.integrate import solve_ivp

    v = ocp.vehicle
    f = v.rhs_function()
    t = traj["t"].to_numpy()
    x_nodes = np.array([traj[s].to_numpy() for s in v.states])
    u_nodes = np.array([traj[c].to_numpy() for c in v.controls])
    px, py = (v.states.index(n) for n in v.position)
    pieces, drift = [], 0.0
    for k in range(len(t) - 1):
        a, b = t[k], t[k + 1]

        def rhs(s, x, k=k, a=a, b=b):
            w = (s - a) / (b - a)
            return f(x, (1 - w) * u_nodes[:, k] + w * u_nodes[:, k + 1])

        times = np.linspace(a, b, substeps + 1)
        sol = solve_ivp(rhs, (a, b), x_nodes[:, k], method="DOP853", rtol=1e-10, atol=1e-10, t_eval=times)
        pieces.append(sol.y)
        end = sol.y[:, -1]
        drift = max(drift, float(np.hypot(end[px] - x_nodes[px, k + 1], end[py] - x_nodes[py, k + 1])))
    y = np.hstack(pieces)
    return {s: y[i] for i, s in enumerate(v.states)}, drift


def outside_depth(rect: shapely.Polygon, corridor) -> float:
    """How far (m) the rectangle reaches out of the corridor: the largest distance to the corridor of the
    part outside it, on its boundary sampled every millimetre (0 inside)."""
    piece = rect.difference(corridor)
    if piece.is_empty:
        return 0.0
    points = np.vstack([np.asarray(g.exterior.segmentize(0.001).coords) for g in getattr(piece, "geoms", [piece])
                        if g.geom_type == "Polygon"] or [np.zeros((1, 2))])  # fmt: skip
    return float(max(shapely.Point(p).distance(corridor) for p in points))


def worst_outside(ocp, columns, corridors) -> tuple[float, str]:
    """The largest distance (m) by which a body's exact rectangle leaves its corridor, and the body."""
    poses, worst = ocp.vehicle.body_poses(), (0.0, "-")
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(columns)
        for corners in body.corners(x, y, h):
            worst = max(worst, (outside_depth(shapely.Polygon(corners), corridors[name]), name))
    return worst


def commonroad_check(ocp, columns: dict[str, np.ndarray], scenario) -> tuple[int, float, str]:
    """Obstacles read back, the largest centre distance (m) to the bodies' centres, and the size check."""
    obstacles = scenario.dynamic_obstacles
    poses, worst, sizes = ocp.vehicle.body_poses(), 0.0, "ok"
    t = columns["t"]
    centres = {}
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(columns)
        centres[name] = (body.corners(x, y, h).mean(axis=1), body)
    for obstacle, (name, (centre, body)) in zip(obstacles, centres.items(), strict=False):
        shape = obstacle.obstacle_shape
        if abs(shape.length - body.length) > 1e-6 or abs(shape.width - body.width) > 1e-6:
            sizes = f"{name}: {shape.length} x {shape.width}"
        states = [obstacle.initial_state] + list(obstacle.prediction.trajectory.state_list)
        for s in states:
            ts = s.time_step * scenario.dt
            if ts > t[-1] + 1e-9:
                continue
            want = np.array([np.interp(ts, t, centre[:, 0]), np.interp(ts, t, centre[:, 1])])
            worst = max(worst, float(np.hypot(*(np.asarray(s.position) - want))))
    return len(obstacles), worst, sizes


def lateral_cycles_cut(network) -> list[int]:
    """Cut the lateral links of lanelets whose walk to the right comes back to them, and name them.

    Neuweiler's lanelets 180 and 181 are one lanelet mapped twice, each the other's left and right
    neighbour in the opposite direction: the drivability checker's lane sections
    (``commonroad_dc.boundary.lanelet_bounds.lane_sections``, walking to the rightmost lanelet)
    never end on them. Their polygons are kept, so the road's area is the same.
    """
    cut = []
    for lanelet in network.lanelets:
        seen, current, direction = {lanelet.lanelet_id}, lanelet, True
        while True:  # the checker's walk to the rightmost lanelet
            nxt, same = ((current.adj_right, current.adj_right_same_direction) if direction
                         else (current.adj_left, current.adj_left_same_direction))  # fmt: skip
            if nxt is None:
                break
            if nxt in seen:
                cut += sorted(seen)
                break
            seen.add(nxt)
            direction = direction == same
            current = network.find_lanelet_by_id(nxt)
    for lanelet_id in set(cut):
        lanelet = network.find_lanelet_by_id(lanelet_id)
        lanelet.adj_left = lanelet.adj_right = None
    return sorted(set(cut))


def boundary_hits(ocp, columns: dict[str, np.ndarray], scenario) -> tuple[int, int]:
    """Body rectangles at the nodes (shrunk 1 cm) that collide with the drivability checker's road
    boundary of the written map, and how many of those reach out of every lanelet of the map (the union
    of all its lanelet polygons, cracks under 1 mm closed): a hit that does not is the checker's
    triangulation of a crack between two lanelets, not a body off the road."""
    import commonroad_dc.pycrcc as pycrcc
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle

    _, boundary = create_road_boundary_obstacle(scenario, method="aligned_triangulation", axis=2)
    road = shapely.union_all([lanelet_polygon(la) for la in scenario.lanelet_network.lanelets])
    road = road.buffer(CRACK / 2, join_style="mitre").buffer(-CRACK / 2, join_style="mitre")
    poses, hits, off_road = ocp.vehicle.body_poses(), 0, 0
    for name, body in ocp.bodies.items():
        x, y, h = ocp.vehicle.state_function(list(poses[name]))(columns)
        for a, corners in zip(h, body.corners(x, y, h), strict=True):
            cx, cy = corners.mean(axis=0)
            if boundary.collide(pycrcc.RectOBB(body.length / 2 - 0.01, body.width / 2 - 0.01, float(a),
                                               float(cx), float(cy))):  # fmt: skip
                hits += 1
                off_road += outside_depth(shapely.Polygon(corners), road) > 0.01
    return hits, off_road


def check(path: Path, out: Path) -> dict:
    """The independent checks of one solved case."""
    import pandas as pd
    from commonroad.common.file_reader import CommonRoadFileReader

    from model.problem.scenario import load_scenario
    from model.scene.lanelet_map import dataset_file

    doc = tomllib.loads(path.read_text())
    ocp = load_scenario(path).ocp
    summary = json.loads((out / "summary.json").read_text())
    traj = pd.read_csv(out / "trajectory.csv")
    ids, corridors = contract_corridor(dataset_file(doc["map"]["dataset"]), doc["route"], list(ocp.bodies),
                                       doc["route"].get("apron_use", "trailer"))  # fmt: skip
    columns = {c: traj[c].to_numpy() for c in traj.columns}
    nodes = worst_outside(ocp, columns, corridors)
    states, drift = reintegrated(ocp, traj)
    between = worst_outside(ocp, states, corridors)
    scenario, _ = CommonRoadFileReader(str(out / "commonroad.xml")).open()
    n_obstacles, centre_error, sizes = commonroad_check(ocp, columns, scenario)
    cut = lateral_cycles_cut(scenario.lanelet_network)  # before the checker walks the lanes
    hits, off_road = boundary_hits(ocp, columns, scenario)
    agree = ids == summary["route_lanelets"]
    passed = (nodes[0] <= 1e-6 and between[0] <= 0.02 and drift <= 0.05 and n_obstacles == len(ocp.bodies)
              and centre_error <= 0.05 and sizes == "ok" and off_road == 0 and agree)  # fmt: skip
    return {"corridor_lanelets_agree": agree, "outside_nodes_m": nodes[0],
            "outside_between_m": between[0], "outside_body": between[1] if between[0] else nodes[1],
            "reintegration_drift_m": drift, "commonroad_obstacles": n_obstacles,
            "commonroad_centre_error_m": centre_error, "commonroad_sizes": sizes,
            "boundary_hits": hits, "boundary_hits_off_road": off_road, "boundary_links_cut": cut,
            "checks_pass": bool(passed)}  # fmt: skip


def run_case(case: dict, folder: Path, intervals: int, time_limit: float, grid: str | None = None) -> dict:
    """Pose, solve in its own process, check."""
    record = dict(case)
    path = write_scenario(case, folder, intervals)
    if isinstance(path, str):
        return record | {"result": "not posed", "reason": path}
    out = folder / path.stem
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "model.cli", "solve", str(path), "--out", str(out), "--quiet",
                          "--time-limit", str(time_limit), *(["--map-grid", grid] if grid else [])],
                         capture_output=True, text=True)  # fmt: skip
    record |= {"exit": run.returncode, "wall_s": round(time.perf_counter() - start, 1)}
    summary_file = out / "summary.json"
    if not summary_file.exists():
        return record | {"result": f"exit {run.returncode}", "reason": (run.stderr.strip().splitlines() or [""])[-1]}
    summary = json.loads(summary_file.read_text())
    record |= {"Tf": summary.get("final_time"), "cpu_s": summary.get("cpu_seconds")}
    if run.returncode == 0:
        record |= check(path, out)
        record["result"] = "solved, checks pass" if record["checks_pass"] else "solved, a check fails"
        if summary.get("route_loops"):
            record["reason"] = f"once more round the ring ({summary['route_loops']} loop)"
    else:
        diagnosis = summary.get("diagnosis") or {}
        record |= {"result": "refused", "reason": diagnosis.get("message", json.dumps(diagnosis)[:200])}
    return record


def table(records: list[dict]) -> str:
    head = ("| map | kind | movement | vehicle | apron | result | Tf (s) | wall s | outside nodes / between (m) "
            "| drift (m) | commonroad (obstacles, centre m) | boundary hits (off road) | note |")  # fmt: skip
    rows = [head, "|" + "---|" * 13]
    for r in records:
        geo = f"{r['outside_nodes_m']:.3f} / {r['outside_between_m']:.3f}" if "outside_nodes_m" in r else ""
        drift = f"{r['reintegration_drift_m']:.1e}" if "reintegration_drift_m" in r else ""
        cr = f"{r['commonroad_obstacles']}, {r['commonroad_centre_error_m']:.3f}" if "commonroad_obstacles" in r else ""
        hits = f"{r['boundary_hits']} ({r['boundary_hits_off_road']})" if "boundary_hits" in r else ""
        tf = f"{r['Tf']:.3f}" if isinstance(r.get("Tf"), float) and r.get("exit") == 0 else ""
        rows.append(f"| {r['map']} | {r['kind']} | {r['movement']} | {r['vehicle']} | {'yes' if r['apron'] else 'no'} "
                    f"| {r['result']} | {tf} | {r.get('wall_s', '')} | {geo} | {drift} | {cr} "
                    f"| {hits} | {r.get('reason', '')[:160]} |")  # fmt: skip
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--maps", nargs="+", default=list(MAPS), choices=list(MAPS))
    ap.add_argument("--vehicles", nargs="+", default=["SU-30", "EU-semitrailer"])
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=list(KINDS))
    ap.add_argument("--no-apron-pairs", action="store_true", help="only the cases with the apron")
    ap.add_argument("--only-without-apron", action="store_true", help="only the cases without the apron")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--intervals", type=int, default=100)
    ap.add_argument("--time-limit", type=float, default=120.0)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--map-grid", choices=("time", "arclength", "time+arclength"), default=None,
                    help="roundabout solve --map-grid (default: its default)")  # fmt: skip
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    todo = [c for c in cases(args.maps, args.vehicles, args.seed)
            if c["kind"] in args.kinds and (c["apron"] or not args.no_apron_pairs)
            and not (c["apron"] and args.only_without_apron)]  # fmt: skip
    records = []
    for i, case in enumerate(todo, 1):
        print(f"[{i}/{len(todo)}] {case['map']} {case['kind']} {case['movement']} {case['vehicle']} "
              f"apron={case['apron']}", file=sys.stderr, flush=True)  # fmt: skip
        records.append(run_case(case, args.out, args.intervals, args.time_limit, args.map_grid))
        print(f"    {records[-1]['result']} ({records[-1].get('wall_s', '-')} s)", file=sys.stderr, flush=True)
        if args.json:
            args.json.write_text(json.dumps(records, indent=1, default=str))
    print(table(records))
    solved = sum(r["result"] == "solved, checks pass" for r in records)
    print(f"\n{solved} of {len(records)} solved with every check passing", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
