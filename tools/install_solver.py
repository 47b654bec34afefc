"""Install cyipopt built against the Ipopt that the casadi wheel ships (pip only).

Why: cyipopt-wheels bundles Ipopt 3.14.11 whose linear solves ran ~3x slower here than
the Ipopt 3.14.19 (MUMPS + METIS) inside the casadi wheel. casadi ships its headers and
libipopt.so but a pkg-config file with a wrong prefix, so this script writes a correct
one, builds cyipopt from its sdist against it with the library folder on the runtime
path, and checks the result. Both packages provide the module ``cyipopt``: an installed
cyipopt-wheels is removed first. If the build fails, cyipopt-wheels is installed instead
(slower, same results) and the script says so.

Usage: python tools/install_solver.py [--wheels]   (idempotent; fast when up to date)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

CASADI = "casadi>=3.6,<4"
CYIPOPT = "cyipopt>=1.5"
PC_TEMPLATE = """prefix={prefix}
libdir=${{prefix}}
includedir=${{prefix}}/include/coin-or

Name: Ipopt
Description: Ipopt as bundled in the casadi wheel
Version: {version}
Cflags: -I${{includedir}}
Libs: -L${{libdir}} -lipopt
"""


def pip(*args: str, env: dict | None = None) -> int:
    cmd = [sys.executable, "-m", "pip", *args]
    print("+", " ".join(cmd), flush=True)
    return subprocess.call(cmd, env=env)


def probe(code: str) -> str | None:
    """Run ``code`` in a fresh interpreter; its stdout, or None if it failed."""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    return res.stdout.strip() if res.returncode == 0 else None


def casadi_dir() -> Path:
    where = probe("import casadi, os; print(os.path.dirname(casadi.__file__))")
    if where is None:
        if pip("install", "-q", CASADI) != 0:
            sys.exit("install_solver: could not install casadi")
        where = probe("import casadi, os; print(os.path.dirname(casadi.__file__))")
    return Path(where)


def current_ipopt() -> str | None:
    """'<version> <library path>' of the Ipopt the installed cyipopt loads, or None."""
    return probe(
        "import cyipopt, cyipopt.ipopt_wrapper as w, re;"
        "maps = open('/proc/self/maps').read();"
        "lib = sorted(set(re.findall(r'(/\\S*libipopt\\S*)', maps)));"
        "print('.'.join(map(str, cyipopt.IPOPT_VERSION)), lib[0] if lib else '?')"
    )


def build_against_casadi(prefix: Path) -> bool:
    version = "3.14"
    header = prefix / "include" / "coin-or" / "IpoptConfig.h"
    if header.exists():
        for line in header.read_text().splitlines():
            if "IPOPT_VERSION " in line and '"' in line:
                version = line.split('"')[1]
    with tempfile.TemporaryDirectory() as pc:
        Path(pc, "ipopt.pc").write_text(PC_TEMPLATE.format(prefix=prefix, version=version))
        env = dict(os.environ, PKG_CONFIG_PATH=pc, LDFLAGS=f"-Wl,-rpath,{prefix}")
        return pip("install", "--no-cache-dir", "--no-binary", "cyipopt", "--force-reinstall", "--no-deps", CYIPOPT,
                   env=env) == 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--wheels", action="store_true", help="use cyipopt-wheels (bundled Ipopt 3.14.11) instead")
    args = ap.parse_args()
    prefix = casadi_dir()
    have = current_ipopt()
    if not args.wheels and have and str(prefix) in have:
        print(f"install_solver: cyipopt already uses casadi's Ipopt ({have})")
        return 0
    installed = probe("import importlib.metadata as m; print(m.version('cyipopt-wheels'))")
    if installed is not None:
        if args.wheels and have:
            print(f"install_solver: cyipopt-wheels {installed} already installed ({have})")
            return 0
        pip("uninstall", "-y", "cyipopt-wheels")
    if not args.wheels and build_against_casadi(prefix) and current_ipopt():
        print(f"install_solver: cyipopt built against casadi's Ipopt: {current_ipopt()}")
        return 0
    if not args.wheels:
        print("install_solver: building against casadi's Ipopt failed; falling back to cyipopt-wheels", flush=True)
        pip("uninstall", "-y", "cyipopt")
    if pip("install", "cyipopt-wheels>=1.7.0.dev0") != 0 or not current_ipopt():
        sys.exit("install_solver: no working cyipopt could be installed")
    print(f"install_solver: using cyipopt-wheels: {current_ipopt()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
