"""Property-based tests of the scenario parser: no input ends in a traceback.

Any TOML document, any mutation of a valid scenario file and any file content is either a
scenario or an ``InputError`` whose key names a place in the document and whose text is one
line; ``roundabout check`` then exits 0 or 2, and on 2 writes exactly one line to stderr.

The same holds for mutations of the roundabout example ([roundabout], [[roundabout.legs]], [route]).

The bugs these properties found (B1-B8: choice keys of any type, integers beyond 64 bits, quoted
keys, deeply nested arrays, a folder as the file, warnings beside the error line, non-finite
obstacle numbers, over-long integers; R1: roundabout sizes beyond 10 km) are fixed; the tests
named after them keep their minimal inputs as regression tests.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import string
import subprocess
import sys
import tempfile
import tomllib
import warnings
from datetime import date, datetime, time
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, currently_in_test_context, event, example, given, settings
from hypothesis import strategies as st

from model.errors import InputError
from model.problem.roads import LEG_KEYS, ROUNDABOUT_KEYS, ROUTE_KEYS
from model.problem.scenario import OBSTACLE_KEYS, PROBLEM_KEYS, TOP_KEYS, Scenario, load_scenario, parse_scenario
from model.vehicles import PRESETS, VEHICLES

ROOT = Path(__file__).resolve().parents[1]
VALID_FILES = [*sorted((ROOT / "workflows" / "scenarios").glob("*.toml")), ROOT / "examples" / "format-example.toml"]
VALID_BYTES = {p.name: p.read_bytes() for p in VALID_FILES}
VALID = {name: tomllib.loads(raw.decode("utf-8")) for name, raw in VALID_BYTES.items()}
EXAMPLE = VALID["format-example.toml"]
ROAD_FILE = ROOT / "examples" / "roundabout-truck.toml"  # the first file with a [roundabout] and a [route]
ROAD = {ROAD_FILE.name: tomllib.loads(ROAD_FILE.read_bytes().decode("utf-8"))}


def _settings(examples: int) -> settings:
    """Reproducible in CI (derandomize, no example database) and without deadlines (the CLI starts Python)."""
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
    )


DOCS, FAST, BUG, ROADS, CLI = _settings(250), _settings(300), _settings(50), _settings(80), _settings(20)  # ~25 s

# -- documents ------------------------------------------------------------------------------
BARE_CHARS = string.ascii_letters + string.digits + "_-"  # the characters of a bare TOML key
VEHICLE_FIELDS = sorted({f.name for cls in VEHICLES.values() for f in dataclasses.fields(cls)})
VARIABLES = sorted({n for cls in VEHICLES.values() for n in (*cls.states, *cls.controls)})
CHOICES = {"vehicle": ("model",), "problem": ("objective", "scheme", "pass")}
BODY_KEYS = ("length", "width", "rear_overhang")  # [vehicle.body] and [vehicle.trailer_body]
VOCABULARY = sorted(
    TOP_KEYS
    | PROBLEM_KEYS
    | OBSTACLE_KEYS
    | ROUNDABOUT_KEYS
    | LEG_KEYS
    | ROUTE_KEYS
    | {"model", "preset", "body", "trailer_body", *BODY_KEYS}
    | {*VEHICLE_FIELDS, *VARIABLES}
)

INT64 = st.integers(-(2**63), 2**63 - 1)  # the TOML spec's integers (tomllib accepts any size: bug B2)
NUMBERS = st.one_of(st.floats(), INT64)  # floats include inf, -inf and nan
SCALARS = st.one_of(st.text(max_size=8), NUMBERS, st.booleans(), st.datetimes(), st.dates(), st.times())
BARE_KEYS = st.text(BARE_CHARS, min_size=1, max_size=10)
KEYS = st.one_of(st.sampled_from(VOCABULARY), BARE_KEYS)
VALUES = st.recursive(
    SCALARS, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(KEYS, inner, max_size=4), max_leaves=12
)


def _section(known: dict[str, st.SearchStrategy]) -> st.SearchStrategy:
    """A table with any of the known keys, sometimes one unknown key, or any value at all."""
    table = st.builds(
        lambda extra, own: {**extra, **own},
        st.dictionaries(BARE_KEYS, VALUES, max_size=1),
        st.fixed_dictionaries({}, optional=known),
    )
    return st.one_of(table, table, VALUES)


PAIRS = st.lists(NUMBERS, min_size=2, max_size=2)
SHAPED = st.fixed_dictionaries(
    {
        "vehicle": _section(
            {
                "model": st.sampled_from(sorted(VEHICLES)) | VALUES,
                "preset": st.sampled_from(sorted(PRESETS)) | VALUES,
                "body": _section(dict.fromkeys(BODY_KEYS, NUMBERS)),
                "trailer_body": _section(dict.fromkeys(BODY_KEYS, NUMBERS)),
            }
            | dict.fromkeys(VEHICLE_FIELDS, NUMBERS)
        ),
        "bounds": _section(dict.fromkeys(VARIABLES, PAIRS | VALUES)),
        "initial": _section(dict.fromkeys(VARIABLES, NUMBERS)),
        "problem": _section(
            {
                "objective": st.sampled_from(["energy", "time"]) | VALUES,
                "final_time": NUMBERS,
                "intervals": INT64 | VALUES,
                "scheme": st.just("trapezoid") | VALUES,
                "pass": st.sampled_from(["auto", "ccw", "cw"]) | VALUES,
            }
        ),
    },
    optional={
        "name": VALUES,
        "title": VALUES,
        "final": _section(dict.fromkeys(VARIABLES, NUMBERS)),
        "obstacles": st.lists(_section({"center": PAIRS, "radius": NUMBERS, "safety": NUMBERS}), max_size=3) | VALUES,
    },
)
DOCUMENTS = st.one_of(st.dictionaries(KEYS, VALUES, max_size=8), SHAPED)

# -- mutations of the valid files -----------------------------------------------------------
KINDS = ("delete", "rename", "retype", "zero", "negative", "huge", "inf", "nan", "swap", "empty", "extra")
HUGE = (1e15, 1e300, -1e300, 2**53 + 1, 2**63 - 1, -(2**63))


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every place below a table or array, as a tuple of keys and indices."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    out = []
    for key, val in items:
        out.append((*prefix, key))
        out += _paths(val, (*prefix, key))
    return out


def _at(doc: Any, path: tuple) -> Any:
    for step in path:
        doc = doc[step]
    return doc


def _is_number(val: Any) -> bool:
    return isinstance(val, int | float) and not isinstance(val, bool)


@st.composite
def _typo(draw, key: str) -> str:
    """``key`` with one character inserted, dropped, replaced or two swapped (still a bare key)."""
    i = draw(st.integers(0, max(len(key) - 1, 0)))
    c = draw(st.sampled_from(BARE_CHARS))
    kind = draw(st.sampled_from(("insert", "drop", "replace", "swap")))
    if kind == "insert":
        new = key[:i] + c + key[i:]
    elif kind == "drop":
        new = key[:i] + key[i + 1 :]
    elif kind == "replace":
        new = key[:i] + c + key[i + 1 :]
    else:
        new = key[:i] + key[i + 1 : i + 2] + key[i : i + 1] + key[i + 2 :]
    assume(new and new != key)
    return new


def _mutate(draw, doc: dict, kind: str) -> None:
    places = _paths(doc)
    numbers = [p for p in places if _is_number(_at(doc, p))]
    containers = [p for p in places if isinstance(_at(doc, p), dict | list)]
    candidates = {
        "delete": places,
        "rename": [p for p in places if isinstance(p[-1], str)],
        "retype": places,
        "swap": [p for p in containers if isinstance(_at(doc, p), list) and len(_at(doc, p)) >= 2],
        "empty": [(), *containers],
        "extra": [(), *(p for p in containers if isinstance(_at(doc, p), dict))],
    }.get(kind, numbers)
    if not candidates:
        return
    path = draw(st.sampled_from(candidates))
    if kind == "empty" and not path:
        doc.clear()
        return
    if kind == "extra":
        _at(doc, path)[draw(KEYS)] = draw(VALUES)
        return
    parent, last = _at(doc, path[:-1]), path[-1]
    old = parent[last]
    if kind == "delete":
        del parent[last]
    elif kind == "rename":
        parent[draw(_typo(last))] = parent.pop(last)
    elif kind == "retype":
        parent[last] = draw(VALUES.filter(lambda v: type(v) is not type(old)))
    elif kind == "zero":
        parent[last] = draw(st.sampled_from((0, 0.0, -0.0)))
    elif kind == "negative":
        parent[last] = -abs(old) if old else -1
    elif kind == "huge":
        parent[last] = draw(st.sampled_from(HUGE))
    elif kind == "inf":
        parent[last] = draw(st.sampled_from((math.inf, -math.inf)))
    elif kind == "nan":
        parent[last] = math.nan
    elif kind == "swap":
        parent[last] = old[::-1]
    elif kind == "empty":
        parent[last] = type(old)()


@st.composite
def mutated(draw, kinds: tuple[str, ...] = KINDS, bases: dict[str, dict] | None = None) -> dict:
    """A valid scenario file's document (from ``bases``, default VALID) after one to three mutations."""
    bases = bases or VALID
    doc = copy.deepcopy(bases[draw(st.sampled_from(sorted(bases)))])
    for kind in draw(st.lists(st.sampled_from(kinds), min_size=1, max_size=3)):
        _mutate(draw, doc, kind)
    return doc


