"""A lossy UDP link between a ground station and the vehicle: drops, duplicates, reorders, delays.

:class:`LossyProxy` stands where the radio would be.  The vehicle's UDP target is the proxy's
``vehicle_port``; the proxy forwards what the vehicle sends to the ground station at
``127.0.0.1:client_port`` (which listens there, as QGroundControl on 14550 or MAVSDK's
``udpin://0.0.0.0:PORT``) from its own ephemeral socket, and forwards the ground station's
replies to the vehicle.  Each datagram, in each direction independently (seeded
:class:`random.Random`):

* is dropped with probability ``loss``;
* is otherwise delivered after ``delay_s`` plus a uniform jitter up to ``jitter_s`` (jitter larger
  than the spacing of datagrams reorders them);
* is held back with probability ``reorder`` until the next datagram of its direction has gone;
* is delivered twice with probability ``duplicate`` (the copy ``duplicate_gap_s`` later).

A datagram carries whole MAVLink frames (the vehicle and pymavlink/MAVSDK send one frame per
datagram), so the proxy works on frames.  It runs in a thread (:meth:`start`/:meth:`stop`) or as
a process: ``python -m benchmarks.lossy_link --vehicle-port P --client-port Q --loss 0.3``.
"""

from __future__ import annotations

import argparse
import heapq
import itertools
import random
import select
import socket
import threading
import time
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Impairment:
    loss: float = 0.3
    duplicate: float = 0.05
    reorder: float = 0.05
    delay_s: float = 0.01
    jitter_s: float = 0.02
    duplicate_gap_s: float = 0.005


@dataclass
class DirectionStats:
    datagrams: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0
    delivered: int = 0


@dataclass
class ProxyStats:
    to_client: DirectionStats = field(default_factory=DirectionStats)
    to_vehicle: DirectionStats = field(default_factory=DirectionStats)

    def as_dict(self) -> dict[str, dict[str, int]]:
        return {name: vars(getattr(self, name)).copy() for name in ("to_client", "to_vehicle")}


class LossyProxy:
    """UDP proxy: vehicle <-> ``vehicle_port`` | proxy | ephemeral socket <-> client at ``client_port``."""

    def __init__(self, vehicle_port: int, client_port: int, impairment: Impairment, *, seed: int = 1,
                 host: str = "127.0.0.1") -> None:
        self.impairment = impairment
        self.rng = random.Random(seed)
        self.client_addr = (host, client_port)
        self.vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.vehicle_side.bind((host, vehicle_port))
        self.client_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.client_side.bind((host, 0))
        self.vehicle_addr: tuple[str, int] | None = None
        self.stats = ProxyStats()
        self._queue: list[tuple[float, int, socket.socket, bytes, tuple[str, int]]] = []
        self._order = itertools.count()
        self._held: dict[int, tuple[bytes, tuple[str, int]] | None] = {0: None, 1: None}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # -- life cycle -------------------------------------------------------------------------
    def start(self) -> LossyProxy:
        self._thread = threading.Thread(target=self.run, name="lossy-proxy", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2)
        self.vehicle_side.close()
        self.client_side.close()

    def __enter__(self) -> LossyProxy:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- forwarding -------------------------------------------------------------------------
    def _schedule(self, out: socket.socket, data: bytes, addr: tuple[str, int], stats: DirectionStats,
                  direction: int) -> None:
        imp, rng = self.impairment, self.rng
        stats.datagrams += 1
        if rng.random() < imp.loss:
            stats.dropped += 1
            return
        if rng.random() < imp.reorder and self._held[direction] is None:
            self._held[direction] = (data, addr)  # goes out right after the next datagram
            stats.reordered += 1
            return
        now = time.monotonic()
        due = now + imp.delay_s + rng.uniform(0.0, imp.jitter_s)
        heapq.heappush(self._queue, (due, next(self._order), out, data, addr))
        held = self._held[direction]
        if held is not None:
            self._held[direction] = None
            heapq.heappush(self._queue, (due + 1e-4, next(self._order), out, held[0], held[1]))
        if rng.random() < imp.duplicate:
            stats.duplicated += 1
            heapq.heappush(self._queue, (due + imp.duplicate_gap_s, next(self._order), out, data, addr))

    def _flush(self) -> float:
        """Send what is due; returns seconds until the next datagram is due (at most 0.05)."""
        now = time.monotonic()
        while self._queue and self._queue[0][0] <= now:
            _, _, out, data, addr = heapq.heappop(self._queue)
            try:
                out.sendto(data, addr)
            except OSError:
                continue
            (self.stats.to_client if out is self.client_side else self.stats.to_vehicle).delivered += 1
        return min(0.05, max(0.0, self._queue[0][0] - now)) if self._queue else 0.05

    def run(self) -> None:
        while not self._stop.is_set():
            timeout = self._flush()
            try:
                ready, _, _ = select.select([self.vehicle_side, self.client_side], [], [], timeout)
            except (OSError, ValueError):
                return
            for sock in ready:
                try:
                    data, addr = sock.recvfrom(65536)
                except OSError:
                    continue
                if sock is self.vehicle_side:
                    self.vehicle_addr = addr
                    self._schedule(self.client_side, data, self.client_addr, self.stats.to_client, 0)
                elif self.vehicle_addr is not None:
                    self._schedule(self.vehicle_side, data, self.vehicle_addr, self.stats.to_vehicle, 1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--vehicle-port", type=int, required=True, help="the vehicle's UDP target port")
    parser.add_argument("--client-port", type=int, required=True, help="where the ground station listens")
    parser.add_argument("--loss", type=float, default=0.3)
    parser.add_argument("--duplicate", type=float, default=0.05)
    parser.add_argument("--reorder", type=float, default=0.05)
    parser.add_argument("--delay", type=float, default=0.01, help="seconds")
    parser.add_argument("--jitter", type=float, default=0.02, help="seconds")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    imp = Impairment(args.loss, args.duplicate, args.reorder, args.delay, args.jitter)
    with LossyProxy(args.vehicle_port, args.client_port, imp, seed=args.seed):
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            return 0


if __name__ == "__main__":
    raise SystemExit(main())
