"""Row blocks: one SX row template over slots, applied at many indices.

A ``Block`` is ``r`` constraint rows (or the objective) written over ``S`` slot
symbols and evaluated at ``n`` indices; ``index[s, j]`` is the position of slot ``s``
at index ``j`` in the pool vector (x, then p, then constants). A templated Pyomo
Constraint is a block with r = 1 and n = its size; any other component is a block with
n = 1 whose slots are the variables it uses.

Everything symbolic (derivatives, eliminations) happens on the template, so its cost
does not grow with n; the n copies exist only as index arrays and ``Function.map``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np
from scipy.sparse import coo_matrix, csr_matrix


@dataclass
class Block:
    """Rows ``row`` (r x 1 SX over ``slots``) at n indices; full rows offset + j r + i.

    ``bounds``: (lower, upper) numbers shared by all rows, if the template has them;
    ``ids``: explicit full row numbers [r, n] (merged blocks).
    """

    row: ca.SX
    slots: ca.SX
    index: np.ndarray
    offset: int = 0
    own: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    bounds: tuple | None = None
    ids: np.ndarray | None = None

    @property
    def n(self) -> int:
        return self.index.shape[1]

    @property
    def r(self) -> int:
        return self.row.numel()

    @property
    def m(self) -> int:
        """Number of rows."""
        return self.n * self.r

    def rows(self) -> np.ndarray:
        """Full-model row numbers of this block, in evaluation order."""
        return self.ids.T.ravel() if self.ids is not None else self.offset + np.arange(self.m)

    def mapped(self, expr: ca.SX, extra: list[ca.SX] = ()) -> ca.Function | Chunked:
        """``expr`` (over slots and ``extra``) as a Function mapped over the n indices."""
        fn = ca.Function("block", [self.slots, *extra], [expr])
        return Chunked(fn, self.n) if self.n > 1 else fn

    def gather(self, pool: ca.MX | np.ndarray):
        """Slot values at every index, padded to whole chunks (the last index repeated):
        an S x width matrix taken from the pool, the argument of ``mapped`` Functions."""
        cols = pad_columns(self.n)
        flat = self.index[:, cols].T.ravel()
        if isinstance(pool, np.ndarray):
            return pool[flat].reshape(len(cols), -1).T
        return ca.reshape(pool[flat.tolist()], self.index.shape[0], len(cols))

    def values(self, fn: ca.Function | Chunked, pool: np.ndarray) -> np.ndarray:
        """A ``mapped`` Function evaluated numerically at the n indices: outputs x n."""
        return np.array(fn(self.gather(pool)))[:, : self.n]


class Chunked:
    """``fn`` at n indices, called on chunks of ``CHUNK`` indices at a time.

    One chunk is an SX function of CHUNK copies, so CasADi's per-call overhead of a
    serial map (~50 ns, more than a small template costs) is paid n / CHUNK times.
    It is called on arguments padded to whole chunks (``Block.gather``) and returns
    padded columns; the caller keeps the first n.
    """

    CHUNK = 16

    def __init__(self, fn: ca.Function, n: int):
        self.n, self.k = n, min(self.CHUNK, n)
        self.calls = -(-n // self.k)
        self.fn = fn.map(self.k).expand().map(self.calls)

    @classmethod
    def width(cls, n: int) -> int:
        k = min(cls.CHUNK, n)
        return -(-n // k) * k

    def __call__(self, *args):
        return self.fn(*args)


def pad_columns(n: int) -> np.ndarray:
    """Column numbers 0..n-1 padded to whole chunks with copies of the last."""
    return np.minimum(np.arange(Chunked.width(n)), n - 1)


def from_expressions(rows: ca.SX, x: ca.SX, p: ca.SX, offset: int) -> Block:
    """A one-index block of ``rows`` over the x and p entries they depend on."""
    dx = np.flatnonzero(ca.which_depends(rows, x, 1, False)) if x.numel() else np.zeros(0, int)
    dp = np.flatnonzero(ca.which_depends(rows, p, 1, False)) if p.numel() else np.zeros(0, int)
    slots = ca.vertcat(_pick(x, dx), _pick(p, dp))
    index = np.concatenate([dx, x.numel() + dp]).astype(np.int64).reshape(-1, 1)
    return Block(rows, slots, index, offset, np.zeros(len(index), dtype=bool))


def _pick(v: ca.SX, which) -> ca.SX:
    """Entries ``which`` of an SX column, in one call (an empty column if none)."""
    which = np.asarray(which, dtype=np.int64)
    return v[which.tolist()] if len(which) else ca.SX(0, 1)


def tidy(block: Block) -> Block:
    """Merge slots that point to the same positions everywhere; drop unused slots."""
    if block.slots.numel() == 0:
        return block
    seen: dict[bytes, int] = {}
    first = np.array([seen.setdefault(r.tobytes(), s) for s, r in enumerate(block.index)], dtype=np.int64)
    keep = np.unique(first)
    row = ca.substitute(block.row, block.slots, _pick(block.slots, first))
    used = np.asarray(ca.which_depends(row, block.slots, 1, False), dtype=bool)
    keep = keep[used[keep]]
    own = block.own[keep] if len(block.own) else np.zeros(len(keep), dtype=bool)
    slots = _pick(block.slots, keep)
    return replace(block, row=row, slots=slots, index=block.index[keep], own=own)


def merge(blocks: list[Block]) -> Block:
    """Blocks with the same n (not summed) as one: their rows stacked at each index,
    so shared slots and subexpressions are computed once per index."""
    rows, slots, ids = [], [], []
    for b in blocks:
        copy = ca.SX.sym("m", b.slots.numel())
        rows.append(ca.substitute(b.row, b.slots, copy))
        slots.append(copy)
        ids.append(b.rows().reshape(b.n, b.r).T)
    index = np.vstack([b.index for b in blocks])
    own = np.zeros(index.shape[0], dtype=bool)
    return tidy(Block(ca.vertcat(*rows), ca.vertcat(*slots), index, blocks[0].offset, own, ids=np.vstack(ids)))


@dataclass
class Definition:
    """Rows 0 = c X[t] + rest of a block: X at ``cols`` := ``value`` (over the block's slots)."""

    block: Block
    slot: int
    value: ca.SX

    @property
    def cols(self) -> np.ndarray:
        return self.block.index[self.slot]


def find_definition(block: Block, n_x: int, unbounded: np.ndarray) -> Definition | None:
    """The definition in a templated block, if exactly one slot enters with a constant
    coefficient, is a Var indexed like the constraint and unbounded, and others are Vars."""
    if block.r != 1 or not len(block.own):
        return None
    grad = ca.jacobian(block.row, block.slots)
    const = [k for k in range(grad.nnz()) if grad.nz[k].is_constant() and float(grad.nz[k]) != 0]
    if len(const) != 1:
        return None
    s = int(grad.sparsity().get_col()[const[0]])
    others = [k for k in range(block.slots.numel()) if k != s and np.all(block.index[k] < n_x)]
    if not block.own[s] or not others or not unbounded[block.index[s]].all():
        return None
    rest = ca.substitute(block.row, block.slots[s], 0)
    return Definition(block, s, -rest / float(grad.nz[const[0]]))


def split_linear(block: Block, owner: np.ndarray, dpos: np.ndarray, pool: np.ndarray, n_free: int):
    """``block`` = rest + K v, with v its slots on defined variables and K constant
    (numbers, or pool constants at positions >= ``n_free``: evaluated per index).

    Returns the rest (a block without those slots) and the links (full row, position
    of the defined value in the vector of all definitions, coefficient); None if a
    defined slot enters nonlinearly or also points to free variables.
    """
    idx, defined = block.index, _defined(block, owner)
    hit = np.flatnonzero(defined.any(axis=1))
    if not len(hit):
        return block, no_links()
    if not defined[hit].all():
        return None
    v = _pick(block.slots, hit)
    grad = ca.jacobian(block.row, v)
    varying = np.flatnonzero(~np.all(idx >= n_free, axis=1))
    if any(ca.which_depends(grad.nz[:], _pick(block.slots, varying), 1, True)):
        return None
    rest = tidy(replace(block, row=ca.substitute(block.row, v, ca.DM.zeros(len(hit)))))
    gi, gs = (np.asarray(a, dtype=np.int64) for a in grad.sparsity().get_triplet())
    coef = block.values(block.mapped(ca.vec(grad.nz[:])), pool).T.ravel()  # [j, k]
    full = block.rows().reshape(block.n, block.r)  # [j, i]
    return rest, (full[:, gi].ravel(), dpos[idx[hit[gs]].T].ravel(), coef)


def nonlinear_uses(block: Block, owner: np.ndarray, n_free: int) -> np.ndarray:
    """Columns of defined variables that ``block`` uses other than linearly with a
    constant coefficient (these must be substituted; the others can be linked)."""
    idx, defined = block.index, _defined(block, owner)
    hit = np.flatnonzero(defined.any(axis=1))
    if not len(hit):
        return np.zeros(0, np.int64)
    grad = ca.jacobian(block.row, _pick(block.slots, hit))  # one call for all defined slots
    varying = _pick(block.slots, np.flatnonzero(~np.all(idx >= n_free, axis=1)))
    moving = np.asarray(ca.which_depends(grad.nz[:], varying, 1, True), dtype=bool)
    bad = ~defined[hit].all(axis=1)
    bad[np.asarray(grad.sparsity().get_col())[moving]] = True
    return np.unique(idx[hit[bad]][defined[hit[bad]]])


def _defined(block: Block, owner: np.ndarray) -> np.ndarray:
    """[S, n]: does slot s point at index j to a defined variable (``owner`` >= 0)?"""
    n_x = len(owner)
    return (block.index < n_x) & (owner[np.minimum(block.index, n_x - 1)] >= 0)


def no_links() -> tuple:
    return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)