# -- what a good answer looks like ----------------------------------------------------------
_COMPONENT = re.compile(r'([A-Za-z0-9_-]+|"(?:[^"\\]|\\.)*"|\'[^\']*\')((?:\[\d+\])*)(\.|\Z)')


def _split_key(key: str) -> list | None:
    """An error key such as ``obstacles[0].radius`` or ``initial."a b"`` as keys and indices."""
    steps: list = []
    pos = 0
    while pos < len(key):
        m = _COMPONENT.match(key, pos)
        if not m or (m[3] == "." and m.end() == len(key)):
            return None
        part = m[1]
        if part[0] in "\"'":
            try:
                part = tomllib.loads(f"k = {part}")["k"]
            except tomllib.TOMLDecodeError:
                return None
        steps += [part, *(int(i) for i in re.findall(r"\d+", m[2]))]
        pos = m.end()
    return steps or None


def _names_place(doc: dict, key: str) -> bool:
    """True if ``key`` names a value of ``doc``, or a key missing from one of its tables.

    A key of an optional top-level table the file leaves out (``initial.phi`` beside a [route]) names
    the place the value would go, and counts too.
    """
    steps = _split_key(key)
    if steps is None:
        return False
    if len(steps) == 2 and steps[0] in TOP_KEYS and steps[0] not in doc and isinstance(steps[1], str):
        return True
    node: Any = doc
    for i, step in enumerate(steps):
        last = i == len(steps) - 1
        if isinstance(step, str) and isinstance(node, dict):
            if step not in node:
                return last  # a required key the table lacks
            node = node[step]
        elif isinstance(step, int) and isinstance(node, list) and step < len(node):
            node = node[step]
        else:
            return False
    return True


