import math
from pathlib import Path

import pytest

from model import OCP, Circle, Energy, Time, Truck

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "workflows" / "scenarios").glob("*.toml"))
EXAMPLE = ROOT / "examples" / "format-example.toml"

TRUCK_BOUNDS = {"u1": (-1.0, 1.0), "u2": (-0.35, 0.35), "phi": (-0.6, 0.6)}
START = {"x": 0.0, "y": 0.0, "theta": 0.0, "phi": 0.0}


def straight(cost, length: float = 1.0, tf: float = 2.0) -> OCP:
    """Obstacle-free drive along the x axis (energy: u1 = L / Tf; time: Tf = L / u1max)."""
    return OCP(
        vehicle=Truck(0.1),
        cost=cost,
        bounds=TRUCK_BOUNDS,
        initial=START,
        final={"x": length, "y": 0.0, "theta": 0.0, "phi": 0.0},
        final_time=tf,
    )


def straight_energy(length: float = 1.0, tf: float = 2.0) -> OCP:
    return straight(Energy(), length, tf)


def straight_time(length: float = 1.0) -> OCP:
    return straight(Time(), length, 3.0)  # final_time: the first guess


def paper_energy_problem(tf: float = 4.5) -> OCP:
    """The scenario format's example, posed in Python."""
    return OCP(
        vehicle=Truck(wheelbase=0.1),
        cost=Energy(),
        final_time=tf,
        bounds=TRUCK_BOUNDS,
        obstacles=[Circle(center=(0.5, 0.03), radius=0.2, safety=0.05)],
        initial=START,
        final={"x": 1.0, "y": 0.0, "theta": 0.0},
        passing="ccw",
    )


@pytest.fixture(scope="session")
def example_solution():
    return paper_energy_problem().solve(intervals=100)


__all__ = ["math"]


def replay_as_the_contract_says(out: Path, commands: dict | None = None) -> None:
    """docs/traffic-format.md's replay loop, written here apart from model.traffic, on ``out``'s sumo/ folder and
    trajectory.csv (and a cooperative run's speed ``commands``, t -> id -> m/s): it must give traffic.csv."""
    import csv

    import traci

    rows = {round(float(r["t"]), 6): r for r in csv.DictReader((out / "trajectory.csv").open())}
    front, seen = 8.0 - 1.5, []  # the example truck's front bumper ahead of its rear axle
    traci.start(["sumo", "-c", str(out / "sumo" / "run.sumocfg")])
    try:
        while traci.simulation.getTime() < max(rows) - 1e-9:
            t_next = round(traci.simulation.getTime() + 0.1, 6)
            if t_next in rows and "truck" in traci.vehicle.getIDList():
                r = rows[t_next]
                th = float(r["theta"])
                x, y = float(r["x"]) + front * math.cos(th), float(r["y"]) + front * math.sin(th)
                traci.vehicle.moveToXY("truck", "", -1, x, y, 90 - math.degrees(th), keepRoute=2)
            for vid, speed in (commands or {}).get(t_next, {}).items():
                if vid in traci.vehicle.getIDList():
                    traci.vehicle.setSpeed(vid, speed)
            traci.simulationStep()
            t = round(traci.simulation.getTime(), 6)
            seen += [(t, vid, traci.vehicle.getPosition(vid)) for vid in traci.vehicle.getIDList() if vid != "truck"]
    finally:
        traci.close()
    recorded = list(csv.DictReader((out / "traffic.csv").open()))
    assert len(seen) == len(recorded) > 0
    for (t, vid, (fx, fy)), r in zip(seen, recorded, strict=True):  # SUMO's front bumper -> the rectangle's centre
        assert (t, vid) == (float(r["t"]), r["id"])
        h, half = float(r["heading"]), float(r["length"]) / 2
        assert math.hypot(fx - half * math.cos(h) - float(r["x"]), fy - half * math.sin(h) - float(r["y"])) < 1e-6


@pytest.fixture
def contract_replay():
    """``replay_as_the_contract_says``, for the traffic tests."""
    return replay_as_the_contract_says
