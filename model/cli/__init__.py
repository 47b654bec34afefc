"""The ``roundabout`` command: solve a scenario file, simulate it in closed loop, print its
Pontryagin system, check it, plot a results folder, or export its roundabout (SUMO network,
CommonRoad map with a map scenario of the same manoeuvre).

Exit codes of ``roundabout solve``: 0 solved and validated (with ``--time-limit``, the best
validated answer when the budget stopped the search); 1 the solver ran and failed, or no start
validated within the time limit (DIR/summary.json says how); 2 invalid input (one line on stderr, nothing
written); 130 interrupted (Ctrl-C; one line, nothing written). ``roundabout simulate``
(docs/closed-loop-format.md): 0 the closed loop reached the goal (every run, with --runs);
1 it did not, a step failed or the open-loop solve failed, e.g. found nothing valid within
``--time-limit`` (the same budget, default and progress as ``solve``; the files are still written);
2 invalid input. A run's files appear in DIR together when it ends, with the umask's
permissions, replacing an earlier run's (``model.outputs``).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from pathlib import Path

from model.analysis.validation import failed_checks
from model.cli.progress import Progress
from model.errors import InputError
from model.outputs import RUN_FILES, run_folder, write_files

EPILOG = """examples:
  roundabout solve workflows/scenarios/s2-case1.toml --out results/s2-case1
  roundabout solve my.toml --out out/ --intervals 400 --verbose
  roundabout solve my.toml --out out/ --time-limit 60
  roundabout derive workflows/scenarios/s1.toml --latex
  roundabout simulate examples/closed-loop-truck.toml --out out/cl --controller tracking --runs 5
  roundabout traffic examples/traffic-roundabout.toml --out out/traffic --driver autopilot
  roundabout export-commonroad examples/roundabout-truck.toml --out maps/truck.xml   # and maps/truck.toml
  roundabout plot out/ --out figure.png

scenario files: see docs/scenario-format.md (TOML, SI units, radians);
                [disturbance] and [control]: docs/closed-loop-format.md.
