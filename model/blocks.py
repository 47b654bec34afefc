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


@dataclass
class Block:
    """Rows ``row`` (r x 1 SX over ``slots``) at n indices; full rows offset + j r + i.

    ``summed``: the n copies add up into the same r rows (a sum over the grid);
    ``bounds``: (lower, upper) numbers shared by all rows, if the template has them;
    ``ids``: explicit full row numbers [r, n] (merged blocks).
    """

    row: ca.SX
    slots: ca.SX
    index: np.ndarray
    offset: int = 0
    own: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    summed: bool = False
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
        return self.r if self.summed else self.n * self.r

    def rows(self) -> np.ndarray:
        """Full-model row numbers of this block, in evaluation order."""
        return self.ids.T.ravel() if self.ids is not None else self.offset + np.arange(self.m)

    def evaluate(self, fn: ca.Function, args, *extra):
        """Rows (or row-like outputs of ``fn``) of all indices; summed blocks add up."""
        out = fn(args, *extra)
        return ca.sum2(out) if self.summed else ca.vec(out)

    def mapped(self, expr: ca.SX, extra: list[ca.SX] = ()) -> ca.Function:
        """``expr`` (over slots and ``extra``) as a Function mapped over the n indices."""
        fn = ca.Function("block", [self.slots, *extra], [expr])
        return fn.map(self.n) if self.n > 1 else fn

    def gather(self, pool: ca.MX | np.ndarray):
        """Slot values at every index: an S x n matrix taken from the pool."""
        flat = self.index.T.ravel()
        if isinstance(pool, np.ndarray):
            return pool[flat].reshape(self.n, -1).T
        return ca.reshape(pool[flat.tolist()], self.index.shape[0], self.n)


def from_expressions(rows: ca.SX, x: ca.SX, p: ca.SX, offset: int) -> Block:
    """A one-index block of ``rows`` over the x and p entries they depend on."""
    dx = np.flatnonzero(ca.which_depends(rows, x, 1, False)) if x.numel() else np.zeros(0, int)
    dp = np.flatnonzero(ca.which_depends(rows, p, 1, False)) if p.numel() else np.zeros(0, int)
    slots = ca.vertcat(*[x[int(i)] for i in dx], *[p[int(i)] for i in dp]) if len(dx) + len(dp) else ca.SX(0, 1)
    index = np.concatenate([dx, x.numel() + dp]).astype(np.int64).reshape(-1, 1)
    return Block(rows, slots, index, offset, np.zeros(len(index), dtype=bool))


def tidy(block: Block) -> Block:
    """Merge slots that point to the same positions everywhere; drop unused slots."""
    if block.slots.numel() == 0:
        return block
    _, first, inverse = np.unique(block.index, axis=0, return_index=True, return_inverse=True)
    inverse = np.asarray(inverse).ravel()
    keep = np.sort(first)
    sym = [block.slots[int(s)] for s in range(block.slots.numel())]
    row = ca.substitute(block.row, block.slots, ca.vertcat(*[sym[int(first[inverse[s]])] for s in range(len(sym))]))
    used = np.asarray(ca.which_depends(row, block.slots, 1, False), dtype=bool)
    keep = keep[used[keep]]
    own = block.own[keep] if len(block.own) else np.zeros(len(keep), dtype=bool)
    slots = ca.vertcat(*[sym[int(s)] for s in keep]) if len(keep) else ca.SX(0, 1)
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


def eliminate_sum(block: Block, defs: list[Definition], owner: np.ndarray, at: np.ndarray, constant) -> Block | None:
    """A one-row block sum_s c_s v_s of defined variables (one definition, constant c_s)
    as a summed block: the definition's template over the defining indices, times c.

    ``constant(values)`` puts numbers in the pool and returns their positions.
    None if the row is not of that form.
    """
    n_x = len(owner)
    pos = block.index[:, 0] if block.n == 1 and block.r == 1 else np.zeros(0, int)
    hit = np.flatnonzero((pos < n_x) & (owner[np.minimum(pos, n_x - 1)] >= 0)) if len(pos) else pos
    if not len(hit) or len(np.unique(owner[pos[hit]])) != 1:
        return None
    v = ca.vertcat(*[block.slots[int(s)] for s in hit])
    grad = ca.jacobian(block.row, v)
    if grad.nnz() != len(hit) or not all(grad.nz[k].is_constant() for k in range(grad.nnz())):
        return None
    if not ca.substitute(block.row, v, ca.DM.zeros(len(hit))).is_zero():
        return None
    d = defs[int(owner[pos[hit[0]]])]
    coef, copy = ca.SX.sym("c"), ca.SX.sym("e", d.block.slots.numel())
    row = coef * ca.substitute(d.value, d.block.slots, copy)
    c = np.array(ca.evalf(grad)).ravel()
    index = np.vstack([constant(c)[None, :], d.block.index[:, at[pos[hit]]]])
    own = np.zeros(index.shape[0], dtype=bool)
    return tidy(Block(row, ca.vertcat(coef, copy), index, block.offset, own, summed=True))


