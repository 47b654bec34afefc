"""Vehicle roles (issue 19, item 4): nothing outside model/vehicles/ knows a vehicle's state names.

A car-like truck with the standard truck's dynamics but other names in another order (states
``(psi, px, py, delta)``, controls ``(steer_rate, v)``) is registered as a model of its own; the
same scenario files, renamed, solve to the truck's objectives, and the plant and the tracking
controller drive it as they drive the truck. A scan of model/ and derivations/ keeps the rule:
no string literal that is one of the standard vehicles' state or control names outside
model/vehicles/ and the files exempted below with their reasons.
"""

from __future__ import annotations

import ast
import copy
import io
import re
import tokenize
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from model.errors import InputError
from model.problem.closed_loop import Disturbance
from model.problem.scenario import parse_scenario
from model.simulation.controllers import Tracking
from model.simulation.loop import simulate
from model.simulation.mpc import MPC
from model.simulation.plant import Plant
from model.vehicles import VEHICLES, Roles, Truck, Vehicle, sym
from tests.conftest import ROOT

RENAME = {"x": "px", "y": "py", "theta": "psi", "phi": "delta", "u1": "v", "u2": "steer_rate"}


@dataclass
class RenamedCar(Vehicle):
    """The paper's truck, system (1), with other names in another order (the wheelbase too: l)."""

    wheelbase: float = 0.1
    model = "renamed-car"
    parameter_keys = {"l": "wheelbase"}
    states = ("psi", "px", "py", "delta")
    controls = ("steer_rate", "v")
    roles = Roles(x="px", y="py", heading="psi", steering="delta", speed="v", steering_rate="steer_rate")

    def parameters(self) -> dict[str, float]:
        return {"l": float(self.wheelbase)}

    def dynamics(self) -> dict[str, sp.Expr]:
        psi, px, py, delta = self.state_symbols()
        steer_rate, v = self.control_symbols()
        wheelbase = sym("l")
        return {"psi": v * sp.tan(delta) / wheelbase, "px": v * sp.cos(psi), "py": v * sp.sin(psi), "delta": steer_rate}

    @property
    def lateral_acceleration(self) -> sp.Expr:
        return sym("v") ** 2 * sp.tan(sym("delta")) / sym("l")


@pytest.fixture
def registered(monkeypatch):
    """The renamed car in the registry a scenario's ``model = "..."`` looks up."""
    monkeypatch.setitem(VEHICLES, RenamedCar.model, RenamedCar)


def renamed(doc: dict) -> dict:
    """A truck scenario document for the renamed car: the model and every state and control key renamed."""
    out = copy.deepcopy(doc)
    out["vehicle"]["model"] = RenamedCar.model
    for table in ("bounds", "initial", "final"):
        if table in out:
            out[table] = {RENAME.get(k, k): val for k, val in out[table].items()}
    return out


def load(name: str, **problem) -> dict:
    doc = tomllib.loads((ROOT / "examples" / name).read_text())
    doc["problem"] = {**doc["problem"], **problem}
    return doc


def same_columns(car: dict, truck: dict, rel: float) -> None:
    """The car's state and control columns are the truck's, renamed."""
    for old, new in RENAME.items():
        scale = max(1.0, float(np.max(np.abs(truck[old]))))
        assert np.max(np.abs(np.asarray(car[new]) - np.asarray(truck[old]))) <= rel * scale, new


# -- the roles themselves -------------------------------------------------------------------------


def test_the_standard_vehicles_name_their_roles():
    assert Truck.roles == Roles() and Truck().position == ("x", "y")
    unicycle, trailer = VEHICLES["unicycle"].roles, VEHICLES["tractor-trailer"].roles
    assert unicycle.steering is None and unicycle.turning == unicycle.turn_rate == "u2"
    assert trailer.trailers == ("theta1",) and trailer.headings == ("theta", "theta1")
    for cls in VEHICLES.values():
        cls.roles.check(cls.states, cls.controls)


def test_a_role_that_names_no_state_is_refused_when_the_class_is_defined():
    with pytest.raises(TypeError, match=r"Roles.heading = 'theta' is not one of the states"):

        class Wrong(RenamedCar):
            roles = Roles(x="px", y="py", steering="delta", speed="v", steering_rate="steer_rate")

    with pytest.raises(TypeError, match=r"Roles.speed = 'px' is not one of the controls"):

        class Crossed(RenamedCar):
            roles = replace(RenamedCar.roles, speed="px")

    with pytest.raises(TypeError, match=r"Roles.y = 'px' is already Roles.x"):

        class Twice(RenamedCar):
            roles = replace(RenamedCar.roles, y="px")