def eliminate(block: Block, defs: list[Definition], owner: np.ndarray, at: np.ndarray) -> Block:
    """Substitute defined variables into ``block``: each such slot becomes its
    definition's other slots, shifted to the index that defines it.

    ``owner[c]``/``at[c]``: the definition and index that define column c (-1: none).
    Raises ValueError if a slot mixes defined and free columns or two definitions.
    """
    idx, defined = block.index, _defined(block, owner)
    old, new, slots, index = [], [], [block.slots], [idx]
    for s in range(idx.shape[0]):
        pos, hit = idx[s], defined[s]
        if not hit.any():
            continue
        which = np.unique(owner[pos[hit]]) if hit.all() else []
        if len(which) != 1:
            raise ValueError("a slot mixes defined and free variables")
        d = defs[int(which[0])]
        copy = ca.SX.sym(f"e{s}", d.block.slots.numel())
        old.append(block.slots[s])
        new.append(ca.substitute(d.value, d.block.slots, copy))
        slots.append(copy)
        index.append(d.block.index[:, at[pos]])
    if not old:
        return block
    row = ca.substitute(block.row, ca.vertcat(*old), ca.vertcat(*new))
    own = np.zeros(sum(i.shape[0] for i in index), dtype=bool)
    own[: len(block.own)] = block.own
    return tidy(Block(row, ca.vertcat(*slots), np.vstack(index), block.offset, own))


