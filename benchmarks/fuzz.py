"""``usv bench --only fuzz``: the long fuzz soak of a real ``usv sitl`` (the suite runs a short one,
``tests/rig/test_fuzz_sitl.py``).

One ``usv sitl`` process (:class:`benchmarks.fuzz_target.FuzzTarget`: UDP, TCP and a serial radio
on a pty) gets hostile frames of every :class:`~benchmarks.fuzz_frames.FrameKind` on every link,
in batches of :data:`BATCH`; after each batch the vehicle must answer on that link (PING,
PARAM_VALUE, a fresh HEARTBEAT); then :data:`TCP_CUTS` TCP connections are cut mid-frame.  A
failure is a batch after which the vehicle did not answer (or the process died); the figure that
matters is ``failures`` = 0.  The GPS-INS parser gets its own hostile stream in-process.

JSON: frames sent per link and kind, batches, failures, checks that needed a second request,
TCP connections cut, RSS of the process before and after (kB), GPS-INS sentences fed and the
parser's error count, wall time.
"""

from __future__ import annotations

import random
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.fuzz_frames import FrameKind, hostile_frame, hostile_nmea
from benchmarks.fuzz_target import Channel, FuzzTarget

FRAMES_FULL = 100_000
FRAMES_QUICK = 1_800
BATCH = 100
TCP_CUTS = 200
TCP_CUTS_QUICK = 20
NMEA_FULL = 100_000
NMEA_QUICK = 2_000
SEED = 2026


def soak(target: FuzzTarget, frames: int, rng: random.Random) -> dict[str, Any]:
    sent = {channel.value: {kind.value: 0 for kind in FrameKind} for channel in Channel}
    failures: list[dict[str, Any]] = []
    batches = retried = 0
    kinds = list(FrameKind)
    channels = list(Channel)
    for index in range(frames // BATCH):
        channel = channels[index % len(channels)]
        for _ in range(BATCH):
            kind = rng.choice(kinds)
            target.send(channel, hostile_frame(kind, rng))
            sent[channel.value][kind.value] += 1
        batches += 1
        report = target.check_alive(channel)
        retried += report.attempts > 1
        if not report.ok:
            failures.append({"batch": index, "link": channel.value, "missing": report.missing})
            if not target.running():
                break
    return {"frames_sent": sum(sum(k.values()) for k in sent.values()), "frames_sent_by_link_and_kind": sent,
            "batches": batches, "failures": len(failures), "failure_details": failures[:20],
            "checks_needing_a_second_request": retried}


def nmea_soak(sentences: int, rng: random.Random) -> dict[str, Any]:
    from companion.bus import Bus
    from companion.clock import SimClock
    from companion.sensors.gpsins import GpsInsParser

    navs: list[object] = []
    parser = GpsInsParser(SimClock(), Bus(), lambda nav, ack: navs.append(nav))
    crashes = 0
    for _ in range(sentences):
        try:
            parser.feed(hostile_nmea(rng))
        except Exception:  # counted: the parser must never raise
            crashes += 1
    return {"gpsins_inputs_fed": sentences, "gpsins_parser_exceptions": crashes,
            "gpsins_errors_counted": parser.errors, "gpsins_nav_samples_accepted": len(navs)}


def run(quick: bool) -> dict[str, Any]:
    rng = random.Random(SEED)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="usv-fuzz-") as tmp, FuzzTarget(Path(tmp)) as target:
        rss_before = target.rss_kb()
        figures = soak(target, FRAMES_QUICK if quick else FRAMES_FULL, rng)
        cuts = target.cut_tcp_connections([hostile_frame(FrameKind.EXTREME_FIELDS, rng)
                                           for _ in range(TCP_CUTS_QUICK if quick else TCP_CUTS)])
        after_cuts = {channel.value: target.check_alive(channel).ok for channel in Channel}
        figures["failures"] += sum(not ok for ok in after_cuts.values())
        rss_after = target.rss_kb()
        alive = target.running()
    figures.update({
        "tcp_connections_cut_mid_frame": cuts,
        "alive_after_cuts": after_cuts,
        "process_alive_at_end": alive,
        "rss_before_kb": rss_before,
        "rss_after_kb": rss_after,
        "rss_growth_kb": rss_after - rss_before,
        "soak_wall_s": round(time.perf_counter() - t0, 1),
        "seed": SEED,
    })
    figures.update(nmea_soak(NMEA_QUICK if quick else NMEA_FULL, rng))
    return figures
