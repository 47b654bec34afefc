"""The symbols the claim checks share, and the paper's printed switching function (8).

psi_1 below is typed from the paper as a claim under test (its eq. 8), never used to
derive anything: the engine derives its own from the model definition.
"""

from __future__ import annotations

import sympy as sp

from derivations.symbolic import obstacle_symbols
from model.vehicles import sym

x, y, theta, phi = (sym(n) for n in ("x", "y", "theta", "phi"))
px, py, pth, pph = (sym(n) for n in ("p_x", "p_y", "p_theta", "p_phi"))
u1, u2, d, mu = sym("u1"), sym("u2"), sym("d"), sym("mu")
xo, yo, R = obstacle_symbols(0, 1)
DIST = sp.sqrt((x - xo) ** 2 + (y - yo) ** 2)
PAPER_PSI1 = px * sp.cos(theta) + py * sp.sin(theta) + pth * sp.tan(phi) / d