@dataclass
class Layout:
    """A block's derivative nonzeros: a Function mapped over its indices, and for
    each raw output entry the (row, column) it adds into."""

    fn: ca.Function
    rows: np.ndarray
    cols: np.ndarray


def _variable_slots(block: Block, n_var: int) -> tuple[ca.SX, np.ndarray]:
    """The slots that point to a variable (position < n_var) at some index."""
    which = np.flatnonzero((block.index < n_var).any(axis=1))
    return _pick(block.slots, which), block.index[which]


def jacobian_layout(block: Block, start: int, n_var: int) -> Layout:
    """d rows / d variable slots per index; target rows start + j r + i, columns the
    slot positions."""
    slots, index = _variable_slots(block, n_var)
    jac = ca.jacobian(block.row, slots)
    jr, jc = (np.asarray(a, dtype=np.int64) for a in jac.sparsity().get_triplet())
    rows = (start + np.arange(block.n)[:, None] * block.r + jr[None, :]).ravel()
    return Layout(block.mapped(ca.vec(jac.nz[:])), rows, index[jc].T.ravel())


def hessian_layout(block: Block, n_var: int) -> tuple[Layout, np.ndarray]:
    """Lower triangle of d2 (lam . rows) / d slots2 per index (variable slots), as
    (row >= column) targets, and the weights: two different slots at the same
    position meet on the diagonal twice."""
    slots, index = _variable_slots(block, n_var)
    lam = ca.SX.sym("lam", block.r)
    hess = ca.tril(ca.hessian(ca.dot(lam, block.row), slots)[0])
    hr, hc = (np.asarray(a, dtype=np.int64) for a in hess.sparsity().get_triplet())
    a, b = index[hr].T.ravel(), index[hc].T.ravel()
    weight = np.where(np.tile(hr != hc, block.n) & (a == b), 2.0, 1.0)
    return Layout(block.mapped(ca.vec(hess.nz[:]), [lam]), np.maximum(a, b), np.minimum(a, b)), weight


class Assembly:
    """Raw derivative entries summed into a sparse pattern by one constant matrix.

    Contributions are (row, column, raw entry, weight); a raw entry may feed several
    targets. ``dense=n`` makes the pattern a dense vector of length n (a gradient).
    """

    def __init__(self, rows, cols, raw, weight, n_raw: int, n_cols: int, dense: int | None = None):
        if dense is None:
            keys, target = np.unique(rows * n_cols + cols, return_inverse=True)
            self.rows, self.cols = (np.asarray(a, dtype=np.int64) for a in np.divmod(keys, n_cols))
            self.size = len(keys)
        else:
            target, self.size = cols, dense
        coo = coo_matrix((weight, (np.asarray(target).ravel(), raw)), shape=(self.size, n_raw)).tocsc()
        coo.sum_duplicates()
        pattern = ca.Sparsity(self.size, n_raw, coo.indptr.tolist(), coo.indices.tolist())
        self.matrix = ca.DM(pattern, coo.data)


def through(links: csr_matrix, lay: Layout, offset: int) -> tuple[np.ndarray, ...]:
    """Contributions of a definition's derivative entries (rows = positions in the
    vector of definitions) to the rows that use them with constant coefficients."""
    pick = coo_matrix((np.ones(len(lay.rows)), (lay.rows, np.arange(len(lay.rows)))),
                      shape=(links.shape[1], len(lay.rows)))  # fmt: skip
    used = (links @ pick.tocsc()).tocoo()
    return used.row, lay.cols[used.col], offset + used.col, used.data