exit codes: 0 solved and validated (also the best answer when --time-limit stopped the search),
            1 solver failed or no valid answer within --time-limit (summary.json says why),
            2 invalid input (one line on stderr, nothing written), 130 interrupted."""


CONTROLLERS = ("open-loop", "tracking", "mpc")
# The search's budget of one solve (each scenario of a batch): about 9 x the slowest default solve
# measured (34.5 s, benchmarks/road-suite.md; the pipeline scenarios take seconds), so a solve that
# would succeed is not cut on a loaded machine, while a hopeless one ends within five minutes.
DEFAULT_TIME_LIMIT = 300.0


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="roundabout",
        description="Optimal trajectories of truck-type vehicles around roundabouts.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    s = sub.add_parser("solve", help="solve a scenario; write DIR/summary.json and DIR/trajectory.csv")
    s.add_argument("scenario", type=Path, nargs="+", help="scenario file (TOML); several: a batch in one process")
    s.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder (a batch: DIR/<scenario name>/ for each)")  # fmt: skip
    s.add_argument("--intervals", type=int, metavar="N", help="override problem.intervals")
    s.add_argument("--verbose", action="store_true", help="show Ipopt's iteration log and the time of each phase")
    s.add_argument("--quiet", action="store_true", help="print no progress on stderr (results and errors only)")
    s.add_argument(
        "--search", choices=("quick", "default", "thorough"), default="default",
        help="starts tried: quick (one per pass direction), default, thorough (more, screened on a coarse grid)",
    )  # fmt: skip
    s.add_argument(
        "--ipopt", action="append", default=[], metavar="KEY=VALUE",
        help="an Ipopt option, e.g. mumps_pivot_order=5 or mu_strategy=adaptive (repeatable)",
    )  # fmt: skip
    s.add_argument(
        "--time-limit", metavar="SECONDS", default=None,
        help=f"the search's budget per scenario (default {DEFAULT_TIME_LIMIT:g}; 'inf': none). After it the best "
             "validated answer so far is written (summary.json: search.stopped_by_time_limit), "
             "or exit 1 with a diagnosis",
    )  # fmt: skip
    s.add_argument(
        "--map-grid", choices=("time", "arclength", "time+arclength"), default=None,
        help="a map route's nodes: equal steps of a free Tf (time), fixed to equal steps of the route frame's "
             "arclength with the time free per interval (arclength), or the time grid and, where it validates "
             "nothing, the arclength grid (time+arclength, the default; docs/map-corridor.md)",
    )  # fmt: skip
    d = sub.add_parser("derive", help="print the Pontryagin system of a scenario's problem")
    d.add_argument("scenario", type=Path, help="scenario file (TOML)")
    d.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    m = sub.add_parser(
        "simulate",
        help="solve, then run a controller against the disturbed plant; write DIR/closed_loop.csv and DIR/summary.json",
    )
    m.add_argument("scenario", type=Path, help="scenario file (TOML) with optional [disturbance] and [control]")
    m.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    m.add_argument("--controller", required=True, metavar="NAME", help="|".join(CONTROLLERS))
    m.add_argument("--runs", type=int, default=1, metavar="K", help="K runs with seeds seed, seed + 1, ... (runs.csv)")
    m.add_argument("--intervals", type=int, metavar="N", help="override problem.intervals of the open-loop solve")
    m.add_argument("--plant", metavar="MODEL",
                   help="kinematic|single-track: override plant.model (docs/closed-loop-format.md)")  # fmt: skip
    m.add_argument(
        "--time-limit", metavar="SECONDS", default=None,
        help=f"the open-loop solve's budget, as solve's (default {DEFAULT_TIME_LIMIT:g}; 'inf': none). After it the "
             "best validated answer so far is simulated, or exit 1 with a diagnosis and no simulation",
    )  # fmt: skip
    m.add_argument("--verbose", action="store_true", help="show Ipopt's iteration log of the open-loop solve")
    m.add_argument("--quiet", action="store_true", help="print no progress on stderr (results and errors only)")
    f = sub.add_parser("traffic", help="drive the truck through SUMO traffic; DIR/summary.json, traffic.csv")
    f.add_argument("scenario", type=Path, help="scenario file (TOML) with [traffic] (docs/traffic-format.md)")
    f.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    f.add_argument("--driver", default="autopilot", metavar="NAME",
                   help="autopilot|sumo|cooperative|reservation (default autopilot)")  # fmt: skip
    f.add_argument("--runs", type=int, default=1, metavar="K", help="K runs with seeds seed, seed + 1, ... (runs.csv)")
    x = sub.add_parser("export-sumo", help="write the scenario's SUMO network, routes and run.sumocfg into DIR")
    x.add_argument("scenario", type=Path, help="scenario file (TOML) with [traffic] (docs/traffic-format.md)")
    x.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (opens in sumo-gui)")
    e = sub.add_parser("export-commonroad", help="write the scenario's roundabout as a CommonRoad lanelet map, and a "
                       "map scenario of the same manoeuvre beside it")  # fmt: skip
    e.add_argument("scenario", type=Path, help="scenario file (TOML) with a [roundabout]")
    e.add_argument("--out", type=Path, required=True, metavar="FILE", help="the CommonRoad XML file to write")
    e.add_argument("--scenario-out", type=Path, metavar="FILE",
                   help="the map scenario (TOML) to write (default: FILE with the suffix .toml)")  # fmt: skip
    e.add_argument("--ring-lanes", type=int, default=1, metavar="K", help="lanes the ring is split into (default 1)")
    e.add_argument("--tolerance", type=float, default=1e-3, metavar="M",
                   help="m: the largest gap between a sampled circle and its chords (default 0.001)")  # fmt: skip
    c = sub.add_parser("check", help="validate a scenario file only, as solve would (exit 0 or 2)")
    c.add_argument("scenario", type=Path, help="scenario file (TOML)")
    g = sub.add_parser("plot", help="draw a results folder of solve or simulate as a PNG (or PDF, SVG)")
    g.add_argument("folder", type=Path, metavar="DIR", help="a folder written by roundabout solve or simulate")
    g.add_argument("--out", type=Path, metavar="FILE", help="figure file (default DIR/figure.png)")
    g.add_argument("--scenario", type=Path, metavar="FILE", help="the scenario file (default DIR/scenario.toml)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv``; the exit code (130 on Ctrl-C, after one line on stderr)."""
    try:
        return _main(argv)
    except KeyboardInterrupt:
        print("roundabout: interrupted; nothing was written", file=sys.stderr, flush=True)
        return 130


