"""``python -m model.cli``: the ``roundabout`` command."""

from model.cli import run

run()
