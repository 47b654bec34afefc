"""The engine's numeric form: one H and psi, the same with and without the on-disk cache."""

from __future__ import annotations

import numpy as np
import pytest

import derivations.functions as functions
import derivations.pmp
from model import load_scenario


@pytest.fixture
def ocp():
    return load_scenario("examples/format-example.toml").ocp


@pytest.fixture
def nodes(ocp):
    rng = np.random.default_rng(3)
    names = [*ocp.vehicle.states, *ocp.vehicle.controls, *(f"p_{s}" for s in ocp.vehicle.states), "mu"]
    return {n: rng.normal(size=7) for n in names}


def fresh(monkeypatch, cache):
    monkeypatch.setenv("ROUNDABOUT_CACHE", str(cache))
    monkeypatch.setattr(functions, "_MEMORY", {})


def test_hamiltonian_matches_the_engine_expression(ocp, nodes):
    """H from the generated function equals the engine's symbolic H evaluated by SymPy."""
    pmp = derivations.pmp.derive(ocp)
    values = {s.name: v for s, v in pmp.parameters.items()}
    k = 4
    subs = {s: nodes[s.name][k] if s.name in nodes else values[s.name] for s in pmp.hamiltonian.free_symbols}
    expected = float(pmp.hamiltonian.subs(subs))
    got = functions.pmp_functions(ocp).evaluate(nodes)["H"][k]
    assert got == pytest.approx(expected, rel=1e-12)


def test_cache_gives_identical_values_and_skips_the_derivation(ocp, nodes, tmp_path, monkeypatch):
    fresh(monkeypatch, "off")
    reference = functions.pmp_functions(ocp).evaluate(nodes)
    fresh(monkeypatch, tmp_path)
    functions.pmp_functions(ocp)  # derives and writes the cache
    assert len(list(tmp_path.glob("pmp-*.py"))) == 1
    fresh(monkeypatch, tmp_path)  # a new process, as far as the cache can tell

    def no_derivation(*args, **kwargs):
        raise AssertionError("derived although the structure is cached")

    monkeypatch.setattr(derivations.pmp, "derive", no_derivation)
    cached = functions.pmp_functions(ocp).evaluate(nodes)
    for key, value in reference.items():
        np.testing.assert_array_equal(cached[key], value)


def test_a_damaged_cache_entry_is_derived_again(ocp, nodes, tmp_path, monkeypatch):
    fresh(monkeypatch, tmp_path)
    functions.pmp_functions(ocp)
    (entry,) = tmp_path.glob("pmp-*.py")
    entry.write_text("def evaluate(:\n")
    fresh(monkeypatch, tmp_path)
    values = functions.pmp_functions(ocp).evaluate(nodes)
    assert np.all(np.isfinite(values["H"]))
    assert "def evaluate(a0" in entry.read_text()


def test_the_key_follows_the_structure_not_the_numbers(ocp):
    import dataclasses

    from model import Circle, Truck

    moved = dataclasses.replace(ocp, obstacles=[Circle((0.4, 0.1), 0.3)], vehicle=Truck(wheelbase=0.2))
    two = dataclasses.replace(ocp, obstacles=[*ocp.obstacles, Circle((2.0, 2.0), 0.1)])
    assert functions.structure_key(moved) == functions.structure_key(ocp)
    assert functions.structure_key(two) != functions.structure_key(ocp)