def _check_error(err: InputError, doc: dict | None) -> None:
    text = str(err)
    assert text.splitlines() == [text], f"not one line: {text!r}"
    if doc is not None:
        assert err.key, f"no key named: {text!r}"
        assert _names_place(doc, err.key), f"key {err.key!r} names no place in the document: {text!r}"


def _outcome(doc: dict) -> Scenario | InputError:
    """``parse_scenario(doc)``: a Scenario, or a checked InputError; anything else propagates."""
    try:
        result = parse_scenario(copy.deepcopy(doc))
    except InputError as err:
        _check_error(err, doc)
        _event("InputError")
        return err
    assert isinstance(result, Scenario)
    _event("Scenario")
    return result


def _event(name: str) -> None:
    """Count outcomes in --hypothesis-show-statistics (a property that never parses anything shows)."""
    if currently_in_test_context():
        event(name)


def _leaves(node: Any) -> list:
    return [_at(node, p) for p in _paths(node)]



# -- sanity of the helpers: the valid files are valid, the key reader reads keys ---------------
@pytest.mark.parametrize("name", sorted(VALID | ROAD))
def test_every_base_file_is_a_valid_scenario(name):
    assert isinstance(_outcome((VALID | ROAD)[name]), Scenario)


def test_error_keys_are_read_as_places():
    assert _names_place(EXAMPLE, "obstacles[0].radius")
    assert _names_place(EXAMPLE, "obstacles[0].saftey")  # absent from an existing table: a missing key
    assert _names_place(EXAMPLE, "vehicle")
    assert _names_place({"initial": {"a b": 1}}, 'initial."a b"')
    assert not _names_place(EXAMPLE, "obstacles[1].radius")
    assert not _names_place(EXAMPLE, "initial.x.y")
    assert not _names_place({"initial": {"a b": 1}}, "initial.a b")
    assert not _names_place({"": 1}, "")
    err = _outcome({**EXAMPLE, "problem": {**EXAMPLE["problem"], "objectve": "time"}})
    assert isinstance(err, InputError) and err.key == "problem.objectve"


# -- 1. in-process properties ---------------------------------------------------------------
@DOCS
@given(DOCUMENTS)
def test_arbitrary_documents_parse_or_raise_one_input_error(doc):
    _outcome(doc)


