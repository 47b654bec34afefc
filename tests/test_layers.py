"""The layers of docs/architecture.md, checked on the import graph read from the source."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tools.import_graph import ROOT, imports_of, module_file, module_name, project_modules

# Each layer and the layers it may import (its own always allowed). Order: bottom to top.
LAYERS = {
    "model.errors": set(),
    "model.outputs": set(),
    "model.vehicles": {"model.errors"},
    "model.scene": {"model.errors", "model.vehicles"},  # another vehicle is placed as a body is
    "model.problem": {"model.errors", "model.vehicles", "model.scene"},
    "derivations": {"model.errors", "model.vehicles", "model.scene", "model.problem"},
    "model.nlp": set(),
    "model.analysis": {"model.errors", "model.vehicles", "model.scene", "model.problem", "derivations"},
}
LAYERS["model.direct"] = {*LAYERS["model.analysis"], "model.analysis", "model.nlp", "model.outputs"}
LAYERS["model.indirect"] = LAYERS["model.analysis"]
LAYERS["model.search"] = {*LAYERS["model.direct"], "model.direct"}
LAYERS["model.plotting"] = {*LAYERS["model.analysis"], "model.analysis", "model.outputs"}
LAYERS["derivations.paper"] = {*LAYERS["derivations"], "derivations"}
LAYERS["model.simulation"] = {*LAYERS["model.search"], "model.search"}
LAYERS["model.studies"] = {*LAYERS["model.simulation"], "model.simulation", "model.indirect"}  # plant_gap drives plans
LAYERS["model.traffic"] = {*LAYERS["model.simulation"], "model.simulation", "model.outputs"}
LAYERS["model.cli"] = {*LAYERS["model.traffic"], "model.traffic", "model.plotting", "model.outputs"}
LAYERS["model"] = set(LAYERS)  # the package's lazy public API may name any layer


def layer_of(module: str) -> str:
    """The longest layer name that is ``module`` or a prefix of it."""
    return max((name for name in LAYERS if module == name or module.startswith(name + ".")), key=len)


def test_every_module_belongs_to_a_layer():
    for path in project_modules():
        assert layer_of(module_name(path)), path


@pytest.mark.parametrize("path", project_modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_module_imports_a_layer_above_its_own(path):
    own = layer_of(module_name(path))
    allowed = LAYERS[own] | {own}
    wrong = [m for m in imports_of(path) if layer_of(m) not in allowed]
    assert not wrong, f"{module_name(path)} ({own}) imports {wrong}"


def test_the_check_catches_an_upward_import(tmp_path, monkeypatch):
    """The rule is not vacuous: a problem-layer module that imports the solver is flagged."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from model.direct.solve import finish\n")
    found = imports_of(bad)
    assert "model.direct.solve" in found
    assert layer_of("model.direct.solve") not in LAYERS["model.problem"]


def test_type_checking_imports_are_annotations_only(tmp_path):
    f = tmp_path / "typed.py"
    f.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from model.direct import Solution\n")
    assert imports_of(f) == ()


def test_checking_a_scenario_loads_no_solver():
    """`roundabout check` and the problem layer import neither Pyomo, CasADi, pandas nor matplotlib."""
    code = (
        "import sys; from model.cli import main; main(['check', 'examples/format-example.toml']);"
        "print(sorted(m for m in ('pyomo', 'casadi', 'pandas', 'matplotlib', 'scipy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_a_solve_loads_no_pandas_matplotlib_or_scipy_stats(tmp_path):
    """The solve path imports what a solve needs only (pandas comes with ``Solution.trajectory``)."""
    code = (
        "import sys; from model.cli import main;"
        f"main(['solve', 'examples/format-example.toml', '--out', {str(tmp_path)!r}, '--intervals', '20']);"
        "print(sorted(m for m in ('pandas', 'matplotlib', 'scipy.stats') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert (tmp_path / "trajectory.csv").read_text().startswith("t,x,y,theta,phi,u1,u2,p_x")


def private_uses(path, own: str | None = None) -> list[str]:
    """``from x import _y`` and ``m._y`` (m a module imported from another layer) in ``path`` (of layer ``own``)."""
    import ast

    own = own or layer_of(module_name(path))
    tree = ast.parse(path.read_text())
    found, aliases = [], {}
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.ImportFrom)
            and node.module
            and node.level == 0
            and node.module.split(".")[0] in ("model", "derivations")
        ):
            for a in node.names:
                full = f"{node.module}.{a.name}"
                if layer_of(node.module) != own and a.name.startswith("_") and not a.name.startswith("__"):
                    found.append(f"from {node.module} import {a.name}")
                if module_file(full):
                    aliases[a.asname or a.name] = full
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in ("model", "derivations") and a.asname:
                    aliases[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases:
            target = aliases[node.value.id]
            if layer_of(target) != own and node.attr.startswith("_") and not node.attr.startswith("__"):
                found.append(f"{target}.{node.attr}")
    return found


@pytest.mark.parametrize("path", project_modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_name_is_used_across_layers(path):
    assert not private_uses(path), private_uses(path)


def test_the_private_name_check_catches_one(tmp_path):
    bad = tmp_path / "probe.py"
    bad.write_text("from model.direct.solution import _hidden\nimport model.nlp.ipopt as ip\nip._x\n")
    assert private_uses(bad, own="model.simulation") == [
        "from model.direct.solution import _hidden",
        "model.nlp.ipopt._x",
    ]