def test_the_renamed_car_is_the_truck():
    car, truck = RenamedCar(0.3), Truck(0.3)
    f, g = car.dynamics(), truck.dynamics()
    subs = {sym(new): sym(old) for old, new in {**RENAME, "d": "l"}.items()}
    for old, new in RENAME.items():
        if old in g:
            assert sp.simplify(f[new].subs(subs, simultaneous=True) - g[old]) == 0, new
    assert car.reference_speed() == truck.reference_speed() == 1
    assert car.parameter_values() == truck.parameter_values() == {"wheelbase": 0.3}


def test_the_plant_disturbs_the_roles_not_the_places():
    """Speed gain on the speed control, steering bias on the steering angle, noise on position and heading."""
    dist = Disturbance(speed_gain=0.9, steering_bias=0.02, noise=0.1)
    car, truck = Plant(RenamedCar(2.0), dist, 0.1), Plant(Truck(2.0), dist, 0.1)
    state = {"x": 1.0, "y": -2.0, "theta": 0.7, "phi": 0.3}
    control = {"u1": 1.5, "u2": -0.2}
    xt, ut = np.array(list(state.values())), np.array(list(control.values()))
    xc = np.array([state[k] for k in ("theta", "x", "y", "phi")])
    uc = np.array([control["u2"], control["u1"]])
    assert car.rhs(xc, uc) == pytest.approx(truck.rhs(xt, ut)[[2, 0, 1, 3]], rel=1e-14)
    assert car.step(xc, uc) == pytest.approx(truck.step(xt, ut)[[2, 0, 1, 3]], rel=1e-9)
    assert car._noise_scale.tolist() == [0.1, 1.0, 1.0, 0.0]


def test_a_route_leaves_only_the_steering_and_trailer_headings_free(registered):
    """A road scenario of the renamed car takes its start and goal from the route, by the car's names."""
    doc = renamed(load("roundabout-truck.toml"))
    doc["initial"] = {"delta": 0.1}
    ocp = parse_scenario(doc).ocp
    assert list(ocp.initial) == ["px", "py", "psi", "delta"] and ocp.initial["delta"] == 0.1
    assert set(ocp.final) == {"px", "py", "psi"}
    for key, words in (("psi", "set by the [route]: only delta may be given"), ("theta", "not a state of the")):
        doc["initial"] = {key: 0.0}
        with pytest.raises(InputError, match=re.escape(words)) as err:
            parse_scenario(doc)
        assert err.value.key == f"initial.{key}"


