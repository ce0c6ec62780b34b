"""Analyses of the study's results: summary tables, the inference of the paper's unstated
setup, the experiments beyond the paper, and the claims.

Imports the layers below it, never :mod:`uavwind.report`.
"""
