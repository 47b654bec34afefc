"""Record the truck's front poses of one autopilot run as CSV (t, x, y, angle): a test's fixture.

Usage: PYTHONPATH=$PWD python benchmarks/traffic/record_poses.py VEHICLE TURN RATE SEED DETAIL OUT.csv

Drives the bench's cell (``benchmarks.bench_traffic.document``) with the autopilot on a network
converted with ``--junctions.internal-link-detail DETAIL`` (5 is netconvert's default, the network
of benchmarks/traffic.md round 3) and writes the poses the contract's replay loop sends to
``moveToXY``. tests/data/traffic/semitrailer-right-450-seed4.csv is ``semitrailer right 450 4 5``.
"""

import sys
import tempfile
from pathlib import Path

import model.traffic.network as network
from benchmarks.bench_traffic import document
from model.problem.scenario import parse_scenario
from model.traffic.autopilot import plan_of
from model.traffic.cosim import autopilot_drive, write_sumo_files
from model.traffic.run import solve_plan
from model.traffic.sumo import find_sumo


def main() -> None:
    """Solve the cell's plan, drive it among the seed's traffic, write the truck's poses."""
    vehicle, turn, rate, seed = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
    network.INTERNAL_LINK_DETAIL, out = int(sys.argv[5]), Path(sys.argv[6])
    scenario = parse_scenario(document(vehicle, turn, rate))
    sol, _ = solve_plan(scenario)
    sumo = find_sumo()
    with tempfile.TemporaryDirectory() as tmp:
        write_sumo_files(scenario, Path(tmp), sumo, seed)
        driven = autopilot_drive(scenario, sumo, Path(tmp), plan_of(sol, scenario.ocp.vehicle))
    rows = [f"{t:.1f},{x:.4f},{y:.4f},{a:.4f}" for t, (x, y, a, *_) in sorted(driven.truck.items())]
    out.write_text("t,x,y,angle\n" + "\n".join(rows) + "\n")
    worst = max((max(d.values(), default=0.0) for d in driven.braking.values()), default=0.0)
    print(f"{len(rows)} poses, max braking caused {worst:.2f}")


if __name__ == "__main__":
    main()
