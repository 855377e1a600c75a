"""Physical models: valve, cylinder, friction, the hybrid statechart, the continuous reference and the
linearised model (SPEC §3-§7)."""
