"""The Pontryagin system as numeric functions of node arrays: the one source of H and psi.

``pmp_functions(ocp)`` turns the engine's symbolic system (``derivations.pmp.derive``)
into one vectorised NumPy function of the states, controls, costates, multipliers and
parameters that returns H, the adjoint right-hand sides -dH/dx, the switching
functions psi_u and the obstacle constraints c_j. The solve's trajectory columns, the
PMP certificate and ``derivations.numerics.confirm`` all evaluate this function.

The symbolic work (derivation, simplification, code printing) depends only on the
problem's structure (dynamics and cost with symbolic parameters, number of obstacles),
not on its numbers. Its generated source is kept in memory per process and on disk
(``$ROUNDABOUT_CACHE``, else ``$XDG_CACHE_HOME/roundabout-ocp``, else
``~/.cache/roundabout-ocp``; ``ROUNDABOUT_CACHE=off`` disables it), keyed by a hash of
the symbolic definition, so a new process does no symbolic work for a known structure.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from derivations.symbolic import obstacle_symbols
from model.vehicles import expression

if TYPE_CHECKING:
    from model.problem.ocp import OCP

FORMAT = 1  # bump when the generated source changes meaning


@dataclass(frozen=True)
class PMPFunctions:
    """H, -dH/dx, psi_u and c_j of one problem structure, evaluated on node arrays.

    Attributes
    ----------
    arguments : names the generated function takes, in order (states, controls,
        costates, multipliers, parameters).
    states, controls, multipliers : names, in the engine's order.
    laws : (control, kind) with kind "projection" (energy: psi is the unconstrained
        maximiser) or "bang-singular" (time: psi is the switching function dH/du).
    parameters : the numeric values of the parameter arguments for one problem.
    """

    arguments: tuple[str, ...]
    states: tuple[str, ...]
    controls: tuple[str, ...]
    multipliers: tuple[str, ...]
    laws: tuple[tuple[str, str], ...]
    parameters: Mapping[str, float]
    function: Callable[..., tuple]

    def evaluate(self, columns: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Node values of ``H``, ``adjoint_<state>``, ``psi_<control>`` and ``c_<multiplier>``.

        ``columns`` holds the states, controls and ``p_<state>`` arrays; multipliers
        missing from it are read from a summed ``mu`` column (each node's mass going to
        the obstacle nearest to contact) or taken as 0.
        """
        n = len(columns[self.states[0]])
        values = {k: np.asarray(columns[k], dtype=float) for k in self._node_arguments()}
        values.update(self._multiplier_values(columns, values, n))
        out = self.function(*[values.get(a, self.parameters.get(a)) for a in self.arguments])
        names = ["H", *(f"adjoint_{s}" for s in self.states), *(f"psi_{c}" for c, _ in self.laws),
                 *(f"c_{m}" for m in self.multipliers)]  # fmt: skip
        return {k: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy() for k, v in zip(names, out, strict=True)}

    def _node_arguments(self) -> list[str]:
        return [*self.states, *self.controls, *(f"p_{s}" for s in self.states)]

    def _multiplier_values(self, columns: Mapping, values: dict, n: int) -> dict[str, np.ndarray]:
        if all(m in columns for m in self.multipliers):
            return {m: np.asarray(columns[m], dtype=float) for m in self.multipliers}
        total = np.asarray(columns["mu"], dtype=float) if "mu" in columns else np.zeros(n)
        if len(self.multipliers) <= 1:
            return {m: total for m in self.multipliers}
        zeros = {m: np.zeros(n) for m in self.multipliers}
        c = self.function(*[values.get(a, zeros.get(a, self.parameters.get(a))) for a in self.arguments])
        nearest = np.argmin(np.array(c[-len(self.multipliers):], dtype=float), axis=0)
        return {m: np.where(nearest == j, total, 0.0) for j, m in enumerate(self.multipliers)}


def pmp_functions(ocp: OCP) -> PMPFunctions:
    """The numeric PMP functions of ``ocp`` (normal case, p0 = -1), from cache when known.

    Examples
    --------
    >>> fns = pmp_functions(ocp)                                  # doctest: +SKIP
    >>> fns.evaluate(solution.trajectory)["H"]                    # doctest: +SKIP
    """
    key = structure_key(ocp)
    namespace = _load(_MEMORY.get(key) or _read_cache(key))
    if namespace is None:  # unknown structure, or an unreadable cache entry: derive it again
        source = generate_source(ocp)
        namespace = _load(source)
        _write_cache(key, source)
    _MEMORY[key] = namespace["SOURCE"]
    return PMPFunctions(
        arguments=tuple(namespace["ARGUMENTS"]), states=tuple(namespace["STATES"]),
        controls=tuple(namespace["CONTROLS"]), multipliers=tuple(namespace["MULTIPLIERS"]),
        laws=tuple(namespace["LAWS"]), parameters=parameter_values(ocp), function=namespace["evaluate"],
    )  # fmt: skip


