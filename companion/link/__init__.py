"""MAVLink links: transports (UDP, TCP, serial), per-link codec and stream rates, telemetry logs."""