def _main(argv: list[str] | None) -> int:
    startup = process_seconds()
    args = parser().parse_args(argv)
    args.startup = startup
    if args.command == "plot":
        from model.cli.plot import plot_folder

        return plot_folder(args.folder, args.out, args.scenario)
    t0 = time.perf_counter()
    from model.problem.scenario import load_scenario

    batch = args.command == "solve" and len(args.scenario) > 1
    try:
        if args.command in ("solve", "simulate"):
            args.time_limit = checked_time_limit(args.time_limit)
        if batch:
            from model.search.batch import load_batch

            return _solve_batch(load_batch(args.scenario), args)
        if args.command == "solve":
            args.scenario = args.scenario[0]
        scenario = load_scenario(args.scenario)
        args.load_seconds = time.perf_counter() - t0
        if args.command in ("solve", "simulate", "traffic", "export-sumo"):
            check_output_folder(args.out)
        if args.command in ("traffic", "export-sumo"):
            sumo = check_traffic(args, scenario)
        if args.command == "export-commonroad":
            return _export_commonroad(scenario, args)
        check_grid(getattr(args, "intervals", None), scenario)
        if args.command == "simulate":
            check_simulate(args, scenario)
        if args.command not in ("check", "solve"):  # a map scenario solves; simulate and derive do not yet
            scenario.ocp.check_solvable()
        options = checked_ipopt_options(getattr(args, "ipopt", []))
    except InputError as err:
        print(f"roundabout: invalid input: {err}", file=sys.stderr)
        return 2
    if args.command == "check":
        if scenario.ocp.map_route is not None:
            print(map_lines(scenario.ocp.map_route))
        print(f"{args.scenario}: ok")
        if scenario.ocp.road is not None:
            print(bounds_line(scenario.ocp))
        return 0
    if args.command == "derive":
        return _derive(scenario, args.latex)
    if args.command == "simulate":
        return _simulate(scenario, args)
    if args.command == "traffic":
        return _traffic(scenario, args, sumo)
    if args.command == "export-sumo":
        return _export_sumo(scenario, args, sumo)
    return _solve(scenario, args, options)


def bounds_line(ocp) -> str:
    """One line of the road bounds (``model.analysis.bounds``, no solver): verdict, margins, time bound, proofs."""
    from model.analysis.bounds import geometric_bounds

    b = geometric_bounds(ocp)
    parts = [f"bounds: {b['verdict']}"]
    if b["swept_annulus"]:
        parts.append(f"steady swept annulus at full lock {b['swept_annulus']['outer']:.3g} / "
                     f"{b['swept_annulus']['inner']:.3g} m")  # fmt: skip
    if b["time_lower_bound_s"] is not None:
        parts.append(f"time >= {b['time_lower_bound_s']:.4g} s")
    parts += [p["message"] for p in b["proofs"]] + b["tight"]
    return "; ".join(parts)


# Measured peak memory of a solve (truck, 4 states + 2 controls): about 165 MB plus 70 kB per interval.
BASE_BYTES, BYTES_PER_INTERVAL_AND_VARIABLE = 165e6, 70e3 / 6


def map_lines(route) -> str:
    """What ``check`` says of a route through a lanelet map: its lanelets, length, corridor and poses."""
    x0, y0, a0 = route.start()
    x1, y1, a1 = route.goal()
    return "\n".join([
        f"map: {route.map.path} ({len(route.map.ids)} lanelets)",
        f"route lanelets: {' '.join(map(str, route.lanelets))}",
        f"route length: {route.goal_s - route.start_offset:.2f} m from the start to the goal "
        f"(centre line {route.line.length:.2f} m)",
        f"corridor: {len(route.corridor_lanelets)} lanelets ({' '.join(map(str, route.corridor_lanelets))}), "
        f"area {route.lanes.area:.1f} m^2" + (f"; with the apron lanelets {route.with_apron.area:.1f} m^2"
                                               if route.apron_lanelets else ""),
        f"start: x {x0:.3f} m, y {y0:.3f} m, heading {a0:.4f} rad; goal: x {x1:.3f} m, y {y1:.3f} m, "
        f"heading {a1:.4f} rad",
    ])  # fmt: skip


