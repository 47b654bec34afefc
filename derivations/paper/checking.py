"""The checking machinery: robust expression comparison, computed verdicts, claim records."""

from __future__ import annotations

import math
import random
from dataclasses import asdict, dataclass

import sympy as sp

from model.vehicles import expression

HOLDS = "holds"
FAILS = "fails"
CORRECTED = "holds after correction"


@dataclass
class Comparison:
    """a == b decided by simplify(a - b) == 0 and, as a second opinion, random numeric points."""

    equal: bool
    symbolic: bool
    numeric_error: float
    difference: sp.Expr


@dataclass
class Claim:
    """One mathematical claim of the paper with its computed verdict."""

    id: str
    section: str
    statement: str
    verdict: str
    evidence: str

    @property
    def status(self) -> str:
        """HOLDS, FAILS or CORRECTED (the verdict without its correction text)."""
        return self.verdict.split(":")[0]

    def to_dict(self) -> dict[str, str]:
        return asdict(self)


def _sample(symbol: sp.Symbol, rng: random.Random) -> float:
    """A random value in a domain where the project's expressions are defined."""
    if symbol.is_positive:
        return rng.uniform(0.2, 2.0)
    if symbol.name in ("phi", "theta"):
        return rng.uniform(-1.2, 1.2)
    return rng.uniform(-2.0, 2.0)


def numeric_error(expr: sp.Expr, scale: sp.Expr, samples: int = 12, seed: int = 7) -> float:
    """max |expr| / (1 + |scale|) over random real points of the free symbols."""
    symbols = sorted(expr.free_symbols | scale.free_symbols, key=lambda s: s.name)
    f = sp.lambdify(symbols, [expr, scale], "mpmath")
    rng = random.Random(seed)
    worst = 0.0
    for _ in range(samples):
        point = [_sample(s, rng) for s in symbols]
        value, size = (complex(v) for v in f(*point))
        worst = max(worst, abs(value) / (1.0 + abs(size)))
    return worst


def compare(a: sp.Expr, b: sp.Expr, tol: float = 1e-9) -> Comparison:
    """Compare two expressions symbolically and numerically; the numeric opinion decides
    when simplify cannot prove equality, and a contradiction between the two raises."""
    a, b = expression(a), expression(b)
    diff = sp.simplify(sp.trigsimp(sp.expand(a - b)))
    symbolic = diff == 0
    err = numeric_error(a - b, sp.Abs(a) + sp.Abs(b))
    if symbolic and err > 1e-6:
        raise ArithmeticError(f"simplify says 0 but numeric error is {err:g} for {a} vs {b}")
    return Comparison(symbolic or err < tol, symbolic, err, diff)


def is_zero(expr: sp.Expr) -> bool:
    """expr == 0, by the same two opinions."""
    return compare(expr, sp.Integer(0)).equal


def decide(printed: bool, corrected: bool | None = None, correction: str = "") -> str:
    """The verdict string from computed booleans: holds, holds after correction, or fails."""
    if printed:
        return HOLDS
    if corrected:
        return f"{CORRECTED}: {correction}"
    return FAILS


def tex(expr: sp.Expr, limit: int = 400) -> str:
    """LaTeX of expr, or a size note when it is too long to read in evidence."""
    out = sp.latex(expr)
    return out if len(out) <= limit else rf"\text{{(expression with {sp.count_ops(expr)} operations)}}"


def nonvanishing(expr: sp.Expr, samples: int = 12) -> bool:
    """expr is non-zero at every random sample point (hence not identically zero)."""
    symbols = sorted(expr.free_symbols, key=lambda s: s.name)
    f = sp.lambdify(symbols, expr, "mpmath")
    rng = random.Random(11)
    return all(abs(complex(f(*[_sample(s, rng) for s in symbols]))) > 1e-12 for _ in range(samples))


def check_expression(claim_id: str, section: str, statement: str, printed: sp.Expr, derived: sp.Expr,
                     readings: dict[str, sp.Expr] | None = None, what: str = "") -> Claim:
    """The paper's printed expression against the derived one; alternative readings (typo
    hypotheses or corrections) are tried in order when the printed one fails."""
    cmp = compare(printed, derived)
    evidence = [f"derived{(' ' + what) if what else ''}: ${tex(derived)}$"]
    if not cmp.equal:
        evidence.append(f"printed minus derived: ${tex(cmp.difference)}$")
    passing = None
    for label, expr in (readings or {}).items() if not cmp.equal else ():
        ok = compare(expr, derived).equal
        evidence.append(f"reading '{label}': {'agrees' if ok else 'disagrees'}")
        if ok and passing is None:
            passing = label
    verdict = decide(cmp.equal, passing is not None, passing or "")
    return Claim(claim_id, section, statement, verdict, "; ".join(evidence))


def fmt(x: float) -> str:
    """A number for evidence text."""
    return f"{x:.6g}" if math.isfinite(x) else str(x)
