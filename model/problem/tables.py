"""Reading TOML tables with one clear error per bad key (InputError naming the dotted key)."""

from __future__ import annotations

import math
import re
from typing import Any

from model.errors import InputError


def table_of(data: dict[str, Any], key: str) -> dict[str, Any]:
    val = data[key]
    if not isinstance(val, dict):
        raise InputError(key, f"must be a table ([{key}]), got {type(val).__name__}")
    return val


def numbers(table: dict[str, Any], where: str) -> dict[str, float]:
    return {k: number(table, k, where) for k in table}


def is_number(val: Any) -> bool:
    return isinstance(val, int | float) and not isinstance(val, bool)


def number(table: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    """``table[key]`` as a float; ``default`` when the key is absent (if given)."""
    if key not in table and default is not None:
        return default
    val = table[key]
    if not is_number(val):
        raise InputError(where + key, f"must be a number, got {val!r}")
    return float(val)


def string(table: dict[str, Any], key: str, default: str) -> str:
    val = table.get(key, default)
    if not isinstance(val, str):
        raise InputError(key, f"must be a string, got {val!r}")
    return val


def choice(table, key, options, where, required=False, default=None) -> str:
    if key not in table:
        if required:
            raise InputError(where + key, f"missing (one of {sorted(options)})")
        return default
    val = table[key]
    if not isinstance(val, str) or val not in options:
        raise InputError(where + key, f"must be one of {sorted(options)}, got {val!r}")
    return val


def no_unknown(table: dict[str, Any], allowed: set[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            hint = closest(key, allowed)
            raise InputError(where + key, "unknown key" + (f" (did you mean '{hint}'?)" if hint else ""))


def closest(key: str, allowed: set[str]) -> str | None:
    import difflib

    match = difflib.get_close_matches(key, sorted(allowed), n=1, cutoff=0.6)
    return match[0] if match else None


def array_of_tables(items: Any, key: str):
    """Yield (index, "key[i].", table) for a TOML array of tables, each checked to be a table."""
    if not isinstance(items, list):
        raise InputError(key, f"must be an array of tables ([[{key}]])")
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            raise InputError(f"{key}[{i}]", "must be a table")
        yield i, f"{key}[{i}].", item


BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")  # every key of the format is one; TOML allows any text quoted


def check_document(value: Any, where: str = "") -> None:
    """Refuse what the per-key checks cannot report on one line: quoted keys, integers beyond 64 bits."""
    if isinstance(value, dict):
        for key, val in value.items():
            path = f"{where}.{toml_key(key)}" if where else toml_key(key)
            if not BARE_KEY.fullmatch(key):
                raise InputError(path, "unknown key")
            check_document(val, path)
    elif isinstance(value, list):
        for i, val in enumerate(value):
            check_document(val, f"{where}[{i}]")
    elif isinstance(value, int) and not isinstance(value, bool) and not -(2**63) <= value < 2**63:
        raise InputError(where, "integer out of range (TOML integers are 64-bit)")


def toml_key(key: str) -> str:
    """``key`` as a TOML dotted key writes it: bare, or quoted with escapes so that it stays one line."""
    if BARE_KEY.fullmatch(key):
        return key
    body = "".join("\\" + c if c in '"\\' else c if c.isprintable() else f"\\U{ord(c):08X}" for c in key)
    return f'"{body}"'


def toml_value(value: Any, where: str = "") -> str:
    """One TOML value (string, boolean, number, array of them) as it is written on a line."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return '"' + "".join(_escaped(c) for c in value) + '"'
    if isinstance(value, list) and not any(isinstance(v, dict) for v in value):
        return "[" + ", ".join(toml_value(v, where) for v in value) + "]"
    raise ValueError(f"{where}: cannot write {type(value).__name__} as a TOML value")


def _escaped(c: str) -> str:
    if c in '"\\':
        return "\\" + c
    return c if c.isprintable() else f"\\U{ord(c):08X}"


def toml_text(document: dict[str, Any]) -> str:
    """A TOML document (nested dicts, arrays of tables) as text that ``tomllib`` reads back equal."""
    lines: list[str] = []
    _toml_table(document, "", lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _is_tables(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _toml_table(table: dict[str, Any], prefix: str, lines: list[str]) -> None:
    for key, value in table.items():
        if not isinstance(value, dict) and not _is_tables(value):
            lines.append(f"{toml_key(key)} = {toml_value(value, prefix + key)}")
    for key, value in table.items():
        name = f"{prefix}{toml_key(key)}"
        if isinstance(value, dict):
            lines += ["", f"[{name}]"]
            _toml_table(value, name + ".", lines)
        elif _is_tables(value):
            for item in value:
                lines += ["", f"[[{name}]]"]
                _toml_table(item, name + ".", lines)
