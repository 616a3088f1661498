"""MAVLink PING (msg 4): a ground station's round-trip probe, answered on the link it came from.

The ping protocol (common.xml): a request has ``target_system`` and ``target_component`` 0; the
answer repeats its ``time_usec`` and ``seq`` and is addressed to the sender.  A PING addressed
to someone (an answer to another system's probe) is not answered.  It changes nothing, so it is
answered unsigned too (:data:`companion.link.signing.READ_ONLY_MESSAGES`).
"""

from __future__ import annotations

from typing import Any

from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager


def register_ping(links: LinkManager) -> None:
    """Answer PING requests on every link of ``links``."""

    def on_ping(link: Link, msg: Any) -> None:
        if int(msg.target_system) != 0 or int(msg.target_component) != 0:
            return  # an answer to a probe, not a request
        link.send(mav.MAVLink_ping_message(int(msg.time_usec), int(msg.seq), msg.get_srcSystem(),
                                           msg.get_srcComponent()))

    links.dispatcher.on("PING", on_ping)
