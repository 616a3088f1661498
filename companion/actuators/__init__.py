"""Servo outputs: actuator commands in SI units -> pulse widths per channel -> servo frames."""
