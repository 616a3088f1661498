"""The hardware seam: GPS-INS sentences in, one servo frame per sample out, same parser everywhere."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from companion.actuators.servo import ServoMap, decode_frame, encode_frame
from companion.bus import Bus
from companion.clock import SimClock
from companion.messages import (
    ENGINE_TOPIC,
    PAYLOAD_SENSORS_TOPIC,
    RC_IN_TOPIC,
    ActuatorCommand,
    NavState,
)
from companion.param_table import all_param_defs
from companion.params import ParamStore
from companion.sensors.gpsins import GpsInsParser
from companion.sensors.nmea import LineFramer, build, checksum

REAL_GPFPD = (b"$GPFPD,2168,370484.000,353.425,0.452,0.079,28.17868576,112.94064199,36.06,0.018,-0.023,"
              b"-0.041,0.974,11,10,04*4E\r\n")
REAL_GTIMU = b"$GTIMU,2168,370484.000,-0.0993,0.2741,-0.0604,-0.0012,0.0078,0.9957,41.0*48\r\n"


def parser() -> tuple[GpsInsParser, list[tuple[NavState, str]], Bus]:
    got: list[tuple[NavState, str]] = []
    bus = Bus()
    return GpsInsParser(SimClock(), bus, lambda nav, ack: got.append((nav, ack))), got, bus


def test_parses_a_device_sentence_pair_with_its_published_checksums() -> None:
    p, got, _ = parser()
    p.feed(REAL_GTIMU + REAL_GPFPD)
    assert p.errors == 0 and len(got) == 1
    nav, ack = got[0]
    assert ack == "370484.000"
    assert nav.heading_rad == pytest.approx(math.radians(353.425))
    assert nav.lat_deg == pytest.approx(28.17868576) and nav.lon_deg == pytest.approx(112.94064199)
    assert nav.vel_east_mps == pytest.approx(0.018) and nav.vel_north_mps == pytest.approx(-0.023)
    assert nav.r_radps == pytest.approx(math.radians(0.0604))  # clockwise = -GyroZ
    assert not nav.position_valid  # status 04: no GNSS position bit in our status map


def test_sentences_split_across_reads_are_reassembled() -> None:
    p, got, _ = parser()
    data = REAL_GTIMU + REAL_GPFPD
    for i in range(0, len(data), 7):
        p.feed(data[i:i + 7])
    assert len(got) == 1 and p.errors == 0


@pytest.mark.parametrize("junk", [
    REAL_GPFPD.replace(b"*4E", b"*4F"),              # bad checksum
    b"\x00\xff\xfe garbage without framing\r\n",
    b"$GPFPD,1,2,3*" + b"%02X" % checksum(b"GPFPD,1,2,3") + b"\r\n",  # good checksum, missing fields
    build("GPFPD,2168,1.0,abc,0,0,28,112,0,0,0,0,1,1,1,0B"),          # non-numeric heading
    b"$" + b"A" * 500 + b"\r\n",
])
def test_bad_input_is_counted_and_dropped_and_the_next_sentence_still_parses(junk: bytes) -> None:
    p, got, _ = parser()
    p.feed(junk)
    assert p.errors >= 1 and got == []
    p.feed(REAL_GPFPD)
    assert len(got) == 1


def test_engine_payload_and_rc_sentences_reach_the_bus() -> None:

    p, _, bus = parser()
    p.feed(build("PUSVE,4200,1") + build("PUSVP,29.50,0,0.0,120.0,0.0,0.0,1,2")
           + build("PUSVRC,0,1500,1500,1100,1500,1100,1900,1100,1100"))
    eng = bus.topic(ENGINE_TOPIC).latest()
    assert eng is not None and eng.rpm == 4200 and eng.running
    pay = bus.topic(PAYLOAD_SENSORS_TOPIC).latest()
    assert pay is not None and pay.cylinder_pressure_mpa == 29.5 and pay.bottle_volume_ml[1] == 120.0
    rc = bus.topic(RC_IN_TOPIC).latest()
    assert rc is not None and rc.source == 0 and rc.channels_us[5] == 1900


def test_servo_map_uses_the_channel_and_pulse_parameters() -> None:
    params = ParamStore(all_param_defs())
    smap = ServoMap(params)
    full_stbd = smap.pulses(ActuatorCommand(0.0, nozzle_rad=math.pi / 2, throttle=1.0, ignition_on=True))
    assert full_stbd[0] == 1900 and full_stbd[2] == 1900 and full_stbd[4] == 1900
    half_port = smap.pulses(ActuatorCommand(0.0, nozzle_rad=-math.pi / 6))
    assert half_port[0] == 1300 and half_port[2] == 1100 and half_port[4] == 1100
    params.set("USV_CH_NOZZLE", 2, persist=False)
    params.set("USV_NOZ_REV", 1, persist=False)
    moved = smap.pulses(ActuatorCommand(0.0, nozzle_rad=-math.pi / 6))
    assert moved[1] == 1700
    frame = decode_frame(LineFramer().feed(encode_frame("12.340", moved))[0])
    assert frame is not None and frame.ack == "12.340" and frame.pulse_us == moved


@given(st.binary(max_size=300))
def test_word_wise_checksum_is_the_nmea_xor_of_every_byte(body: bytes) -> None:
    expected = 0
    for b in body:
        expected ^= b
    assert checksum(body) == expected