def check_output_folder(out: Path) -> None:
    """``--out`` must be a folder or not exist yet, under a folder that can be written to."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a folder")
    parent = next((p for p in (out, *out.parents) if p.exists()), Path("."))
    if not os.access(parent, os.W_OK):
        raise InputError("--out", f"cannot write under {parent}")


def check_grid(override: int | None, scenario) -> None:
    """``--intervals`` (if given) >= 1, and the grid's memory within what this machine has."""
    if override is not None and override < 1:
        raise InputError("--intervals", f"must be >= 1, got {override}")
    check_size(override or scenario.intervals, scenario.ocp, "--intervals" if override else None)


def check_size(intervals: int, ocp, key: str | None) -> None:
    """Refuse grids whose estimated memory exceeds what this machine has available."""
    per_node = len(ocp.vehicle.states) + len(ocp.vehicle.controls)
    need = BASE_BYTES + BYTES_PER_INTERVAL_AND_VARIABLE * per_node * intervals
    have = available_memory()
    if have is not None and need > have:
        raise InputError(
            key or "problem.intervals",
            f"N = {intervals} needs about {need / 2**30:.1f} GiB, more than the {have / 2**30:.1f} GiB available",
        )


def available_memory() -> float | None:
    """MemAvailable from /proc/meminfo in bytes (None where it cannot be read)."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def ipopt_options(pairs: list[str]) -> dict:
    """``KEY=VALUE`` strings as Ipopt options (numbers where they parse as numbers)."""
    options = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key.strip() or not text.strip():
            raise InputError("--ipopt", f"expected KEY=VALUE, got {pair!r}")
        value: int | float | str = text.strip()
        for kind in (int, float):
            try:
                value = kind(text)
                break
            except ValueError:
                continue
        options[key.strip()] = value
    return options


def checked_ipopt_options(pairs: list[str]) -> dict:
    """``--ipopt KEY=VALUE`` options, each checked by Ipopt itself (InputError for the first it rejects)."""
    options = ipopt_options(pairs)
    if options:
        from model.nlp.ipopt import IpoptOptionError, check_options

        try:
            check_options(options)
        except IpoptOptionError as err:
            raise InputError("--ipopt", str(err)) from None
    return options


def checked_time_limit(text: str | None) -> float | None:
    """``--time-limit SECONDS``: a number > 0 (DEFAULT_TIME_LIMIT if not given; 'inf': None, no limit)."""
    if text is None:
        return DEFAULT_TIME_LIMIT
    try:
        seconds = float(text)
    except ValueError:
        seconds = float("nan")
    if not seconds > 0:
        raise InputError("--time-limit", f"must be a number of seconds > 0 (or 'inf'), got {text!r}")
    return None if seconds == float("inf") else seconds


def check_simulate(args, scenario) -> None:
    """The simulate command's own inputs: the controller's name (mpc only once it exists), --runs, the sample time."""
    if args.controller not in CONTROLLERS:
        raise InputError("--controller", f"must be one of {list(CONTROLLERS)}, got {args.controller!r}")
    if args.runs < 1:
        raise InputError("--runs", f"must be >= 1, got {args.runs}")
    if args.plant is not None and args.plant != scenario.plant.model:
        from model.problem.closed_loop import PLANT_MODELS, PlantSettings, check_plant

        if args.plant not in PLANT_MODELS:
            raise InputError("--plant", f"must be one of {list(PLANT_MODELS)}, got {args.plant!r}")
        scenario.plant = PlantSettings(model=args.plant)  # the scenario's [plant] numbers are another model's
        check_plant(scenario.plant, scenario.ocp.vehicle, scenario.disturbance, key="--plant")
    tf, h = scenario.ocp.final_time, scenario.control.sample_time
    if not scenario.ocp.cost.free_final_time and h > tf:
        raise InputError("control.sample_time", f"{h:g} s exceeds problem.final_time = {tf:g} s")
    if args.controller == "mpc":
        try:
            from model.simulation.mpc import MPC  # noqa: F401
        except ImportError as err:
            if err.name != "model.simulation.mpc":
                raise
            raise InputError("--controller", "mpc controller not available yet") from None


def check_traffic(args, scenario):
    """The traffic command's inputs: a [traffic] table, the driver, --runs, SUMO installed; returns SUMO."""
    from model.traffic.run import DRIVERS
    from model.traffic.sumo import find_sumo

    if scenario.traffic is None:
        raise InputError("traffic", "missing: roundabout traffic needs a [traffic] table")
    if args.command == "export-sumo":
        return find_sumo()
    if args.driver not in DRIVERS:
        raise InputError("--driver", f"must be one of {list(DRIVERS)}, got {args.driver!r}")
    if args.runs < 1:
        raise InputError("--runs", f"must be >= 1, got {args.runs}")
    return find_sumo()


