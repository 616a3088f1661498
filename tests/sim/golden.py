"""Bit-exact fingerprints of the simulated boat, to keep speed work behaviour-neutral.

:func:`fingerprint` runs a :class:`~sim_bridge.simboat.SimulatedBoat` for a few simulated
seconds under one :data:`SETTINGS` entry (disturbances, payload, GPS-INS rate and faults),
answers every sample with a scripted ``$PUSVS`` servo frame as the companion would, feeds
the sensor bytes through the companion's :class:`~companion.sensors.gpsins.GpsInsParser`,
and hashes (SHA-256) everything a user or a figure could see: every byte the GPS-INS
writes, the plant's true state after every step (the floats' bits), every message the
parser publishes (``repr``: shortest round-trip floats) and the payloads' end state.

``tests/sim/data/golden_sim.json`` holds the fingerprints of the simulator as of main
08b0103 (before the simulator speed work); ``tests/sim/test_golden.py`` checks them.  A
change that moves any float of the plant, the noise, the sentence formatting or the
parser changes a fingerprint.  If a change is *meant* to alter the simulation (new
physics), regenerate them with ``python -m tests.sim.golden --write`` and say so in the
commit: every ``usv bench`` figure that flies the simulator will move with it.

Bit-exact floats depend on the platform (numpy's and numba's versions pick different
implementations of sin, exp, ...; numpy dispatches on the CPU's vector extensions), so the
file also records :func:`platform_key`, and the test compares only on the same platform
(elsewhere it is skipped, saying so).
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

from companion.actuators.servo import encode_frame
from companion.bus import Bus
from companion.clock import SimClock
from companion.messages import ENGINE_TOPIC, PAYLOAD_SENSORS_TOPIC, RC_IN_TOPIC
from companion.sensors.gpsins import GpsInsParser
from sim_bridge.disturbances import spec_from_strings
from sim_bridge.hull import BoatParams
from sim_bridge.simboat import SimulatedBoat

GOLDEN_PATH = Path(__file__).with_name("data") / "golden_sim.json"


@dataclass(frozen=True)
class Setting:
    seed: int
    wind: str = "0,0"
    current: str = "0,0"
    waves: str = "0"
    payload_kg: float = 0.0
    gnss_rate_hz: int = 100
    psi0_rad: float = 0.0
    steps: int = 2000
    faults: dict[str, tuple[int, int, float]] = field(default_factory=dict)
    """fault name -> (first step, last step, value while active)."""
    rc_override_steps: tuple[int, int] = (-1, -1)


SETTINGS: dict[str, Setting] = {
    "calm": Setting(seed=1),
    "storm": Setting(seed=2, wind="6,90", current="0.8,45", waves="0.3,3", payload_kg=40.0),
    "river": Setting(seed=3, current="1.2,200,0.3", waves="0.2,2.5,30", psi0_rad=1.0,
                     faults={"gps_outage": (500, 700, 1.0), "heading_bias_deg": (900, 1100, 1.5),
                             "corrupt_fraction": (0, 2000, 0.02), "gyro_stuck": (1500, 1550, 1.0)},
                     rc_override_steps=(1200, 1300)),
    "slow_gnss_wind": Setting(seed=4, wind="9,200", gnss_rate_hz=10, payload_kg=70.0, steps=1500),
}


def scripted_pulses(i: int) -> tuple[int, ...]:
    """The servo frame a companion might send at step ``i``: nozzle sweep, throttle steps up to planing speed,
    engine on, companion selected, one launcher trigger, the pump filling bottle 1."""
    t = 0.01 * i
    nozzle = 1500 + round(380.0 * math.sin(0.6 * t) * math.cos(0.13 * t))
    throttle = 1100 + (300 if t < 4.0 else 800 if t < 14.0 else 500)
    valve = 1200 if 1400 <= i < 1600 else 1000
    launcher = 1900 if 1000 <= i < 1030 else 1100
    pump = 1900 if 1400 <= i < 1600 else 1100
    return (nozzle, 1500, throttle, valve, 1900, 1900, launcher, pump)


def fingerprint(name: str) -> str:
    s = SETTINGS[name]
    boat = SimulatedBoat(seed=s.seed, disturbances=spec_from_strings(s.wind, s.current, s.waves),
                         params=BoatParams().with_payload(s.payload_kg), psi0_rad=s.psi0_rad,
                         gnss_rate_hz=s.gnss_rate_hz, start_unix_s=1_700_000_000.0)
    h = hashlib.sha256()
    clock = SimClock(start_unix_time_s=1_700_000_000.0)
    bus = Bus()

    def seen(msg: object) -> None:
        h.update(repr(msg).encode())

    bus.topic(ENGINE_TOPIC).add_listener(seen)
    bus.topic(RC_IN_TOPIC).add_listener(seen)
    bus.topic(PAYLOAD_SENSORS_TOPIC).add_listener(seen)
    parser = GpsInsParser(clock, bus, lambda nav, ack: h.update(f"{nav!r}|{ack}".encode()))
    pack = struct.Struct("<14d").pack
    for i in range(s.steps):
        for fault, (first, last, value) in s.faults.items():
            active = first <= i <= last
            kind = type(getattr(boat.faults, fault))
            setattr(boat.faults, fault, kind(value) if active else kind(0))
        boat.rc.override = s.rc_override_steps[0] <= i < s.rc_override_steps[1]
        boat.rc.nozzle_rad, boat.rc.throttle, boat.rc.ignition_on = -0.4, 0.5, True
        data = boat.sample()
        h.update(data)
        parser.feed(data)
        boat.receive(encode_frame(boat.pending or "", scripted_pulses(i)))
        boat.advance()
        clock.advance_to(boat.t_s)
        st = boat.plant.state
        h.update(pack(st.t_s, st.north_m, st.east_m, st.psi_rad, st.u_r_mps, st.v_r_mps, st.r_radps,
                      st.u_mps, st.v_mps, st.u_dot_mps2, st.v_dot_mps2, st.engine_rpm, st.nozzle_rad,
                      st.thrust_n))
        h.update(b"1" if st.engine_running else b"0")
    h.update(repr((boat.launcher.events, boat.launcher.buoys, boat.sampler.bottles_ml, boat.frames_received,
                   boat.bad_frames, parser.errors, parser.nav_samples)).encode())
    return h.hexdigest()


PLATFORM_KEY = "_platform"


def platform_key() -> dict[str, str]:
    """What bit-exact simulator output depends on besides the code."""
    import numba
    import numpy

    try:
        from numpy._core._multiarray_umath import __cpu_features__ as cpu  # numpy >= 2
    except ImportError:  # pragma: no cover - numpy 1.x
        from numpy.core._multiarray_umath import __cpu_features__ as cpu
    simd = "avx512" if cpu.get("AVX512F") else "avx2" if cpu.get("AVX2") else "baseline"
    return {"python": ".".join(platform.python_version_tuple()[:2]), "machine": platform.machine(),
            "numpy": numpy.__version__, "numba": numba.__version__, "simd": simd}


def main(argv: list[str]) -> int:
    digests: dict[str, object] = {name: fingerprint(name) for name in SETTINGS}
    digests[PLATFORM_KEY] = platform_key()
    if "--write" in argv:
        GOLDEN_PATH.write_text(json.dumps(digests, indent=2) + "\n", encoding="utf-8")
        print(f"wrote {GOLDEN_PATH}")
    else:
        print(json.dumps(digests, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
