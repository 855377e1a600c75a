"""Code generated from the C core for dedicated hardware: an FMU (:mod:`hydrohil.export.fmu`)."""