def _export_sumo(scenario, args, sumo) -> int:
    from model.traffic.cosim import write_sumo_files

    with run_folder(args.out) as stage:
        write_sumo_files(scenario, stage, sumo, scenario.traffic.seed)
    print(f"wrote {args.out}: net.net.xml, routes.rou.xml, run.sumocfg (sumo-gui -c {args.out / 'run.sumocfg'})")
    return 0


def export_paths(args, scenario) -> tuple[Path, Path]:
    """The map and map-scenario files of ``export-commonroad``: a roundabout scenario, two distinct files."""
    if scenario.ocp.road is None:
        raise InputError("roundabout", "missing: export-commonroad writes a scenario's parametric [roundabout] "
                         "as a map, and this scenario has none")  # fmt: skip
    xml = args.out
    toml = args.scenario_out or xml.with_suffix(".toml")
    for key, path in (("--out", xml), ("--scenario-out", toml)):
        if path.is_dir():
            raise InputError(key, f"{path} is a folder; give a file")
        parent = next((p for p in path.absolute().parents if p.exists()), Path("."))
        if not os.access(parent, os.W_OK):
            raise InputError(key, f"cannot write under {parent}")
    if xml.absolute() == toml.absolute() or xml.absolute() == Path(args.scenario).absolute():
        raise InputError("--out", f"{xml} would overwrite the map scenario or the scenario itself")
    if toml.absolute() == Path(args.scenario).absolute():
        raise InputError("--scenario-out", f"{toml} would overwrite the scenario itself")
    return xml, toml


def _export_commonroad(scenario, args) -> int:
    """``export-commonroad``: the map and its scenario, both checked by reading them back before either is written."""
    import tomllib

    from model.outputs import write_atomically
    from model.problem.map_export import export_commonroad

    xml, toml = export_paths(args, scenario)
    data = tomllib.loads(Path(args.scenario).read_bytes().decode("utf-8"))
    map_file = os.path.relpath(xml.absolute(), toml.absolute().parent)
    done = export_commonroad(data, scenario.ocp.road, map_file, args.ring_lanes, args.tolerance)
    existed = xml.exists()
    write_atomically(xml, done.xml)
    try:
        write_atomically(toml, done.toml)
    except BaseException:
        if not existed:
            xml.unlink(missing_ok=True)
        raise
    if data.get("moving_obstacles"):
        print("roundabout: note: the map scenario keeps [[moving_obstacles]], which the map search does not "
              "handle yet (docs/map-format.md)", file=sys.stderr)  # fmt: skip
    worst = max(done.mismatch.values(), key=lambda m: m["fraction"])
    route = done.route
    print(f"wrote {xml} ({len(done.network.lanelets)} lanelets; route {' '.join(map(str, route.lanelets))}) and "
          f"{toml} (roundabout solve {toml}); the corridor differs from the parametric one by "
          f"{worst['difference']:.4f} m^2 ({100 * worst['fraction']:.4f} % of {worst['area']:.1f} m^2); start "
          f"{1000 * done.pose_error['start']['distance']:.2f} mm, goal "
          f"{1000 * done.pose_error['goal']['distance']:.2f} mm from the parametric poses")  # fmt: skip
    return 0


def _traffic(scenario, args, sumo) -> int:
    from model.traffic.run import run_traffic

    with run_folder(args.out) as stage:
        summary = run_traffic(scenario, sumo, stage, args.driver, args.runs)
    print(
        f"traffic {args.driver}: arrived={summary['arrived']} collisions={summary['collisions']} "
        f"min_distance={_fmt(summary['min_distance'])} delay={_fmt(summary['delay'])}; wrote {args.out}"
    )
    return 0 if summary["ok"] else 1