@FAST
@given(mutated())
def test_mutated_valid_files_parse_or_raise_one_input_error(doc):
    _outcome(doc)


BYTES = st.one_of(
    st.binary(max_size=300),
    st.text(max_size=300).map(str.encode),
    st.builds(
        lambda name, edits: _edit(VALID_BYTES[name], edits),
        st.sampled_from(sorted(VALID_BYTES)),
        st.lists(
            st.tuples(
                st.floats(0, 1), st.sampled_from(["insert", "drop", "replace"]), st.binary(min_size=1, max_size=3)
            ),
            min_size=1,
            max_size=4,
        ),
    ),
)


def _edit(data: bytes, edits: list) -> bytes:
    """``data`` with byte-level insertions, deletions and replacements at relative positions."""
    out = bytearray(data)
    for where, kind, chunk in edits:
        i = int(where * len(out))
        out[i : i + (0 if kind == "insert" else len(chunk))] = b"" if kind == "drop" else chunk
    return bytes(out)


@_settings(300)
@given(BYTES)
def test_load_scenario_on_arbitrary_bytes(content):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.toml"
        path.write_bytes(content)
        try:
            result = load_scenario(path)
        except InputError as err:
            _check_error(err, None)
        else:
            assert isinstance(result, Scenario)


# -- known bugs, each pinned by its minimal input -------------------------------------------
def _set(doc: dict, path: tuple, value: Any) -> dict:
    """A copy of ``doc`` with the value at ``path`` (keys and indices) replaced."""
    doc = copy.deepcopy(doc)
    _at(doc, path[:-1])[path[-1]] = value
    return doc


def _doc(changes: dict[tuple, Any]) -> dict:
    """The format example with some values replaced."""
    doc = EXAMPLE
    for path, value in changes.items():
        doc = _set(doc, path, value)
    return doc


NUMBER_PLACES = [p for p in _paths(EXAMPLE) if _is_number(_at(EXAMPLE, p))]
TABLE_PLACES = [(), *(p for p in _paths(EXAMPLE) if isinstance(_at(EXAMPLE, p), dict))]
CHOICE_PLACES = [(table, key) for table, keys in CHOICES.items() for key in keys]
INF_RADIUS = _doc({("obstacles", 0, "center"): [math.inf, 0.03], ("obstacles", 0, "radius"): math.inf})
HUGE_GAP = _doc({("obstacles", 0, "center"): [-1e308, 0.03], ("initial", "x"): 1e308})


@BUG
@given(st.sampled_from(CHOICE_PLACES), VALUES)
@example(("vehicle", "model"), [])
def test_b1_choice_keys_of_any_type(place, value):
    _outcome(_set(EXAMPLE, place, value))


@BUG
@given(st.sampled_from([*NUMBER_PLACES, ("name",)]), st.integers(2**63, 2**1100) | st.just(16**4000))
@example(("vehicle", "wheelbase"), 10**309)
def test_b2_integers_beyond_64_bits_are_an_input_error(path, value):
    assert isinstance(_outcome(_set(EXAMPLE, path, value)), InputError)


@BUG
@given(st.sampled_from(TABLE_PLACES), st.text(max_size=6))
@example((), "a\nb")
def test_b3_any_key_text_is_named_as_a_toml_key(table, name):
    _outcome(_set(EXAMPLE, (*table, name), 0))


@BUG
@given(mutated(("inf", "huge", "nan", "negative")))
@example(INF_RADIUS)
@example(HUGE_GAP)
def test_b6_parsing_emits_no_warning(doc):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _outcome(doc)
    assert not caught, [str(w.message) for w in caught]


@BUG
@given(st.sampled_from([("center", 0), ("center", 1), ("radius",), ("safety",)]), st.sampled_from([math.nan, math.inf]))
@example(("radius",), math.nan)
def test_b7_obstacle_numbers_must_be_finite(field, value):
    err = _outcome(_set(EXAMPLE, ("obstacles", 0, *field), value))
    assert isinstance(err, InputError) and err.key.startswith("obstacles[0]."), err


def _deep(depth: int) -> bytes:
    return b"a = " + b"[" * depth + b"]" * depth


LOAD_BUGS = [
    pytest.param(_deep(1000), id="B4-nested-arrays"),
    pytest.param(b"a = 1" + b"0" * 4300, id="B8-long-integer"),
    pytest.param(None, id="B5-folder"),
]  # fmt: skip


@pytest.mark.parametrize("content", LOAD_BUGS)
def test_load_scenario_known_bad_files(tmp_path, content):
    path = tmp_path / "scenario.toml"
    path.mkdir() if content is None else path.write_bytes(content)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    _check_error(info.value, None)


