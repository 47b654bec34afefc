"""Diagnosis: where SUMO puts the truck when an autopilot run makes another vehicle brake hard.

Usage: PYTHONPATH=$PWD python benchmarks/traffic/diagnose_braking.py VEHICLE TURN RATE SEED OUTDIR

Drives the autopilot (``autopilot_drive``), finds the step and vehicle of the largest braking,
then replays the recorded poses (the contract's replay loop, keepRoute=2) printing, around that step, the
truck's lane before and after ``moveToXY`` and the braking vehicle's lane, speed and leader.
"""

import sys
from pathlib import Path

from benchmarks.bench_traffic import document
from model.problem.scenario import parse_scenario
from model.traffic.autopilot import plan_of
from model.traffic.cosim import TIME_DIGITS, autopilot_drive, start_sumo, write_sumo_files
from model.traffic.run import solve_plan
from model.traffic.sumo import find_sumo


def main() -> None:
    """Drive, locate the worst braking, replay with traci queries around it."""
    vehicle, turn, rate, seed, out = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), Path(sys.argv[5])
    scenario = parse_scenario(document(vehicle, turn, rate))
    sol, _ = solve_plan(scenario)
    sumo = find_sumo()
    write_sumo_files(scenario, out, sumo, seed)
    driven = autopilot_drive(scenario, sumo, out, plan_of(sol, scenario.ocp.vehicle))
    t_worst, who, worst = max(((t, k, b) for t, d in driven.braking.items() for k, b in d.items()), key=lambda r: r[2])
    print(f"worst braking {worst:.2f} by {who} at t={t_worst}")
    traci = start_sumo(sumo, out)
    v = traci.vehicle
    try:
        while traci.simulation.getTime() < t_worst + 0.5 - 1e-9:
            t_next = round(traci.simulation.getTime() + scenario.traffic.step, TIME_DIGITS)
            near = abs(t_next - t_worst) <= 1.0
            if t_next in driven.truck and "truck" in v.getIDList():
                x, y, a = driven.truck[t_next][:3]
                before = (v.getLaneID("truck"), round(v.getLanePosition("truck"), 2))
                v.moveToXY("truck", "", -1, x, y, a, keepRoute=2)
                if near:
                    print(f"t={t_next} truck pose ({x:.2f},{y:.2f},{a:.1f}) lane before {before}")
            traci.simulationStep()
            if near and "truck" in v.getIDList():
                print(f"   after step truck lane {v.getLaneID('truck')} pos {v.getLanePosition('truck'):.2f} "
                      f"xy {tuple(round(c, 2) for c in v.getPosition('truck'))} route {v.getRoute('truck')}")
            if near and who in v.getIDList():
                print(f"   {who} lane {v.getLaneID(who)} pos {v.getLanePosition(who):.2f} v {v.getSpeed(who):.2f} "
                      f"acc {v.getAcceleration(who):.2f} leader {v.getLeader(who, 50)} "
                      f"next TLS/links {[(lk[0]) for lk in v.getNextLinks(who)[:2]]}")
    finally:
        traci.close()


if __name__ == "__main__":
    main()
