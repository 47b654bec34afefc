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


SCENARIO_FILES = {Path(f).stem: f for f in sorted(glob(str(repo_path(config["scenarios"]))))}
SCENARIOS = sorted(SCENARIO_FILES)
MODEL_CODE = sorted(glob(str(ROOT / "model" / "*.py")))
DERIVATION_CODE = sorted(glob(str(ROOT / "derivations" / "*.py")))
FORMATS = list(config.get("figure_formats", ["pdf", "png"]))
PLOTTING = str(SCRIPTS / "plotting.py")


def scenario_file(wildcards) -> str:
    return SCENARIO_FILES[wildcards.scenario]


def chosen(key: str) -> list[str]:
    """Scenarios named by a config entry ("all" or a list), in config order, that exist."""
    value = config.get(key, "all")
    names = SCENARIOS if value == "all" else list(value)
    return [s for s in names if s in SCENARIO_FILES]


wildcard_constraints:
    scenario="|".join(re.escape(s) for s in SCENARIOS) or "NO_SCENARIO",
