"""The one exception for invalid input: it names the offending key."""

from __future__ import annotations


class InputError(ValueError):
    """Invalid problem data; ``key`` is the dotted scenario key at fault."""

    def __init__(self, key: str, message: str):
        self.key = key
        self.message = message
        super().__init__(f"{key}: {message}" if key else message)