def eliminate(block: Block, defs: list[Definition], owner: np.ndarray, at: np.ndarray) -> Block:
    """Substitute defined variables into ``block``: each such slot becomes its
    definition's other slots, shifted to the index that defines it.

    ``owner[c]``/``at[c]``: the definition and index that define column c (-1: none).
    Raises ValueError if a slot mixes defined and free columns or two definitions.
    """
    n_x = len(owner)
    idx = block.index
    old, new, slots, index = [], [], [block.slots], [idx]
    for s in range(idx.shape[0]):
        pos = idx[s]
        inside = pos < n_x
        hit = np.zeros(len(pos), dtype=bool)
        hit[inside] = owner[pos[inside]] >= 0
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
    return tidy(Block(row, ca.vertcat(*slots), np.vstack(index), block.offset, own, block.summed))


@dataclass
class Layout:
    """A block's derivative nonzeros: a Function mapped over its indices, and for
    each raw output entry the (row, column) it adds into, with a multiplicity."""

    fn: ca.Function
    rows: np.ndarray
    cols: np.ndarray
    weight: np.ndarray


def jacobian_layout(block: Block, start: int) -> Layout:
    """d rows / d slots per index; target rows start + j r + i, columns the slot positions."""
    jac = ca.jacobian(block.row, block.slots)
    jr, jc = (np.asarray(a, dtype=np.int64) for a in jac.sparsity().get_triplet())
    step = np.zeros((block.n, 1), dtype=np.int64) if block.summed else np.arange(block.n)[:, None] * block.r
    rows = (start + step + jr[None, :]).ravel()
    cols = block.index[jc].T.ravel()
    return Layout(block.mapped(jac.nz[:]), rows, cols, np.ones(len(rows)))


def hessian_layout(block: Block) -> Layout:
    """Lower triangle of d2 (lam . rows) / d slots2 per index, as (row >= column) targets.

    Two different slots at the same position meet on the diagonal: weight 2.
    """
    lam = ca.SX.sym("lam", block.r)
    hess = ca.tril(ca.hessian(ca.dot(lam, block.row), block.slots)[0])
    hr, hc = (np.asarray(a, dtype=np.int64) for a in hess.sparsity().get_triplet())
    a, b = block.index[hr].T.ravel(), block.index[hc].T.ravel()
    weight = np.where(np.tile(hr != hc, block.n) & (a == b), 2.0, 1.0)
    return Layout(block.mapped(hess.nz[:], [lam]), np.maximum(a, b), np.minimum(a, b), weight)


class Scatter:
    """Sum raw derivative entries into a sparse pattern without duplicates.

    Entries not ``valid`` (a column or row that is not a variable) are dropped.
    ``dense=n``: a dense vector of length n indexed by ``cols`` (a gradient).
    """

    def __init__(self, rows, cols, n_cols: int, valid: np.ndarray, weight: np.ndarray, dense: int | None = None):
        if dense is None:
            keys, inverse = np.unique(rows[valid] * n_cols + cols[valid], return_inverse=True)
            self.rows, self.cols = (np.asarray(a, dtype=np.int64) for a in np.divmod(keys, n_cols))
            self.size = len(keys)
        else:
            inverse, self.size = cols[valid], dense
        self.target = np.full(len(rows), self.size, dtype=np.int64)
        self.target[valid] = np.asarray(inverse).ravel()
        self.weight = None if np.all(weight == 1.0) else weight

    def __call__(self, raw: np.ndarray) -> np.ndarray:
        w = raw if self.weight is None else raw * self.weight
        return np.bincount(self.target, weights=w, minlength=self.size + 1)[: self.size]

    def matrix(self) -> ca.DM:
        """The same sum as a sparse matrix (size x raw entries), to apply inside CasADi."""
        k = np.flatnonzero(self.target < self.size)
        w = np.ones(len(self.target)) if self.weight is None else self.weight
        pattern = ca.Sparsity.triplet(self.size, len(self.target), self.target[k].tolist(), k.tolist())
        return ca.DM(pattern, w[k])
