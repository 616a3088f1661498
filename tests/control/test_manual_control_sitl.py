"""MAVLink MANUAL_CONTROL from a ground station drives MANUAL and steers CRUISE (lockstep SITL).

The ground station (the asyncio test GCS on loopback UDP) sends MANUAL_CONTROL at 20 Hz of
simulated time from a control-loop stage, as a joystick ground station does; the boat is the
full companion stack against the simulated plant.  Asserted at the plant and at the servo pulses
the simulator receives: MANUAL turns the boat the way the stick says, CRUISE moves its held
heading, and when the ground station goes quiet MANUAL returns the outputs to throttle idle and
nozzle centred.  Unit tests of the axis scaling are at the end.
"""

from __future__ import annotations

import math

import pytest

from companion.bus import Bus
from companion.control.manual_input import (
    AXIS_UNUSED,
    from_manual_control,
    pilot_input,
    rc_steering,
    rc_throttle,
)
from companion.link.dialect import mav
from companion.messages import (
    MANUAL_CONTROL_TOPIC,
    NAV_TOPIC,
    RC_IN_TOPIC,
    ModeNumber,
    NavState,
    RcInput,
)
from sim_bridge.simboat import CH_NOZZLE, CH_THROTTLE
from sim_bridge.sitl import SitlHarness
from tests.mavlink.gcs import AsyncGcs
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs

pytestmark = pytest.mark.integration

MODE_MANUAL, MODE_CRUISE = ModeNumber.MANUAL, ModeNumber.CRUISE


class Joystick:
    """Sends MANUAL_CONTROL(y, z) every 0.05 s of simulated time while ``on``."""

    def __init__(self, h: SitlHarness, gcs: AsyncGcs, target: int = 1) -> None:
        self.gcs, self.target = gcs, target
        self.on, self.y, self.z = True, 0, 0
        self._next_s = 0.0
        h.ctx.bus.topic(NAV_TOPIC).add_listener(self._stage)  # a joystick on simulated time

    def _stage(self, nav: NavState) -> None:
        if self.on and nav.t_s >= self._next_s:
            self._next_s = nav.t_s + 0.05
            self.gcs.send(mav.MAVLink_manual_control_message(self.target, 0, self.y, self.z, 0, 0))


def _heading_deg(h: SitlHarness) -> float:
    return math.degrees(h.plant.state.psi_rad)


def _turned_deg(before: float, after: float) -> float:
    return math.degrees(math.remainder(math.radians(after - before), 2 * math.pi))


async def test_manual_control_drives_manual_mode_and_goes_safe_when_the_gcs_goes_quiet() -> None:
    async with sitl_with_gcs(seed=4, params={"FS_GCS_ENABLE": 0}) as (h, gcs):
        stick = Joystick(h, gcs)
        await h.run_for(1.0)
        vehicle = h.services.vehicle
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        assert vehicle.set_mode(MODE_MANUAL) is None
        stick.y, stick.z = 0, 600  # straight ahead, 60 % throttle
        await h.run_for(8.0)
        assert h.plant.state.u_mps > 2.0
        psi0 = _heading_deg(h)
        await h.run_for(2.0)
        assert abs(_turned_deg(psi0, _heading_deg(h))) < 15.0  # stick centred: no turn
        stick.y = 500  # half right
        await h.run_for(0.5)
        psi0 = _heading_deg(h)
        await h.run_for(2.0)
        assert h.plant.state.r_radps > math.radians(5.0)
        assert _turned_deg(psi0, _heading_deg(h)) > 20.0
        stick.y = -500  # half left
        await h.run_for(1.5)
        psi0 = _heading_deg(h)
        await h.run_for(2.0)
        assert _turned_deg(psi0, _heading_deg(h)) < -20.0
        assert h.boat.pulses[CH_THROTTLE] > 1500  # the throttle stick reaches the servo
        # a target for another vehicle is ignored: the boat keeps the last input for now
        stick.target = 7
        await h.run_for(0.5)
        assert h.boat.pulses[CH_THROTTLE] > 1500
        # ground station silent for longer than USV_MAN_TIMEOUT: outputs go safe
        stick.on = False
        await h.run_for(h.ctx.params.get("USV_MAN_TIMEOUT") + 1.0)
        assert h.boat.pulses[CH_THROTTLE] == 1100
        assert h.boat.pulses[CH_NOZZLE] == 1500
        assert vehicle.armed
        # (the simulated RC transmitter is at idle, so the receiver takes over with safe sticks)
        texts = [m.text for m in gcs.received if m.get_type() == "STATUSTEXT"]
        assert any("ground-station input lost" in t for t in texts)


