"""Install cyipopt built against the Ipopt that the casadi wheel ships (pip only).

Why: cyipopt-wheels bundles Ipopt 3.14.11 whose linear solves ran ~3x slower here than
the Ipopt 3.14.19 (MUMPS + METIS) inside the casadi wheel. casadi ships its headers and
libipopt.so but a pkg-config file with a wrong prefix, so this script writes a correct
one, builds cyipopt from its sdist against it with the library folder on the runtime
path, and checks the result. Both packages provide the module ``cyipopt``: an installed
cyipopt-wheels is removed first. If the build fails, cyipopt-wheels is installed instead
(slower, same results) and the script says so.

The sdist gets one patch before the build (``PATCH``): cyipopt 1.7.0 copies the Jacobian
and Hessian values it gets from Python into Ipopt's arrays through untyped Python
indexing, ~70 ns per nonzero; typing the two arrays makes those loops C loops (N = 1600:
~0.25 s of a 2.6 s solve). If the lines are not found (another cyipopt version), the
sdist is built as it is.

The same step installs the real roundabout maps (docs/map-format.md): the CommonRoad lanelet
files that the BSD-licensed ``commonroad-dataset-converter`` ships under ``crdata/datasets/``.
Only its data is read; its own requirements (numpy < 2 among them) would break this environment,
so it is installed with ``--no-deps`` (``MAP_DATA``). pip then reports those requirements as
unmet whenever it installs something else ("pip's dependency resolver does not currently take
into account ..."); that report is expected and harmless here (nothing imports the package).

Usage: python tools/install_solver.py [--wheels]   (idempotent; fast when up to date)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

CASADI = "casadi>=3.6,<4"
CYIPOPT = "cyipopt>=1.5"
MAP_DATA = ("commonroad-dataset-converter", "2025.1.0")  # its crdata/datasets/*/maps/*.xml only
PC_TEMPLATE = """prefix={prefix}
libdir=${{prefix}}
includedir=${{prefix}}/include/coin-or

Name: Ipopt
Description: Ipopt as bundled in the casadi wheel
Version: {version}
Cflags: -I${{includedir}}
Libs: -L${{libdir}} -lipopt
"""


PATCH = {
    "    np_jac_g = np.array(ret_val, dtype=DTYPEd).flatten()":
        "    cdef np.ndarray[DTYPEd_t, ndim=1] np_jac_g = np.array(ret_val, dtype=DTYPEd).flatten()",
    "    np_h = np.array(ret_val, dtype=DTYPEd).flatten()":
        "    cdef np.ndarray[DTYPEd_t, ndim=1] np_h = np.array(ret_val, dtype=DTYPEd).flatten()",
}  # fmt: skip
PATCHED_MARK = "cdef np.ndarray[DTYPEd_t, ndim=1] np_jac_g"


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


def patched() -> bool:
    """Does the installed cyipopt carry ``PATCH`` (its .pyx is installed with it)?"""
    return probe(
        "import cyipopt, pathlib; p = pathlib.Path(cyipopt.__file__).parent / 'cython' / 'ipopt_wrapper.pyx';"
        f"print(p.read_text().count({PATCHED_MARK!r}))"
    ) not in (None, "0")


def patched_sdist(workdir: Path, env: dict) -> str:
    """Download cyipopt's sdist, apply ``PATCH``; the source folder (or the requirement
    itself if the download or the patch fails)."""
    if pip("download", "-q", "--no-deps", "--no-binary", "cyipopt", "-d", str(workdir), CYIPOPT, env=env) != 0:
        return CYIPOPT
    archives = sorted(workdir.glob("cyipopt-*.tar.gz"))
    if not archives:
        return CYIPOPT
    with tarfile.open(archives[-1]) as tar:
        tar.extractall(workdir, filter="data")
    sources = sorted(workdir.glob("cyipopt-*/cyipopt/cython/ipopt_wrapper.pyx"))
    if not sources:
        return CYIPOPT
    text = sources[-1].read_text()
    if all(old in text for old in PATCH):
        for old, new in PATCH.items():
            text = text.replace(old, new)
        sources[-1].write_text(text)
        print("install_solver: patched the Jacobian/Hessian copy loops of ipopt_wrapper.pyx", flush=True)
    else:
        print("install_solver: patch lines not found; building cyipopt as released", flush=True)
    return str(sources[-1].parents[2])


def build_against_casadi(prefix: Path) -> bool:
    version = "3.14"
    header = prefix / "include" / "coin-or" / "IpoptConfig.h"
    if header.exists():
        for line in header.read_text().splitlines():
            if "IPOPT_VERSION " in line and '"' in line:
                version = line.split('"')[1]
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "ipopt.pc").write_text(PC_TEMPLATE.format(prefix=prefix, version=version))
        env = dict(os.environ, PKG_CONFIG_PATH=tmp, LDFLAGS=f"-Wl,-rpath,{prefix}")
        source = patched_sdist(Path(tmp), env)
        return (
            pip(
                "install", "--no-cache-dir", "--no-binary", "cyipopt", "--force-reinstall", "--no-deps", source, env=env
            )
            == 0
        )


def install_map_data() -> None:
    """``MAP_DATA`` without its dependencies, unless that version is installed already."""
    name, version = MAP_DATA
    if probe(f"import importlib.metadata as m; print(m.version({name!r}))") == version:
        print(f"install_solver: map data {name} {version} already installed")
        return
    if pip("install", "-q", "--no-deps", f"{name}=={version}") != 0:
        sys.exit(f"install_solver: could not install the map data {name}=={version}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--wheels", action="store_true", help="use cyipopt-wheels (bundled Ipopt 3.14.11) instead")
    args = ap.parse_args()
    install_map_data()
    prefix = casadi_dir()
    have = current_ipopt()
    if not args.wheels and have and str(prefix) in have and patched():
        print(f"install_solver: cyipopt already uses casadi's Ipopt ({have}), patched")
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