def _load(source: str | None) -> dict | None:
    """Execute generated source; None if there is none or it does not run."""
    if source is None:
        return None
    namespace: dict = {"SOURCE": source}
    try:
        exec(compile(source, "<derivations.functions>", "exec"), namespace)  # noqa: S102  (our generated code)
    except Exception:  # noqa: BLE001  (a damaged cache file is regenerated, never trusted)
        return None
    needed = ("ARGUMENTS", "STATES", "CONTROLS", "MULTIPLIERS", "LAWS", "evaluate")
    return namespace if all(k in namespace for k in needed) else None


def parameter_values(ocp: OCP) -> dict[str, float]:
    """Vehicle parameters and each obstacle's centre and keep-out radius, by symbol name."""
    values = dict(ocp.vehicle.parameters())
    count = len(ocp.obstacles)
    for j, ob in enumerate(ocp.obstacles):
        xo, yo, radius = obstacle_symbols(j, count)
        values.update({xo.name: ob.center[0], yo.name: ob.center[1], radius.name: ob.keep_out})
    return values


def structure_key(ocp: OCP) -> str:
    """Hash of everything the symbolic system depends on (not the problem's numbers)."""
    v = ocp.vehicle
    parts = [
        f"format {FORMAT}", f"sympy {sp.__version__}", v.model, repr(v.states), repr(v.controls), repr(v.position),
        sp.srepr(v.rhs(numeric=False)), sp.srepr(expression(ocp.cost.lagrangian(v))),
        f"obstacles {len(ocp.obstacles)}",
    ]  # fmt: skip
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def generate_source(ocp: OCP) -> str:
    """Python source of ``evaluate(*ARGUMENTS) -> (H, *adjoint, *psi, *c)`` derived by the engine."""
    from derivations.pmp import derive

    pmp = derive(ocp)
    psi = [law.stationary if law.kind == "projection" else law.switching for law in pmp.laws]
    exprs = [pmp.hamiltonian, *pmp.adjoint, *psi, *pmp.constraints]
    params = sorted(pmp.parameters, key=lambda s: s.name)
    args = [*pmp.states, *pmp.controls, *pmp.costates, *pmp.multipliers, *params]
    printer = sp.printing.numpy.NumPyPrinter({"fully_qualified_modules": True, "allow_unknown_functions": False})
    names = [a.name for a in args]
    safe = {a: sp.Symbol(f"a{i}") for i, a in enumerate(args)}
    body = ",\n        ".join(printer.doprint(expression(e).xreplace(safe)) for e in exprs)
    laws = [(law.control.name, law.kind) for law in pmp.laws]
    return (
        f"# generated by derivations.functions (format {FORMAT}) for {ocp.vehicle.model}\n"
        "import numpy\n\n"
        f"ARGUMENTS = {names!r}\nSTATES = {[s.name for s in pmp.states]!r}\n"
        f"CONTROLS = {[c.name for c in pmp.controls]!r}\nMULTIPLIERS = {[m.name for m in pmp.multipliers]!r}\n"
        f"LAWS = {laws!r}\n\n\n"
        f"def evaluate({', '.join(f'a{i}' for i in range(len(args)))}):\n"
        f"    return (\n        {body},\n    )\n"
    )


_MEMORY: dict[str, str] = {}


def cache_dir() -> Path | None:
    """Where generated sources are kept, or None when the cache is off."""
    env = os.environ.get("ROUNDABOUT_CACHE")
    if env is not None:
        return None if env.lower() in ("", "0", "off", "no") else Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "roundabout-ocp"


def _read_cache(key: str) -> str | None:
    folder = cache_dir()
    path = folder / f"pmp-{key}.py" if folder else None
    try:
        return path.read_text() if path and path.is_file() else None
    except OSError:
        return None


def _write_cache(key: str, source: str) -> None:
    """Write atomically; an unwritable cache only costs the next process the derivation."""
    folder = cache_dir()
    if folder is None:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=folder, delete=False, suffix=".tmp") as tmp:
            tmp.write(source)
        os.replace(tmp.name, folder / f"pmp-{key}.py")
    except OSError:
        pass


__all__ = ["PMPFunctions", "cache_dir", "generate_source", "parameter_values", "pmp_functions", "structure_key"]
