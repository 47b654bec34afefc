"""docs/architecture.md against the code: the import claims it states, the files it names.

The table "What each layer may import, and what it imports" states, for each layer, the rule
(``may import``, the one tests/test_layers.py enforces) and what the layer imports today
(``imports``). Both are parsed here: the imports are compared with the import graph read from the
source (tools/import_graph.py), both ways, and the rule with test_layers' ``LAYERS``. The prose's
"Only `A` imports `B`", "nothing but `A` imports `B` or `C`" and "Nothing imports `B`" are checked
on the same graph, and every project path or module the page names must exist.
"""

from __future__ import annotations

import re

import pytest
from test_layers import LAYERS

from tools.import_graph import ROOT, layer_imports, module_file

DOC = ROOT / "docs" / "architecture.md"
HEADER = "| layer | owns | may import | imports |"
EVERY_LAYER = "every layer"
NAME = re.compile(r"`([\w.]+)`( and below)?")


def claims_table(text: str) -> dict[str, tuple[list[tuple[str, bool]], set[str]]]:
    """The claims table of ``text``: for each layer, its rule and its imports.

    Parameters
    ----------
    text : str
        The Markdown of docs/architecture.md.

    Returns
    -------
    dict
        layer -> (rule, imports). The rule is a list of (layer, and_below) pairs, or
        ``[(EVERY_LAYER, False)]``; the imports a set of layers.

    Raises
    ------
    ValueError
        If the table is missing, a row has not four cells, or a layer has two rows.
    """
    lines = text.splitlines()
    if HEADER not in lines:
        raise ValueError(f"docs/architecture.md has no claims table (header {HEADER!r})")
    rows: dict[str, tuple[list[tuple[str, bool]], set[str]]] = {}
    for line in lines[lines.index(HEADER) + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4:
            raise ValueError(f"a claims row needs 4 cells: {line!r}")
        layer, _, may, imports = cells
        name = NAME.fullmatch(layer)
        if not name or name.group(1) in rows:
            raise ValueError(f"a claims row names no layer, or one named before: {line!r}")
        rule = [(EVERY_LAYER, False)] if may == EVERY_LAYER else [(m, bool(b)) for m, b in NAME.findall(may)]
        rows[name.group(1)] = (rule, {m for m, _ in NAME.findall(imports)})
    return rows


def expand_rule(rows: dict[str, tuple[list[tuple[str, bool]], set[str]]], layer: str) -> set[str]:
    """The layers ``layer`` may import by its row: each named layer, and "X and below" with X's own rule."""
    allowed: set[str] = set()
    for name, below in rows[layer][0]:
        if name == EVERY_LAYER:
            return set(rows) - {layer}
        allowed.add(name)
        if below:
            allowed |= expand_rule(rows, name)
    return allowed


def disagreements(claimed: dict[str, set[str]], actual: dict[str, set[str]]) -> list[str]:
    """Each layer import the page claims and the code lacks, and each the code has and the page lacks."""
    out = []
    for layer in sorted(set(claimed) | set(actual)):
        stated, real = claimed.get(layer, set()), actual.get(layer, set())
        out += [f"{layer}: the page says it imports {m}, the code does not" for m in sorted(stated - real)]
        out += [f"{layer}: the code imports {m}, the page does not say so" for m in sorted(real - stated)]
    return out


def prose_claims(text: str) -> list[tuple[set[str], str]]:
    """(the only importers allowed, the layer) of "Only `A` imports `B`", "nothing but `A` imports `B` or `C`"
    and "Nothing imports `B`" in ``text`` (line breaks ignored)."""
    flat = " ".join(text.split())
    found = []
    for who, what in re.findall(r"(?:Only|[Nn]othing but) `([\w.]+)` imports ((?:`[\w.]+`(?:,| or| and)? ?)+)", flat):
        found += [({who}, m) for m, _ in NAME.findall(what)]
    found += [(set(), m) for m in re.findall(r"Nothing imports `([\w.]+)`", flat)]
    return found


def importers(graph: dict[str, set[str]], layer: str) -> set[str]:
    """The layers whose modules import ``layer``."""
    return {name for name, imported in graph.items() if layer in imported}


@pytest.fixture(scope="module")
def rows():
    return claims_table(DOC.read_text())


@pytest.fixture(scope="module")
def graph():
    return layer_imports(LAYERS)


def test_the_page_has_a_row_for_every_layer(rows):
    assert sorted(rows) == sorted(LAYERS)
    named = {m for rule, imports in rows.values() for m in {n for n, _ in rule} | imports} - {EVERY_LAYER}
    assert named <= set(LAYERS), named - set(LAYERS)


def test_each_layer_imports_exactly_what_the_page_says(rows, graph):
    claimed = {layer: imports for layer, (_, imports) in rows.items()}
    assert not disagreements(claimed, graph), "\n".join(disagreements(claimed, graph))


def test_the_rule_on_the_page_is_the_one_test_layers_enforces(rows):
    rules = {layer: expand_rule(rows, layer) for layer in rows}
    wrong = {layer: (rule, LAYERS[layer]) for layer, rule in rules.items() if rule != LAYERS[layer]}
    assert not wrong, wrong


def test_what_each_layer_imports_is_within_its_rule(rows):
    outside = {layer: imports - expand_rule(rows, layer) for layer, (_, imports) in rows.items()}
    assert not any(outside.values()), outside


def test_the_prose_says_who_imports_a_layer_as_the_code_does(graph):
    claims = prose_claims(DOC.read_text())
    assert len(claims) >= 4  # Only cli imports search; nothing but cli imports traffic, plotting; derivations.paper
    wrong = [(only, layer, importers(graph, layer)) for only, layer in claims if not importers(graph, layer) <= only]
    assert not wrong, wrong


def test_every_path_and_module_the_page_names_exists():
    text = DOC.read_text()
    paths = set(re.findall(r"\b((?:model|derivations|tests|tools|workflows|docs)/[\w./-]*\w)", text))
    missing = [p for p in sorted(paths) if not (ROOT / p).exists()]
    modules = {m for m in re.findall(r"`((?:model|derivations)(?:\.\w+)+)", text) if not m.endswith(".py")}
    missing += [m for m in sorted(modules) if module_file(m) is None and module_file(m.rsplit(".", 1)[0]) is None]
    assert not missing, missing


# -- the checks can fail ------------------------------------------------------------------------------------------


def mutated(text: str, layer: str, old: str, new: str) -> str:
    """``text`` with ``old`` replaced by ``new`` in the claims row of ``layer`` only."""
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith(f"| `{layer}` |"))
    assert old in lines[i]
    lines[i] = lines[i].replace(old, new)
    return "\n".join(lines)


