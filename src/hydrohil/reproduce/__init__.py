"""Reproduce the paper end to end (``hydrohil reproduce``): figures, paper-vs-hydrohil table, round trips."""

from hydrohil.reproduce.runner import STEPS, run_reproduce

__all__ = ["STEPS", "run_reproduce"]
