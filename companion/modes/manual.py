"""MANUAL (Rover 0): the pilot's sticks drive nozzle and throttle directly.

Pilot input (:mod:`companion.control.manual_input`) is MAVLink MANUAL_CONTROL from a ground
station (``y`` steering, ``z`` throttle, as ArduPilot Rover reads them) or, without a fresh one,
the RC receiver.  Steering -1..1 becomes the nozzle angle (+-USV_NOZ_MAX, positive = starboard),
throttle 0..1 the throttle, through the actuator limits and slew rates.  With no fresh input for
USV_MAN_TIMEOUT (the ground station went quiet and no receiver), or disarmed, the outputs go to
their safe state: throttle idle, nozzle centred (the boat then drifts).  A change of input
source (ground station lost, RC receiver taking over) is announced with a STATUSTEXT.
"""

from __future__ import annotations

import math

from companion.control.target import ControlRequest
from companion.messages import ModeNumber, NavState
from companion.modes.base import Mode
from companion.modes.host import ModeHost


class ManualMode(Mode):
    number = ModeNumber.MANUAL
    name = "MANUAL"
    standard_mode = None
    description = "Manual: RC or MANUAL_CONTROL input goes straight to nozzle and throttle."
    manual_input = True

    def __init__(self) -> None:
        super().__init__()
        self._source: str | None = None

    def enter(self, host: ModeHost) -> None:
        self._source = None
        host.control.reset()

    def update(self, host: ModeHost, nav: NavState) -> ControlRequest:
        inp = host.pilot_input()
        source = None if inp is None else inp.source
        if source != self._source and self._source is not None:
            lost = "ground-station input lost" if self._source == "gcs" else "RC input lost"
            then = "RC receiver in control" if source == "rc" else "throttle idle, nozzle centred"
            host.status(f"MANUAL: {lost}; {then}" if source != "gcs" else "MANUAL: ground-station input")
        self._source = source
        if inp is None or not host.armed:
            return ControlRequest.idle(ignition_on=host.armed)
        nozzle_max = math.radians(host.params.get("USV_NOZ_MAX"))
        return ControlRequest.direct(inp.steering * nozzle_max, inp.throttle, ignition_on=True)