def test_a_claimed_import_the_code_lacks_and_an_unclaimed_one_are_both_caught(graph):
    text = DOC.read_text()
    claimed_too_much = mutated(text, "model.traffic", "`model.errors`, ", "`model.errors`, `model.simulation`, ")
    claimed_too_little = mutated(text, "derivations", "| `model.vehicles` |", "| - |")
    for wrong, expected in (
        (claimed_too_much, "model.traffic: the page says it imports model.simulation, the code does not"),
        (claimed_too_little, "derivations: the code imports model.vehicles, the page does not say so"),
    ):
        claimed = {layer: imports for layer, (_, imports) in claims_table(wrong).items()}
        assert disagreements(claimed, graph) == [expected]


def test_a_wrong_rule_and_a_missing_table_are_caught():
    text = DOC.read_text()
    rows = claims_table(mutated(text, "model.studies", ", `model.indirect` and below", ""))
    assert expand_rule(rows, "model.studies") == LAYERS["model.studies"] - {"model.indirect"}
    with pytest.raises(ValueError, match="no claims table"):
        claims_table(text.replace(HEADER, "| layer | owns |"))


def test_a_wrong_sentence_about_importers_is_caught(graph):
    claims = prose_claims("Only `model.traffic` imports\n`model.search`. Nothing imports `model.errors` but the tests.")
    assert claims == [({"model.traffic"}, "model.search"), (set(), "model.errors")]
    assert all(not importers(graph, layer) <= only for only, layer in claims)
