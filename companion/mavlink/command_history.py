"""Commands stay idempotent over a lossy link: a repeat of a command that was just executed is
answered with its first COMMAND_ACK instead of being run again.

On a radio link a ground station resends a command whose COMMAND_ACK it did not get (with
``confirmation`` incremented, as the MAVLink command protocol says, or unchanged, as simple
scripts do), and a link may deliver one frame twice.  A rope launcher must not fire twice, a
bottle must not be filled twice, a toggle must not toggle back because the first ACK was lost.

Rule (:class:`CommandHistory`): a command from the same ground station (source system and
component, on any link) with the same id, frame and parameters as one that was ACCEPTED less
than :data:`REPEAT_WINDOW_S` ago (vehicle clock), while the vehicle is still in the state that
command left it in (armed or not, and the mode), is a repeat: it is answered with the cached
ACK and not executed.  If the state changed meanwhile (a failsafe disarmed the boat, a mission
ended and switched to HOLD), the command is executed again: the station means it.  Refused
commands are not cached (they changed nothing, so a retry is judged afresh), nor are the
read-only requests (:data:`NOT_CACHED`: a retried REQUEST_MESSAGE means its answer was lost, and
must be sent again).  To run the same command twice on purpose,
wait :data:`REPEAT_WINDOW_S`; the vehicle says so in a STATUSTEXT when it answers a repeat.
"""

from __future__ import annotations

import struct
from collections.abc import Hashable
from dataclasses import dataclass

from companion.link.signing import READ_ONLY_COMMANDS

REPEAT_WINDOW_S = 3.0
"""How long after its ACK an identical command counts as a repeat (QGroundControl and MAVSDK
retry within this; a person repeating a command waits longer)."""
NOT_CACHED: frozenset[int] = READ_ONLY_COMMANDS
"""Commands that only ask for a message: always executed (their answer may have been lost)."""

_Source = tuple[int, int, int]
"""(source system, source component, command id)."""


@dataclass(frozen=True, slots=True)
class CachedAck:
    """The final COMMAND_ACK of an executed command."""

    result: int
    result_param2: int
    at_s: float
    signature: bytes
    state: Hashable = None
    """The vehicle's state right after the command (armed, mode)."""


def command_signature(frame: int, params: tuple[float, ...], is_int: bool) -> bytes:
    """What makes two commands the same: frame, kind and the exact parameter bits (NaN included)."""
    return struct.pack(f"<?B{len(params)}d", is_int, frame & 0xFF, *params)


class CommandHistory:
    """The last ACCEPTED command per (ground station, command id)."""

    def __init__(self, window_s: float = REPEAT_WINDOW_S) -> None:
        self.window_s = window_s
        self._last: dict[_Source, CachedAck] = {}
        self._announced: set[tuple[_Source, float]] = set()
        self.repeats_answered = 0

    def repeat_of(self, source: tuple[int, int], command: int, signature: bytes, now_s: float, *,
                  state: Hashable = None) -> CachedAck | None:
        """The cached ACK if this command repeats one accepted within the window, in an unchanged
        vehicle ``state``, else None."""
        cached = self._last.get((source[0], source[1], command))
        if (cached is None or cached.signature != signature or cached.state != state
                or not 0.0 <= now_s - cached.at_s <= self.window_s):
            return None
        self.repeats_answered += 1
        return cached

    def first_repeat(self, source: tuple[int, int], command: int) -> bool:
        """True once per cached command: the vehicle tells the operator about the first repeat only
        (a ground station retrying a lost ACK several times gets one STATUSTEXT, not several)."""
        key = (source[0], source[1], command)
        cached = self._last.get(key)
        if cached is None or (key, cached.at_s) in self._announced:
            return False
        self._announced.add((key, cached.at_s))
        return True

    def record(self, source: tuple[int, int], command: int, signature: bytes, result: int,
               result_param2: int, now_s: float, *, accepted: bool, state: Hashable = None) -> None:
        """Remember an executed command's final ACK (only accepted, state-changing ones count)."""
        key = (source[0], source[1], command)
        if accepted and command not in NOT_CACHED:
            self._last[key] = CachedAck(result, result_param2, now_s, signature, state)
        else:
            self._last.pop(key, None)
        if len(self._last) > 256:  # many stations and commands: forget the expired ones
            self._last = {k: v for k, v in self._last.items() if now_s - v.at_s <= self.window_s}
        if len(self._announced) > 256:
            self._announced = {a for a in self._announced if now_s - a[1] <= self.window_s}