async def test_manual_control_steers_the_held_heading_of_cruise() -> None:
    async with sitl_with_gcs(seed=5, psi0_deg=0.0, params={"FS_GCS_ENABLE": 0}) as (h, gcs):
        stick = Joystick(h, gcs)
        await h.run_for(1.0)
        vehicle = h.services.vehicle
        assert vehicle.arm() is None
        assert vehicle.set_mode(MODE_CRUISE) is None
        vehicle.speed_override_mps = 3.0
        await h.run_for(10.0)
        psi0 = _heading_deg(h)
        assert abs(_turned_deg(0.0, psi0)) < 5.0  # stick centred: holds the entry heading
        stick.y = 1000  # full right: the held heading turns at USV_TURN_MAX
        await h.run_for(1.0)
        stick.y = 0
        await h.run_for(8.0)  # settle on the new held heading
        new_deg = _turned_deg(psi0, _heading_deg(h))
        turn_max = h.ctx.params.get("USV_TURN_MAX")
        assert 0.6 * turn_max < new_deg < 1.4 * turn_max
        mode = vehicle.modes.current
        assert mode.number == MODE_CRUISE
        assert abs(_turned_deg(math.degrees(mode.heading_rad), _heading_deg(h))) < 5.0  # type: ignore[attr-defined]
        # the ground station stops: CRUISE keeps the heading it was given
        stick.on = False
        await h.run_for(5.0)
        assert abs(_turned_deg(psi0 + new_deg, _heading_deg(h))) < 6.0
        assert h.plant.state.u_mps > 2.0


def test_manual_control_axes_follow_ardurover() -> None:
    m = from_manual_control(1.0, 500, 1000)
    assert (m.steering, m.throttle) == (0.5, 1.0)
    m = from_manual_control(1.0, -2000, -300)  # out of range clipped; no reverse on a jet
    assert (m.steering, m.throttle) == (-1.0, 0.0)
    m = from_manual_control(1.0, AXIS_UNUSED, AXIS_UNUSED)
    assert (m.steering, m.throttle) == (None, None)
    assert from_manual_control(1.0, 20, 0).steering == 0.0  # deadband


def test_rc_sticks() -> None:
    assert rc_steering((1900, 1500, 1100)) == 1.0
    assert rc_throttle((1500, 1500, 1900)) == 1.0
    assert rc_throttle((1500, 1500, 1100)) == 0.0
    assert rc_steering((3000, 1500, 1100)) is None  # invalid pulse width
    assert rc_throttle((1500,)) is None  # channel missing


def test_fresh_ground_station_input_wins_then_the_receiver_then_nothing() -> None:
    bus = Bus()
    bus.topic(MANUAL_CONTROL_TOPIC).publish(from_manual_control(10.0, -400, 500))
    bus.topic(RC_IN_TOPIC).publish(RcInput(10.5, (1900, 1500, 1500)))
    gcs = pilot_input(bus, 10.8, timeout_s=1.0)
    assert gcs is not None and (gcs.source, gcs.steering, gcs.throttle) == ("gcs", -0.4, 0.5)
    rc = pilot_input(bus, 11.2, timeout_s=1.0)
    assert rc is not None and (rc.source, rc.steering, rc.throttle) == ("rc", 1.0, 0.5)
    assert pilot_input(bus, 11.6, timeout_s=1.0) is None
