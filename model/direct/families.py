"""The typed record of a transcription: which rows form which constraint family, and how soft each is.

``build_model`` opens a ``Transcription`` on the Pyomo model it builds (``m.transcription``, the one
attribute the model carries for its users) and every part of the transcription declares its rows
there once, as it adds them: the trapezoid rows per state, the bounded outputs, the disc keep-out,
each body's island / corridor / keep-out rows, the moving obstacles, the horizon's terminal rows,
the auxiliary points' definitions and the initial-value parameters. A family's softness says how it
may be violated:

- ``hard``: never (no slack);
- ``slack``: each row has a slack column (``slacks``) that the objective prices (the MPC's soft
  keep-out and body rows, at the options' penalty) or that is the objective (the minimal-violation
  model behind ``diagnosis``).

The MPC, the real-time iteration, the stagewise QP and the costates address rows and columns through
it (``transcription_of(m)``), never through component names.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pyomo.environ as pyo

SOFTNESS = ("hard", "slack")
KINDS = ("dynamics", "bound", "path", "obstacle", "island", "corridor", "keep_out", "moving", "terminal")
PRICED = ("bound", "island", "corridor", "keep_out", "moving")  # the path families the costates price


@dataclass
class Family:
    """Rows declared together: their name, kind, constraints, softness and slack columns.

    Parameters
    ----------
    name : str
        The family's name (``dynamics_x``, ``articulation`` (a bounded output), ``vehicle_corridor``, ``moving``,
        ``obstacle``, ``terminal``); the costates' multiplier columns are ``mu_<name>``.
    kind : str
        One of ``KINDS``: ``bound`` a bounded output of the state, ``path`` one of state and control (the
        lateral acceleration, at the nodes and the midpoints), ``obstacle`` the disc keep-out.
    rows : list of pyo.Constraint
        Its indexed constraints (one per node, disc or obstacle and node).
    softness : str
        One of ``SOFTNESS``.
    slacks : list of pyo.Var
        The slack columns of a ``slack`` family.
    """

    name: str
    kind: str
    rows: list = field(default_factory=list)
    softness: str = "hard"
    slacks: list = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.kind not in KINDS or self.softness not in SOFTNESS:
            raise ValueError(f"family {self.name}: kind {self.kind!r} or softness {self.softness!r} unknown")


@dataclass
class Transcription:
    """The families of one built model, in the order they were declared.

    Parameters
    ----------
    states, controls : tuple of str
        The vehicle's names, in the model's order.
    """

    states: tuple[str, ...]
    controls: tuple[str, ...]
    families: dict[str, Family] = field(default_factory=dict)
    definitions: list[tuple[pyo.Var, pyo.Constraint]] = field(default_factory=list)
    initial: dict[str, pyo.Param] = field(default_factory=dict)
    order: list[tuple[str, pyo.Constraint]] = field(default_factory=list)
    slack_columns: list[pyo.Var] = field(default_factory=list)

    def declare(self, name: str, kind: str, row: pyo.Constraint | None = None, softness: str = "hard",
                slack: pyo.Var | None = None) -> Family:  # fmt: skip
        """Add ``row`` (and its ``slack``) to the family ``name``, creating it on first use."""
        family = self.families.setdefault(name, Family(name, kind, softness=softness))
        if (family.kind, family.softness) != (kind, softness):
            raise ValueError(f"family {name} declared as {family.kind}/{family.softness}, now {kind}/{softness}")
        if row is not None:
            family.rows.append(row)
            self.order.append((name, row))
        if slack is not None:
            family.slacks.append(slack)
        return family

    def of_kind(self, *kinds: str) -> list[Family]:
        """The families of the given kinds (all if none), in declaration order."""
        return [f for f in self.families.values() if not kinds or f.kind in kinds]

    def dynamics(self) -> list[pyo.Constraint]:
        """The trapezoid rows, one indexed constraint per state in state order."""
        return [self.families[f"dynamics_{s}"].rows[0] for s in self.states]

    def add_slack(self, column: pyo.Var) -> None:
        """A row slack of a body or moving-obstacle family (indexed by node): the soft cost prices it, the
        minimal-violation objective sums it, the real-time iteration holds it."""
        self.slack_columns.append(column)

    def family_slacks(self, name: str) -> list[pyo.Var]:
        """The slack columns of the family ``name`` ([] if it is absent or hard)."""
        family = self.families.get(name)
        return list(family.slacks) if family else []

    def rows_of_kind(self, *kinds: str) -> list[tuple[str, pyo.Constraint]]:
        """(family, constraint) of every row of the given kinds, in the order they were declared."""
        return [(name, row) for name, row in self.order if self.families[name].kind in kinds]


def open_transcription(m: pyo.ConcreteModel, states, controls) -> Transcription:
    """Attach an empty ``Transcription`` to the model being built."""
    m.transcription = Transcription(tuple(states), tuple(controls))
    return m.transcription


def transcription_of(m: pyo.ConcreteModel) -> Transcription:
    """The model's ``Transcription`` (``build_model`` opens it)."""
    record = getattr(m, "transcription", None)
    if not isinstance(record, Transcription):
        raise ValueError(f"model {m.name!r} was not built by build_model: it has no transcription")
    return record


__all__ = ["KINDS", "PRICED", "SOFTNESS", "Family", "Transcription", "open_transcription", "transcription_of"]
