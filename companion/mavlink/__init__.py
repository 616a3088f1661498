"""The vehicle's MAVLink services: commands, parameters, missions, telemetry."""
