"""MANUAL (Rover 0): the RC transmitter or MAVLink MANUAL_CONTROL drives nozzle and throttle.

Minimal version from the MAVLink issue so arming and mode changes work end to end; the
guidance/control issue owns the behaviour (passthrough of MANUAL_CONTROL).
"""

from __future__ import annotations

from companion.modes.base import Mode


class ManualMode(Mode):
    number = 0
    name = "MANUAL"
    standard_mode = None
    description = "Manual: RC or MANUAL_CONTROL input goes straight to nozzle and throttle."
    manual_input = True
