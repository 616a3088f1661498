"""DO_SET_SERVO / DO_SET_RELAY reach the simulated boat's servo input on free outputs only.

Lockstep SITL with the full companion stack; a ground station on loopback UDP sends the
commands; the assertions read what the simulator received (its latest ``$PUSVS`` frame) and
SERVO_OUTPUT_RAW.  Autopilot-owned outputs (nozzle, throttle, valve, ignition, selector,
launcher trigger, pump) are refused with the function's name and the frame does not change.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from companion.actuators.servo import ServoMap
from companion.link.dialect import mav
from companion.messages import ActuatorCommand
from companion.payloads.registry import PayloadRegistry, built_in_payloads
from tests.mavlink.helpers import make_ctx
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs

pytestmark = pytest.mark.integration

SERVO_OUTPUT_RAW = 36


async def test_set_servo_and_relay_drive_the_free_output() -> None:
    async with sitl_with_gcs() as (h, gcs):
        await run_until_done(h, gcs.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, SERVO_OUTPUT_RAW, 50_000))
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_SERVO, 2, 1750))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(0.3)
        assert h.boat.pulses[1] == 1750  # what the simulator's servo input received
        raw = await run_until_done(h, gcs.wait("SERVO_OUTPUT_RAW", lambda m: m.servo2_raw == 1750))
        assert raw.servo7_raw == 1100 and raw.servo5_raw == 1100  # launcher safe, ignition off

        # Relay 0 is wired to channel 2 by default (USV_RLY0_CH): on/off pulses.
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_RELAY, 0, 1))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(0.3)
        assert h.boat.pulses[1] == 1900
        await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_RELAY, 0, 0))
        await h.run_for(0.3)
        assert h.boat.pulses[1] == 1100

        # 0 us releases the override: the output goes back to its idle pulse.
        await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_SERVO, 2, 0))
        await h.run_for(0.3)
        assert h.boat.pulses[1] == 1500


@pytest.mark.parametrize("channel,function", [
    (1, "nozzle (steering)"), (3, "throttle"), (4, "sampler valve"), (5, "ignition"), (6, "RC/GCS selector"),
    (7, "launcher trigger"), (8, "sampler pump"),
])
async def test_set_servo_on_owned_channel_refused_and_nothing_changes(channel: int, function: str) -> None:
    async with sitl_with_gcs() as (h, gcs):
        await h.run_for(0.5)
        before = h.boat.pulses
        text_wait = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Set servo" in m.text))
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_SERVO, channel, 1900))
        assert ack.result == mav.MAV_RESULT_DENIED
        text = await run_until_done(h, text_wait)
        assert text.text == f"Set servo {channel} refused: {function}"
        await h.run_for(1.0)  # long enough for a launcher trigger to register (0.2 s hold)
        assert h.boat.pulses == before
        assert h.launcher.events == [] and h.sampler.bottles_ml == [0.0] * 4
        assert not h.plant.state.engine_running


async def test_relay_rewired_to_launcher_is_refused() -> None:
    async with sitl_with_gcs(params={"USV_RLY1_CH": 7}) as (h, gcs):
        text_wait = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Set relay" in m.text))
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_RELAY, 1, 1))
        assert ack.result == mav.MAV_RESULT_DENIED
        text = await run_until_done(h, text_wait)
        assert text.text == "Set relay 1 refused: ch 7 launcher trigger"
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_RELAY, 2, 1))
        assert ack.result == mav.MAV_RESULT_DENIED  # relay 2 is not wired by default
        await h.run_for(1.0)
        assert h.boat.pulses[6] == 1100 and h.launcher.events == []


def test_servo_map_drops_override_when_channel_becomes_owned(tmp_path: Path) -> None:
    ctx = make_ctx(tmp_path)
    params = ctx.params
    servo_map = ServoMap(params, PayloadRegistry(ctx, built_in_payloads()).servo_channels)
    servo_map.overrides_us = {2: 1800}
    cmd = ActuatorCommand(t_s=0.0)
    assert servo_map.pulses(cmd)[1] == 1800
    params.set("USV_CH_PUMP", 2, persist=False)  # the pump is rewired to output 2
    assert servo_map.pulses(cmd)[1] == 1100  # pump off, not the stale override
