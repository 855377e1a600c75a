"""hydrohil: hybrid valve-cylinder models, identification and real-time HIL simulation of hydraulic systems."""

__version__ = "0.1.0"
