"""Fuzzing the GPS-INS parser (unit, hypothesis): hostile serial bytes never raise out of the
parser, and the next good sentence pair after them is still read, as it would be from a
GPS-INS whose line picked up noise."""

from __future__ import annotations

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.fuzz_frames import hostile_nmea
from companion.bus import Bus
from companion.clock import SimClock
from companion.guidance.geo import valid_lat_lon
from companion.messages import NavState
from companion.sensors.gpsins import GpsInsParser

REAL_GPFPD = (b"$GPFPD,2168,370484.000,353.425,0.452,0.079,28.17868576,112.94064199,36.06,0.018,-0.023,"
              b"-0.041,0.974,11,10,04*4E\r\n")
REAL_GTIMU = b"$GTIMU,2168,370484.000,-0.0993,0.2741,-0.0604,-0.0012,0.0078,0.9957,41.0*48\r\n"


@settings(max_examples=60, deadline=None)
@given(rngs=st.lists(st.randoms(use_true_random=False), min_size=1, max_size=12),
       chunk=st.integers(1, 64))
def test_hostile_gpsins_bytes_never_raise_and_good_sentences_still_parse(rngs: list[random.Random],
                                                                         chunk: int) -> None:
    got: list[tuple[NavState, str]] = []
    parser = GpsInsParser(SimClock(), Bus(), lambda nav, ack: got.append((nav, ack)))
    noise = b"".join(hostile_nmea(rng) for rng in rngs)
    data = noise + b"\r\n" + REAL_GTIMU + REAL_GPFPD
    for i in range(0, len(data), chunk):  # as the serial port delivers it, in pieces
        parser.feed(data[i:i + chunk])
    assert got, "the good sentence after the noise was lost"
    nav, ack = got[-1]
    assert ack == "370484.000" and nav.lat_deg == 28.17868576 and nav.lon_deg == 112.94064199
    for nav, _ in got:  # whatever the noise produced passed the parser's own range checks
        assert valid_lat_lon(nav.lat_deg, nav.lon_deg) and math.isfinite(nav.heading_rad)
