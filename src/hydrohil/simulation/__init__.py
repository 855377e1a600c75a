"""Running the models: compiled loops, per-step plant API, scenarios and their outputs."""