def open_loop_solve(scenario, args, options: dict, progress: Progress):
    """The scenario's optimum by the default solve (as ``roundabout solve``), with its phase timings."""
    intervals = args.intervals or scenario.intervals
    if not progress.quiet:
        print(f"{scenario.ocp.name}: solving with N = {intervals} ...", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    from model.problem.methods import default_solve, load_method

    method = load_method(default_solve(scenario.ocp))
    from model.nlp.imports import settled_heap

    t1 = time.perf_counter()
    with settled_heap():  # the imports' objects out of the solve's collections (model/nlp/imports.py)
        sol = scenario.ocp.solve(
            intervals=intervals,
            method=method,
            verbose=args.verbose,
            options=options,
            progress=progress,
            **({"search": args.search} if getattr(args, "search", "default") != "default" else {}),
            **({"time_limit": args.time_limit} if getattr(args, "time_limit", None) is not None else {}),
            **({"grid": args.map_grid} if getattr(args, "map_grid", None) and scenario.ocp.map_route is not None
               else {}),
        )  # fmt: skip
    return sol, t1 - t0


def solve_line(scenario, sol) -> str:
    return (
        f"{scenario.ocp.name}: {sol.status}, objective {sol.objective:.10g}, Tf {sol.final_time:.6g} s, "
        f"energy {sol.energy:.6g}, {sol.iterations} iterations, {sol.solve_seconds:.2f} s"
    )


def failure_reason(sol) -> str:
    if (sol.diagnosis or {}).get("kind") in ("time limit", "map corridor"):
        return sol.diagnosis["message"]
    failed = list(failed_checks(sol.validation))
    return sol.status if sol.status != "optimal" else "validation failed: " + ", ".join(failed)


def _solve_batch(scenarios: list, args) -> int:
    """Solve each scenario into DIR/<name>/ in this one process (the imports are paid once)."""
    check_output_folder(args.out)
    for scenario in scenarios:
        check_grid(args.intervals, scenario)
    options = checked_ipopt_options(args.ipopt)
    out, codes = args.out, []
    try:
        for i, scenario in enumerate(scenarios, 1):
            if not args.quiet:
                print(f"[{i} of {len(scenarios)}] {scenario.path}", file=sys.stderr, flush=True)
            args.out, args.load_seconds = out / scenario.ocp.name, 0.0
            codes.append(_solve(scenario, args, options))
    except KeyboardInterrupt:
        print(f"roundabout: interrupted; {len(codes)} of {len(scenarios)} scenarios were written, the one being "
              "solved was not", file=sys.stderr, flush=True)  # fmt: skip
        return 130
    solved = codes.count(0)
    print(f"batch: {solved} of {len(codes)} solved and validated; one folder per scenario in {out}/")
    return 0 if solved == len(codes) else 1


def time_limit_note(sol) -> str:
    """A line for an answer the time limit cut the search short on ('' otherwise)."""
    search = getattr(sol, "search", None) or {}
    if not search.get("stopped_by_time_limit"):
        return ""
    return (f"\nnote: the time limit of {search['time_limit']:g} s stopped the search ({search['starts_skipped']} "
            "starts skipped): this is the best validated answer found by then")  # fmt: skip


def loop_note(sol) -> str:
    """A line for a map answer that goes round the ring more than the route's direct path ('' otherwise)."""
    loops = sol.ocp.map_route.loops if sol.ocp.map_route is not None else 0
    if not loops:
        return ""
    return (f"\nnote: nothing validated on the route's direct path; this answer goes {loops} more time(s) round "
            "the ring (route_loops in summary.json)")  # fmt: skip


def wrote_line(out: Path) -> str:
    """The success line's second half: where the files are."""
    names = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file() and p.name in RUN_FILES)
    return f"results in {out}/: {', '.join(names)} (draw them: roundabout plot {out})"


def _solve(scenario, args, options: dict) -> int:
    with Progress(quiet=args.quiet) as progress:
        sol, import_seconds = open_loop_solve(scenario, args, options, progress)
        from model.search.batch import run_files  # after the solve: its imports are the solver's (timed there)

        progress.activity = "writing the results"
        t2 = time.perf_counter()
        with run_folder(args.out) as stage:
            write_files(stage, {**sol.files(), **run_files(scenario)})
    if args.verbose:
        phases = {"scenario (sympy, parse)": args.load_seconds, "solver imports": import_seconds,
                  **sol.timings.get("all_starts", {}), "write": time.perf_counter() - t2}  # fmt: skip
        print(phase_report(phases, args.startup), file=sys.stderr)
    line = solve_line(scenario, sol)
    if sol.ok:
        print(f"{line}\n{wrote_line(args.out)}" + time_limit_note(sol) + loop_note(sol))
        return 0
    print(f"{line}\nroundabout: FAILED ({failure_reason(sol)}); see {args.out / 'summary.json'}", file=sys.stderr)
    return 1