# -- the roundabout example: [roundabout], [[roundabout.legs]], [route], [vehicle.body] ----------
@ROADS
@given(mutated(bases=ROAD))
def test_mutated_roundabout_file_parses_or_raises_one_input_error(doc):
    _outcome(doc)


ROAD_DOC = ROAD["roundabout-truck.toml"]
R1 = "R1: roundabout lengths and coordinates have no upper bound; {} in the road geometry"
ROAD_BUGS = [
    pytest.param(("roundabout", "inscribed_diameter"), 1e15, id="R1-diameter-1e15"),
    pytest.param(("roundabout", "inscribed_diameter"), 1e300, id="R1-diameter-1e300"),
    pytest.param(("roundabout", "center", 0), 1e15, id="R1-center-1e15"),
    pytest.param(("roundabout", "center", 0), 1e300, id="R1-center-1e300"),
]  # fmt: skip


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # shapely's, on the way to the exception
@pytest.mark.parametrize("path, value", ROAD_BUGS)
def test_r1_roundabout_sizes_far_beyond_a_roundabout(path, value):
    _outcome(_set(ROAD_DOC, path, value))


# -- 2. end to end: `roundabout check` ------------------------------------------------------
def _toml_string(text: str) -> str:
    escaped = "".join(
        "\\" + c if c in '"\\' else c if c.isprintable() and c != "\x7f" else f"\\U{ord(c):08X}" for c in text
    )
    return f'"{escaped}"'


def _toml(value: Any) -> str:
    """A TOML inline value (tables inline, so a document is one ``key = value`` line per top key)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)  # inf, -inf, 1e+300: TOML spellings too
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, datetime | date | time):
        return value.isoformat()
    if isinstance(value, list):
        return "[" + ", ".join(map(_toml, value)) + "]"
    return "{" + ", ".join(f"{_toml_key(k)} = {_toml(v)}" for k, v in value.items()) + "}"


def _toml_key(key: str) -> str:
    return key if key and set(key) <= set(BARE_CHARS) else _toml_string(key)


def _dumps(doc: dict) -> str:
    return "".join(f"{_toml_key(k)} = {_toml(v)}\n" for k, v in doc.items())


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(map(_same, a, b))
    return type(a) is type(b) and a == b


def _check(content: bytes | None) -> subprocess.CompletedProcess:
    """``roundabout check`` on a file with ``content`` (None: a folder in its place)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.toml"
        path.mkdir() if content is None else path.write_bytes(content)
        return subprocess.run(
            [sys.executable, "-m", "model.cli", "check", str(path)], capture_output=True, text=True, cwd=ROOT
        )


def _assert_contract(res: subprocess.CompletedProcess) -> None:
    assert res.returncode in (0, 2), res.stderr
    assert "Traceback" not in res.stderr, res.stderr
    if res.returncode == 0:
        assert res.stderr == "", res.stderr
    else:
        assert res.stdout == "", res.stdout
        assert res.stderr.startswith("roundabout: invalid input: "), res.stderr
        assert res.stderr.count("\n") == 1 and res.stderr.endswith("\n"), res.stderr


def test_dumps_writes_what_tomllib_reads():
    doc = {
        **_set(EXAMPLE, ("obstacles", 0, "radius"), math.nan),
        "a b": {"c\n": [datetime(2000, 1, 2, 3, 4), -math.inf]},
    }
    assert _same(tomllib.loads(_dumps(doc)), doc)


@CLI
@given(mutated())
def test_cli_check_on_mutated_files_exits_0_or_2_with_one_line(doc):
    text = _dumps(doc)
    assert _same(tomllib.loads(text), doc)  # the file says what the property is about
    res = _check(text.encode())
    _assert_contract(res)
    assert res.returncode == (0 if isinstance(_outcome(doc), Scenario) else 2), res.stderr


@_settings(5)
@given(BYTES)
def test_cli_check_on_arbitrary_bytes_exits_0_or_2_with_one_line(content):
    _assert_contract(_check(content))


CLI_BUGS = [
    pytest.param(_dumps(HUGE_GAP).encode(), id="B6-exit-2-three-lines"),
    pytest.param(_dumps(INF_RADIUS).encode(), id="B6-exit-0-warnings"),
    pytest.param(None, id="B5-folder"),
]  # fmt: skip


@pytest.mark.parametrize("content", CLI_BUGS)
def test_cli_check_known_bad_files(content):
    _assert_contract(_check(content))
