"""MAVLink FTP (FILE_TRANSFER_PROTOCOL): refuse cleanly so clients fall back.

QGroundControl and MAVProxy first try to download parameters as ``@PARAM/param.pck`` over
MAVLink FTP and fall back to PARAM_REQUEST_LIST when the vehicle answers with a NAK.  This
vehicle serves no files: every open/read/list is NAKed with ``FileNotFound`` (or
``UnknownCommand``), session resets are ACKed.  Payload layout per the MAVLink FTP spec:
seq u16, session u8, opcode u8, size u8, req_opcode u8, burst_complete u8, padding u8,
offset u32, data[239].
"""

from __future__ import annotations

import struct
from typing import Any

from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager

OP_TERMINATE_SESSION = 1
OP_RESET_SESSIONS = 2
OP_LIST_DIRECTORY = 3
OP_OPEN_FILE_RO = 4
OP_READ_FILE = 5
OP_BURST_READ_FILE = 15
OP_ACK = 128
OP_NAK = 129
ERR_FAIL = 1
ERR_UNKNOWN_COMMAND = 7
ERR_FILE_NOT_FOUND = 10

_HEADER = struct.Struct("<HBBBBBBI")
PAYLOAD_LEN = 251


def reply_payload(request: bytes, opcode: int, error: int | None) -> bytes:
    seq, session, req_opcode, _size, _r, _b, _p, offset = _HEADER.unpack_from(request.ljust(12, b"\0"))
    data = b"" if error is None else bytes([error])
    header = _HEADER.pack((seq + 1) & 0xFFFF, session, opcode, len(data), req_opcode, 0, 0, offset)
    return (header + data).ljust(PAYLOAD_LEN, b"\0")


class FtpService:
    """NAKs every file operation."""

    def __init__(self, links: LinkManager) -> None:
        links.dispatcher.on("FILE_TRANSFER_PROTOCOL", self._on_ftp)
        self.requests = 0

    def _on_ftp(self, link: Link, msg: Any) -> None:
        payload = bytes(msg.payload)
        if len(payload) < 12:
            return
        self.requests += 1
        opcode = payload[3]
        if opcode in (OP_TERMINATE_SESSION, OP_RESET_SESSIONS):
            reply = reply_payload(payload, OP_ACK, None)
        elif opcode in (OP_LIST_DIRECTORY, OP_OPEN_FILE_RO, OP_READ_FILE, OP_BURST_READ_FILE):
            reply = reply_payload(payload, OP_NAK, ERR_FILE_NOT_FOUND)
        else:
            reply = reply_payload(payload, OP_NAK, ERR_UNKNOWN_COMMAND)
        link.send(mav.MAVLink_file_transfer_protocol_message(0, msg.get_srcSystem(), msg.get_srcComponent(),
                                                             list(reply)))
