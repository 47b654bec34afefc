"""Figures and results files: the pipeline's plots, shared by rules, notebooks and tests.

Imports matplotlib (Agg) and pandas; reads results folders, never runs a solver.
"""
