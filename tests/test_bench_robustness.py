"""The robustness suite's scenario generator (benchmarks/bench_robustness.py): seeded, and every file parses."""

import math
import tomllib

import pytest

from benchmarks.bench_robustness import generate, to_toml, write_scenarios
from model.problem.scenario import parse_scenario

COUNT = 60


def test_same_seed_same_files_and_a_prefix_does_not_depend_on_count(tmp_path):
    long = write_scenarios(COUNT, 3, tmp_path / "a")
    short = write_scenarios(10, 3, tmp_path / "b")
    assert [p.read_text() for _, p, _ in short] == [p.read_text() for _, p, _ in long[:10]]
    assert to_toml(generate(3, 7)) == to_toml(generate(3, 7))
    assert to_toml(generate(3, 7)) != to_toml(generate(4, 7))


@pytest.mark.parametrize("seed", [0, 1])
def test_every_generated_file_parses_within_the_ranges(seed):
    kinds = set()
    for index in range(COUNT):
        data = generate(seed, index)
        scenario = parse_scenario(tomllib.loads(to_toml(data)), default_name=data["name"])
        ocp = scenario.ocp
        assert 0.05 <= ocp.vehicle.parameters()["d"] <= 0.3
        assert 60 <= scenario.intervals <= 100
        assert 0.5 - 1e-3 <= ocp.straight_distance() <= 2.0 + 1e-3
        assert len(ocp.obstacles) <= 2
        for ob in ocp.obstacles:
            assert 0.05 <= ob.radius <= 0.4
            assert ob.clearance(0.0, 0.0) > 0 and ob.clearance(ocp.final["x"], ocp.final["y"]) > 0
        if data["problem"]["objective"] == "energy":
            ratio = ocp.final_time * ocp.max_speed() / ocp.straight_distance()
            assert 1.2 - 1e-2 <= ratio <= 3.0 + 1e-2
        kinds.add((data["problem"]["objective"], len(ocp.obstacles)))
    assert {k for k, _ in kinds} == {"energy", "time"} and {n for _, n in kinds} == {0, 1, 2}
    assert math.isfinite(ocp.final["theta"])