# -- solves and the closed loop ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def disc_pair():
    """The closed-loop example (energy, a disc obstacle) solved for the truck and the renamed car at N = 40."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(VEHICLES, RenamedCar.model, RenamedCar)
        doc = load("closed-loop-truck.toml", intervals=40)
        doc["disturbance"]["noise"] = 0.0  # the noise is drawn in state order: the same draws on other states
        truck, car = parse_scenario(doc), parse_scenario(renamed(doc))
        return (truck, truck.ocp.solve(intervals=40)), (car, car.ocp.solve(intervals=40))


def test_the_renamed_car_solves_the_disc_scenario_as_the_truck(disc_pair):
    (_, truck), (_, car) = disc_pair
    assert truck.ok and car.ok, (truck.status, car.status, car.validation.get("checks"))
    assert car.objective == pytest.approx(truck.objective, rel=1e-6)
    same_columns(car.columns, truck.columns, 1e-4)
    assert [(a["pass"], a.get("route"), a["status"]) for a in car.attempts] == [
        (a["pass"], a.get("route"), a["status"]) for a in truck.attempts
    ]


def test_the_tracking_controller_drives_the_renamed_car_as_the_truck(disc_pair):
    (ts, truck), (cs, car) = disc_pair
    runs = [simulate(s, sol, Tracking(sol, s.control, s.disturbance), s.disturbance, s.control)
            for s, sol in ((ts, truck), (cs, car))]  # fmt: skip
    (t, c) = (r.summary for r in runs)
    assert t["reached_goal"] and c["reached_goal"]
    for key in ("final_position_error", "final_heading_error", "energy"):
        assert c[key] == pytest.approx(t[key], rel=1e-4, abs=1e-7), key
    same_columns(runs[1].columns, runs[0].columns, 1e-4)


def test_the_figures_draw_the_renamed_car_as_the_truck(disc_pair):
    """The paper's figures and the closed-loop figure read the roles: the same curves, the car's labels."""
    import matplotlib.pyplot as plt

    from model.plotting.closed_loop import closed_loop_figure
    from model.plotting.figures import costate_figure, solution_figure
    from model.plotting.results import Result

    drawn = []
    for scenario, sol in disc_pair:
        result = Result(scenario.ocp.name, sol.summary(), sol.trajectory)
        figs = [solution_figure(result, scenario.ocp), costate_figure(result, scenario.ocp)]
        run = simulate(scenario, sol, Tracking(sol, scenario.control, Disturbance()), Disturbance(), scenario.control)
        figs.append(closed_loop_figure(scenario.ocp, sol.columns, run.columns, run.summary))
        lines = [(ax.get_ylabel(), [ln.get_label() for ln in ax.get_lines()], [ln.get_ydata() for ln in ax.get_lines()])
                 for fig in figs for ax in fig.axes]  # fmt: skip
        drawn.append(lines)
        plt.close("all")
    (truck, car) = drawn
    assert len(truck) == len(car)
    close = lambda a, b: np.shape(a) == np.shape(b) and np.allclose(a, b, rtol=1e-4, atol=1e-6)  # noqa: E731
    for (_, _, yt), (_, _, yc) in zip(truck, car, strict=True):  # the same curves (the costates in state order)
        assert len(yt) == len(yc) and all(any(close(a, b) for b in yc) for a in yt)
    labels = " ".join(" ".join([y, *names]) for y, names, _ in car)
    assert "$v$" in labels and "$steer_{rate}$" in labels and "$p_{\\psi}$" in labels and "$u_1$" not in labels


def test_the_mpc_drives_the_renamed_car_as_the_truck(disc_pair):
    (ts, truck), (cs, car) = disc_pair
    control = replace(ts.control, horizon=20)
    t, c = (simulate(s, sol, MPC(sol, control, s.disturbance), s.disturbance, control).summary
            for s, sol in ((ts, truck), (cs, car)))  # fmt: skip
    assert t["reached_goal"]
    for key in ("final_position_error", "final_heading_error", "energy"):
        assert c[key] == pytest.approx(t[key], rel=1e-6), key


def test_the_renamed_car_takes_the_road_as_the_truck(registered):
    doc = load("roundabout-truck.toml")
    doc["problem"] = {"objective": "energy", "final_time": 20.0, "intervals": 40}
    truck, car = parse_scenario(doc).ocp, parse_scenario(renamed(doc)).ocp
    assert {car.initial[RENAME[k]] for k in ("x", "y", "theta")} == {truck.initial[k] for k in ("x", "y", "theta")}
    a, b = truck.solve(intervals=40), car.solve(intervals=40)
    assert a.ok and b.ok, (a.status, b.status, b.validation.get("checks"))
    assert b.objective == pytest.approx(a.objective, rel=1e-6)
    assert b.validation["measures"]["exit_taken"] == 2


# -- the rule, kept by a scan of the source ---------------------------------------------------------

NAMES = {"x", "y", "theta", "phi", "u1", "u2", "theta1", "theta2", "p_x", "p_y", "p_theta", "p_phi", "u2/u1"}
PRAGMA = "# names:"  # a line that carries this comment and a reason may hold such a literal
EXEMPT = {
    "model/vehicles/": "the vehicles own their names",
    "model/nlp/": "the NLP knows no vehicle: 'x' is CasADi's decision vector",
    "derivations/paper/": "the seed paper's claims are about its truck, system (1), by its names",
    "model/direct/bodies.py": "Pyomo component names of a disc centre's coordinates (<tag>_x, <tag>_y), not states",
}


def literal_names(source: str) -> list[tuple[int, str]]:
    """(line, value) of every string literal whose value is a vehicle name, on lines without the pragma."""
    lines = source.splitlines()
    hits = []
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type != tokenize.STRING:
            continue
        try:
            value = ast.literal_eval(tok.string)
        except (ValueError, SyntaxError):  # an f-string
            continue
        line = lines[tok.start[0] - 1]
        if value in NAMES and not (PRAGMA in line and line.split(PRAGMA, 1)[1].strip()):
            hits.append((tok.start[0], value))
    return hits


def project_sources() -> list[Path]:
    return sorted(p for d in ("model", "derivations") for p in (ROOT / d).rglob("*.py"))


def test_no_literal_vehicle_names_outside_the_vehicles():
    found = []
    for path in project_sources():
        rel = path.relative_to(ROOT).as_posix()
        if any(rel.startswith(prefix) for prefix in EXEMPT):
            continue
        found += [f"{rel}:{line}: {value!r}" for line, value in literal_names(path.read_text())]
    assert not found, "literal vehicle names (use vehicle.roles):\n" + "\n".join(found)


def test_the_scan_catches_a_literal_and_honours_only_a_pragma_with_a_reason():
    bad = 'def f(ocp):\n    return ocp.initial["theta"], ocp.bounds.get(\'u1\')\n'
    assert literal_names(bad) == [(2, "theta"), (2, "u1")]
    assert literal_names('a = {"phi": 1}  # names: a result key\n') == []
    assert literal_names('a = {"phi": 1}  # names:\n') == [(1, "phi")]
    assert literal_names('"""The x position."""\ns = "xy" + f"{s}_x"\n') == []  # no name, nor an f-string
    assert all((ROOT / prefix).exists() for prefix in EXEMPT)  # an exemption names what is there
