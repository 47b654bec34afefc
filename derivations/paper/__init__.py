"""The seed paper's claims, checked case by case against the Pontryagin engine.

``python -m derivations.paper.report --out DIR`` writes ``claims.json`` and ``report.md``.
This package imports the engine (``derivations``) and the problem definition; nothing
in the engine or the solver imports it.
"""
