"""A payload added as one module (the bilge pump fixture, :mod:`tests.payloads.bilge_pump`):
its command, servo output, sentence and dialect entry work end to end, and nothing else of the
companion names it."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import pytest

from companion.link.dialect import mav
from companion.payloads.registry import PayloadRegistry, built_in_payloads, merged_dialect
from companion.runtime import build_context
from companion.sensors.nmea import build
from mavlink_dialect.generate import generate_source
from tests.mavlink.helpers import make_ctx
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs
from tests.payloads import bilge_pump
from tests.payloads.bilge_pump import CMD_BILGE_PUMP

REPO = Path(__file__).resolve().parents[2]
BILGE_OUTPUT = 2


async def test_bilge_pump_command_ack_and_pulse_at_the_simulator() -> None:
    async with sitl_with_gcs(extra_payloads=[bilge_pump.PAYLOAD]) as (h, gcs):
        assert h.ctx.params.get("USV_CH_BILGE") == BILGE_OUTPUT  # its parameter joined the table
        await h.run_for(0.5)
        assert h.boat.pulses[BILGE_OUTPUT - 1] == 1100  # off
        ack = await run_until_done(h, gcs.command(CMD_BILGE_PUMP, 1))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(0.3)
        assert h.boat.pulses[BILGE_OUTPUT - 1] == 1900  # USV_SW_PWM_ON, seen by the simulator
        # the output is the pump's now: a ground station cannot override it, the relay neither
        text_wait = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Set servo" in m.text))
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_SERVO, BILGE_OUTPUT, 1500))
        assert ack.result == mav.MAV_RESULT_DENIED
        assert (await run_until_done(h, text_wait)).text == "Set servo 2 refused: bilge pump"
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_RELAY, 0, 0))
        assert ack.result == mav.MAV_RESULT_DENIED
        # a bad parameter is refused with a reason, the pump stays on
        text_wait = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "bilge pump:" in m.text))
        ack = await run_until_done(h, gcs.command(CMD_BILGE_PUMP, 5))
        assert ack.result == mav.MAV_RESULT_DENIED
        assert "param1 must be 1 (on) or 0 (off)" in (await run_until_done(h, text_wait)).text
        ack = await run_until_done(h, gcs.command(CMD_BILGE_PUMP, 0))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await h.run_for(0.3)
        assert h.boat.pulses[BILGE_OUTPUT - 1] == 1100
        # its sentence reaches it through the companion's GPS-INS parser
        assert h.hardware is not None and h.services is not None
        h.hardware.parser.feed(build("PUSVB,12.5"))
        assert h.services.payloads.device("bilge_pump").level_cm == 12.5


async def test_without_the_module_the_command_is_unsupported_and_the_output_free() -> None:
    async with sitl_with_gcs() as (h, gcs):
        ack = await run_until_done(h, gcs.command(CMD_BILGE_PUMP, 1))
        assert ack.result == mav.MAV_RESULT_UNSUPPORTED
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_SERVO, BILGE_OUTPUT, 1500))
        assert ack.result == mav.MAV_RESULT_ACCEPTED


def test_its_dialect_fragment_merges_into_a_valid_dialect(tmp_path: Path) -> None:
    registry = PayloadRegistry(make_ctx(tmp_path), (*built_in_payloads(), bilge_pump.PAYLOAD))
    merged = tmp_path / "usv.xml"
    merged.write_text(registry.dialect_xml(), encoding="utf-8")
    module = generate_source(merged)  # mavgen with schema validation, as for the shipped dialect
    assert "USV_CMD_BILGE_PUMP = 31020" in module
    assert "MAVLINK_MSG_ID_USV_LAUNCHER_STATUS = 43000" in module  # the shipped dialect is all there


def test_a_payload_without_its_dialect_entry_is_refused(tmp_path: Path) -> None:
    import dataclasses

    from companion.payloads.registry import DialectEntries, PayloadDef, PayloadError

    def build_without_xml(env):  # type: ignore[no-untyped-def]
        return dataclasses.replace(bilge_pump.build(env), dialect=DialectEntries(
            commands={CMD_BILGE_PUMP: "USV_CMD_BILGE_PUMP"}))

    broken = PayloadDef("bilge_pump", bilge_pump.PARAMS, build_without_xml)
    with pytest.raises(PayloadError, match="31020 USV_CMD_BILGE_PUMP is not in USV_CMD"):
        PayloadRegistry(make_ctx(tmp_path), (broken,))
    assert merged_dialect([bilge_pump.DIALECT_XML]).find("enums") is not None


def test_nothing_outside_its_module_names_it() -> None:
    """Adding the payload edited no file of the product: its names appear only in its module
    (and in this test)."""
    hits = []
    for top in ("companion", "sim_bridge", "mavlink_dialect", "benchmarks", "missions", "tests"):
        for path in (REPO / top).rglob("*"):
            if path.suffix in (".py", ".xml", ".toml", ".md", ".json") and path.is_file():
                text = path.read_text(encoding="utf-8", errors="replace").lower()
                if "bilge" in text or "31020" in text:
                    hits.append(path.relative_to(REPO).as_posix())
    assert sorted(hits) == ["tests/payloads/bilge_pump.py", "tests/payloads/test_bilge_pump.py"], hits


def test_build_context_takes_the_payload_parameters(tmp_path: Path) -> None:
    from companion.clock import SimClock
    from companion.config import default_config

    config = default_config().with_overrides({"vehicle.state_dir": str(tmp_path)})
    assert "USV_CH_BILGE" not in build_context(config, SimClock()).params
    assert "USV_CH_BILGE" in build_context(config, SimClock(), [bilge_pump.PAYLOAD]).params
    assert sys.modules["tests.payloads.bilge_pump"] is bilge_pump
