"""Hydraulic circuits from model descriptions (SPEC §12): a component library (library.py, core/components.h),
circuit files (circuit.py, units.py), the C generated for a circuit (generate.py), compiled and cached
(build.py), run at a fixed step (run.py), shown and plotted (show.py)."""
