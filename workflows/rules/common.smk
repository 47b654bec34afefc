"""Names shared by every rule file: paths, the scenario list, code that outputs depend on."""

import re
import shutil
import sys
from glob import glob
from pathlib import Path

ROOT = Path(workflow.basedir)
SCRIPTS = ROOT / "workflows" / "scripts"
PYTHON = sys.executable
OPTIONAL_TARGETS = []


def repo_path(path: str) -> Path:
    """A config path: absolute as given, else relative to the repository root."""
    p = Path(path)
    return p if p.is_absolute() else ROOT / p


_globs = [config["scenarios"]] if isinstance(config["scenarios"], str) else list(config["scenarios"])
SCENARIO_FILES = {Path(f).stem: f for g in _globs for f in sorted(glob(str(repo_path(g))))}
SCENARIOS = sorted(SCENARIO_FILES)
PAPER_SCENARIOS = [s for s in config.get("paper_keys", {}) if s in SCENARIO_FILES]
FORMATS = list(config.get("figure_formats", ["png"]))

sys.path.insert(0, str(ROOT / "tools"))
from import_graph import closure  # noqa: E402  (a rule depends on the code its script can import)

# A solve runs the CLI and the method OCP.solve names (model.problem.methods.DEFAULT_SOLVE).
SOLVE_CODE = closure("model.cli", "model.search.multistart")
DERIVATION_CODE = closure("derivations.paper.report")


def scenario_file(wildcards) -> str:
    return SCENARIO_FILES[wildcards.scenario]


def chosen(key: str) -> list[str]:
    """Scenarios named by a config entry ("all", "paper" or a list), in config order, that exist."""
    value = config.get(key, "all")
    names = {"all": SCENARIOS, "paper": PAPER_SCENARIOS}[value] if isinstance(value, str) else list(value)
    return [s for s in names if s in SCENARIO_FILES]


wildcard_constraints:
    scenario="|".join(re.escape(s) for s in SCENARIOS) or "NO_SCENARIO",
