"""Real-time hardware-in-the-loop runtime: wire protocol, plant server, controller client, orchestration."""