def _simulate(scenario, args) -> int:
    """Solve the open-loop optimum, then run the controller (K times with --runs); write the results."""
    with Progress(quiet=args.quiet) as progress:
        sol, _ = open_loop_solve(scenario, args, {}, progress)
        from model.search.batch import run_files

        if not sol.ok:
            from model.direct.solution import json_text

            reason = failure_reason(sol)
            summary = {"controller": args.controller, "status": f"the open-loop solve failed ({reason})",
                       "reached_goal": False, "optimum": "optimum/summary.json"}  # fmt: skip
            with run_folder(args.out) as stage:
                write_files(stage / "optimum", sol.files())
                write_files(stage, {"summary.json": json_text(summary), **run_files(scenario)})
            print(f"{solve_line(scenario, sol)}\nroundabout: FAILED ({reason}); see {args.out / 'summary.json'}",
                  file=sys.stderr)  # fmt: skip
            return 1
        if not args.quiet:
            print(solve_line(scenario, sol) + time_limit_note(sol), file=sys.stderr)
        from model.simulation.loop import make_controller, simulate_runs

        progress.activity = f"simulating the closed loop ({args.controller})"
        factory = make_controller(args.controller, sol, scenario.control, scenario.disturbance)
        result = simulate_runs(scenario, sol, factory, scenario.disturbance, scenario.control, runs=args.runs)
        with run_folder(args.out) as stage:
            write_files(stage / "optimum", sol.files())
            write_files(stage, {**result.files(), **run_files(scenario)})
    s = result.summary
    line = (
        f"{scenario.ocp.name}: {s['controller']}, {s['steps']} steps, final position error "
        f"{_fmt(s['final_position_error'])} m, heading error {_fmt(s['final_heading_error'])} rad, energy "
        f"{s['energy']:.6g} (optimum {sol.energy:.6g}), realtime factor {s['realtime_factor']:.3g}"
        + (f", {args.runs} runs, goal reached in {s['reached_goal_rate']:.0%}" if args.runs > 1 else "")
    )
    if s["reached_goal"]:
        print(f"{line}\n{wrote_line(args.out)}")
        return 0
    print(f"{line}\nroundabout: goal not reached within the tolerance; see {args.out / 'summary.json'}",
          file=sys.stderr)  # fmt: skip
    return 1


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.4g}"


def process_seconds() -> float | None:
    """Seconds since this process started (Linux /proc; None elsewhere)."""
    try:
        start_ticks = float(Path("/proc/self/stat").read_text().rpartition(")")[2].split()[19])
        uptime = float(Path("/proc/uptime").read_text().split()[0])
        return uptime - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def phase_report(phases: dict[str, float], startup: float | None = None) -> str:
    """One line per phase of the process, from its start (``startup``: interpreter and imports) to the write."""
    lines = ["phases (s):"]
    if startup is not None:
        lines.append(f"  {'python start + cli imports':28s} {startup:8.3f}")
    lines += [f"  {name.replace('_', ' '):28s} {sec:8.3f}" for name, sec in phases.items()]
    total = process_seconds()
    if total is not None:
        lines.append(f"  {'process so far':28s} {total:8.3f}")
    return "\n".join(lines)


def _derive(scenario, latex: bool) -> int:
    from derivations.pmp import render_pmp

    print(render_pmp(scenario.ocp, fmt="latex" if latex else "text"))
    return 0


def run() -> None:
    """The console script: ``main``, then leave without tearing the interpreter down.

    Everything is written and flushed by then; freeing Pyomo's and CasADi's objects and
    modules one by one at exit would only add about 0.2 s to every solve process. SIGINT
    interrupts even where the parent shell ignores it (a background job sent ``kill -INT``).
    """
    signal.signal(signal.SIGINT, signal.default_int_handler)
    leave(main())


def leave(code: int) -> None:
    """Flush stdout and stderr and end the process with ``code`` without tearing the interpreter down (``run``;
    the study scripts' cells: freeing a solve's Pyomo models and every module one by one costs about 1.2 s)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
