"""A ``casadi.conic`` QP solver called through persistent numpy buffers."""

from __future__ import annotations

import casadi as ca
import numpy as np


class BufferedQP:
    """A ``casadi.conic`` QP solver called through persistent numpy buffers.

    Converting the dense constraint matrix (about 1500 x 100 on a road horizon) to a CasADi DM
    per call costs about 10 ms, more than the hot-started QP itself; the solver's buffer reads
    the arrays in place (column-major for the matrices). The solver's memory, and with it the
    active set it hot-starts from, is the buffer's own and persists across calls.

    Parameters
    ----------
    qp : casadi.Function
        The solver (``casadi.conic``); a matrix input is given as a dense 2-D array (for a dense
        pattern) or as the vector of its nonzeros in CasADi's (column-major) order.
    """

    INPUTS = ("h", "g", "a", "lba", "uba", "lbx", "ubx")

    def __init__(self, qp: ca.Function, every_input: bool = False):
        self.fn = qp
        self._buf, self._trigger = qp.buffer()
        self._args = {}
        for name in qp.name_in() if every_input else self.INPUTS:
            i = qp.index_in(name)
            sp = qp.sparsity_in(i)
            self._args[name] = np.zeros(sp.nnz())  # the nonzeros (column-major for a dense matrix)
            self._buf.set_arg(i, memoryview(self._args[name]))
        self._res = {name: np.zeros(qp.nnz_out(i)) for i, name in enumerate(qp.name_out())}
        for i, name in enumerate(qp.name_out()):
            self._buf.set_res(i, memoryview(self._res[name]))

    @property
    def x(self) -> np.ndarray:
        """The last solution (a copy)."""
        return self._res["x"].copy()  # names: the QP solver's output "x"

    def __call__(self, h, g, a, lba, uba, lbx, ubx) -> dict:
        """Solve the QP with these data (copied into the buffers); the solver's stats."""
        for name, value in zip(self.INPUTS, (h, g, a, lba, uba, lbx, ubx), strict=True):
            self._args[name][...] = value.ravel(order="F") if np.ndim(value) == 2 else value
        self._trigger()
        return self._buf.stats()
