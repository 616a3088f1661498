"""When a ground station counts as lost (:mod:`companion.link.gcs_presence`), on two fake clocks:
the vehicle clock (simulated seconds) and the wall clock, run at the ratios SITL runs them."""

from __future__ import annotations

import pytest

from companion.clock import SimClock
from companion.link.gcs_presence import GcsPresence

FS_GCS_TIMEOUT_S = 5.0
ENG_STOP_S = 120.0


class Clocks:
    """A vehicle clock running ``speedup`` times faster than a wall clock."""

    def __init__(self, speedup: float) -> None:
        self.vehicle, self.wall, self.speedup = SimClock(0.0), SimClock(0.0), speedup
        self.presence = GcsPresence(self.vehicle, self.wall)

    def run_wall(self, wall_s: float, *, speedup: float | None = None) -> None:
        rate = self.speedup if speedup is None else speedup
        self.wall.advance_to(self.wall.now_s() + wall_s)
        self.vehicle.advance_to(self.vehicle.now_s() + wall_s * rate)

    def lost_after_s(self, timeout_s: float, *, step_wall_s: float = 0.001,
                     speedup: float | None = None) -> float:
        """Vehicle seconds of silence until the station counts as lost for ``timeout_s``."""
        start_s = self.vehicle.now_s()
        silence = self.presence.silence()
        while silence is not None and not silence.exceeds(timeout_s):
            self.run_wall(step_wall_s, speedup=speedup)
            silence = self.presence.silence()
        return self.vehicle.now_s() - start_s


def test_wall_paced_station_at_10x_is_never_lost_between_heartbeats_and_lost_after_3_missed() -> None:
    c = Clocks(speedup=10.0)
    while c.vehicle.now_s() < 300.0:  # 1 Hz of wall time: every 10 simulated seconds
        c.presence.heard(heartbeat=True)
        c.run_wall(0.5)
        silence = c.presence.silence()
        assert silence is not None and not silence.exceeds(FS_GCS_TIMEOUT_S)
        c.run_wall(0.5)
        silence = c.presence.silence()
        assert silence is not None and not silence.exceeds(FS_GCS_TIMEOUT_S)
        assert silence.vehicle_s > FS_GCS_TIMEOUT_S  # vehicle time alone would have tripped
    c.presence.heard(heartbeat=True)
    assert abs(c.lost_after_s(FS_GCS_TIMEOUT_S) - 30.0) < 0.1  # 3 missed heartbeats = 3 wall s
    assert abs(c.lost_after_s(ENG_STOP_S) - 90.0) < 0.1  # 120 s of vehicle time in all


def test_station_paced_by_simulated_time_is_judged_by_simulated_time_even_if_the_sim_speeds_up() -> None:
    c = Clocks(speedup=25.0)
    for _ in range(20):  # a lockstep test's ground station: a heartbeat every simulated second
        c.presence.heard(heartbeat=True)
        c.run_wall(1.0 / 25.0)
    c.presence.heard(heartbeat=True)
    assert abs(c.lost_after_s(FS_GCS_TIMEOUT_S, speedup=60.0) - FS_GCS_TIMEOUT_S) < 0.1


@pytest.mark.parametrize("speedup", [1.0, 0.5])  # a boat (one clock), and a simulation slower than real time
@pytest.mark.parametrize("period_s", [1.0, 2.0, 0.2])  # also stations sending more slowly than 1 Hz
def test_when_the_vehicle_clock_is_not_faster_the_timeout_is_exact(speedup: float, period_s: float) -> None:
    c = Clocks(speedup=speedup)
    for _ in range(6):
        c.presence.heard(heartbeat=True)
        c.run_wall(period_s)
    c.presence.heard(heartbeat=True)
    assert abs(c.lost_after_s(FS_GCS_TIMEOUT_S) - FS_GCS_TIMEOUT_S) < 0.01


def test_manual_control_keeps_a_station_present_without_changing_its_heartbeat_period() -> None:
    c = Clocks(speedup=10.0)
    for _ in range(5):
        c.presence.heard(heartbeat=True)
        for _ in range(10):  # a joystick at 10 Hz of wall time between heartbeats
            c.run_wall(0.1)
            c.presence.heard(heartbeat=False)
    silence = c.presence.silence()
    assert silence is not None and silence.vehicle_s < 0.01
    assert abs(silence.period_wall_s - 1.0) < 1e-9 and abs(silence.period_vehicle_s - 10.0) < 1e-9
    assert abs(c.lost_after_s(FS_GCS_TIMEOUT_S) - 30.0) < 0.1


def test_never_heard_is_not_lost() -> None:
    assert Clocks(speedup=10.0).presence.silence() is None


def test_a_simulator_that_stalls_while_starting_then_catches_up_does_not_lose_a_1_hz_station() -> None:
    """``usv sitl --speedup 20`` on a loaded machine: the vehicle clock stands still for the first
    two wall seconds (heartbeats 0 vehicle-seconds apart look paced by the vehicle clock), then runs
    at 20x.  The station still sends its heartbeat every wall second and must never count as lost."""
    c = Clocks(speedup=20.0)
    for _ in range(3):  # stalled: heartbeats arrive, the vehicle clock does not move
        c.presence.heard(heartbeat=True)
        c.run_wall(1.0, speedup=0.0)
    while c.vehicle.now_s() < 300.0:
        c.presence.heard(heartbeat=True)
        for _ in range(10):
            c.run_wall(0.1, speedup=100.0 if c.vehicle.now_s() < 60.0 else 20.0)  # catching up, then 20x
            silence = c.presence.silence()
            assert silence is not None and not silence.exceeds(FS_GCS_TIMEOUT_S), c.vehicle.now_s()
    c.presence.heard(heartbeat=True)
    assert abs(c.lost_after_s(FS_GCS_TIMEOUT_S) - 60.0) < 0.1  # then silent: 3 wall s at 20x
