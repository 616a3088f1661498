"""Fuzzing a real ``usv sitl`` over UDP, TCP and a serial radio on a pty (hypothesis, bounded).

One ``usv sitl`` process serves the whole module (:class:`benchmarks.fuzz_target.FuzzTarget`).
After every burst of hostile input the vehicle must still answer, on the link that took the
burst, a PING, a PARAM_REQUEST_READ and keep sending HEARTBEATs; its resident memory stays
bounded.  The long soak is ``usv bench --only fuzz``.
"""

from __future__ import annotations

import random
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.fuzz_frames import (
    FLOAT_EXTREMES,
    FrameKind,
    extreme_message,
    hostile_frame,
    message_classes,
    pack,
)
from benchmarks.fuzz_target import Channel, FuzzTarget

pytestmark = pytest.mark.integration

RSS_GROWTH_LIMIT_KB = 30_000
"""The whole module sends a few thousand frames; a leak per frame would show far above this."""


@pytest.fixture(scope="module")
def target(tmp_path_factory: pytest.TempPathFactory) -> Iterator[FuzzTarget]:
    with FuzzTarget(tmp_path_factory.mktemp("fuzz")) as t:
        t.rss_start_kb = t.rss_kb()  # type: ignore[attr-defined]
        yield t
        assert t.running(), "usv sitl died"


def _assert_alive(target: FuzzTarget, channel: Channel) -> None:
    report = target.check_alive(channel)
    assert report.ok, f"vehicle silent on {channel.value} after hostile input: missing {report.missing}; " \
                      f"log {target.log_path}"


burst = st.lists(st.tuples(st.sampled_from(list(FrameKind)), st.randoms(use_true_random=False)),
                 min_size=1, max_size=40)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture],
          database=None)
@given(frames=burst, channel=st.sampled_from(list(Channel)))
def test_hostile_bursts_leave_the_vehicle_answering(target: FuzzTarget,
                                                    frames: list[tuple[FrameKind, random.Random]],
                                                    channel: Channel) -> None:
    for kind, rng in frames:
        target.send(channel, hostile_frame(kind, rng))
    _assert_alive(target, channel)


@pytest.mark.parametrize("channel", list(Channel))
def test_every_message_with_nan_inf_and_extreme_fields(target: FuzzTarget, channel: Channel) -> None:
    """One valid-checksum frame of each message of the dialect per value class (floats NaN, +inf,
    -inf, the float limit; integers at random limits), addressed to the vehicle."""
    rng = random.Random(16)
    classes = message_classes()
    assert len(classes) > 300  # common + development + ardupilotmega + the boat's messages
    for index, cls in enumerate(classes):
        for _ in range(2):
            target.send(channel, pack(extreme_message(cls, rng), rng))
        if index % 50 == 49:  # paced: a UDP burst larger than the socket buffer would only be lost
            _assert_alive(target, channel)
    _assert_alive(target, channel)
    assert FLOAT_EXTREMES[0] != FLOAT_EXTREMES[0]  # NaN is among the values


def test_tcp_connections_cut_mid_frame(target: FuzzTarget) -> None:
    rng = random.Random(5)
    cut = target.cut_tcp_connections([hostile_frame(FrameKind.EXTREME_FIELDS, rng) for _ in range(40)])
    assert cut == 40
    _assert_alive(target, Channel.TCP)
    _assert_alive(target, Channel.UDP)


def test_resident_memory_stays_bounded(target: FuzzTarget) -> None:
    """Last in the module: after every burst above."""
    for channel in Channel:
        _assert_alive(target, channel)
    growth_kb = target.rss_kb() - target.rss_start_kb  # type: ignore[attr-defined]
    assert growth_kb < RSS_GROWTH_LIMIT_KB, f"RSS grew by {growth_kb} kB"
