"""ATI Net F/T Raw Data Transfer (RDT) over UDP, port 49152, all fields big-endian.

Request (8 bytes): uint16 header 0x1234, uint16 command, uint32 sample count (0 = until
stopped). Commands: 0 stop, 2 start real-time streaming (one record per packet), 3 start
buffered streaming (several records per packet), 0x42 set software bias.
Record (36 bytes): uint32 rdt_sequence (per record, from 1 for each new stream),
uint32 ft_sequence (the sensor's internal sample number), uint32 status (0 = healthy),
six int32 counts Fx Fy Fz Tx Ty Tz; N = counts / counts-per-force, N*m = counts /
counts-per-torque (cfgcpf, cfgcpt in the device's netftapi2.xml).

>>> encode_request(CMD_START_REALTIME, 0).hex()
'1234000200000000'
>>> decode_request(bytes.fromhex("1234000200000005"))
(2, 5)
>>> recs = decode_records(encode_records([1, 2], [10, 11], [0, 0], [[1, -2, 3, 4, 5, 6]] * 2))
>>> recs["rdt_sequence"].tolist(), recs["counts"][1].tolist()
([1, 2], [1, -2, 3, 4, 5, 6])
"""

from __future__ import annotations

import struct

import numpy as np
from numpy.typing import ArrayLike

from spectratac.ft.errors import FTProtocolError

RDT_PORT = 49152
RDT_HEADER = 0x1234
CMD_STOP = 0x0000
CMD_START_REALTIME = 0x0002
CMD_START_BUFFERED = 0x0003
CMD_SET_SOFTWARE_BIAS = 0x0042

_REQUEST = struct.Struct(">HHI")
REQUEST_SIZE = _REQUEST.size

RDT_RECORD = np.dtype(
    [
        ("rdt_sequence", ">u4"),
        ("ft_sequence", ">u4"),
        ("status", ">u4"),
        ("counts", ">i4", (6,)),
    ]
)
RECORD_SIZE = RDT_RECORD.itemsize  # 36


def encode_request(command: int, count: int = 0) -> bytes:
    return _REQUEST.pack(RDT_HEADER, command, count)


def decode_request(data: bytes) -> tuple[int, int]:
    """(command, sample count) of an RDT request; FTProtocolError if it is not one."""
    if len(data) != REQUEST_SIZE:
        raise FTProtocolError(f"RDT request of {len(data)} bytes; expected {REQUEST_SIZE}")
    header, command, count = _REQUEST.unpack(data)
    if header != RDT_HEADER:
        raise FTProtocolError(f"RDT request header 0x{header:04X}; expected 0x{RDT_HEADER:04X}")
    return command, count


def encode_records(
    rdt_sequence: ArrayLike, ft_sequence: ArrayLike, status: ArrayLike, counts: ArrayLike
) -> bytes:
    """Records back to back (one packet in buffered mode; slice by RECORD_SIZE otherwise)."""
    rdt = np.asarray(rdt_sequence)
    out = np.empty(len(rdt), dtype=RDT_RECORD)
    out["rdt_sequence"] = rdt
    out["ft_sequence"] = ft_sequence
    out["status"] = status
    out["counts"] = counts
    return out.tobytes()


def decode_records(data: bytes) -> np.ndarray:
    """RDT_RECORD rows of one or more packets joined (each a multiple of 36 bytes)."""
    if len(data) % RECORD_SIZE:
        raise FTProtocolError(f"{len(data)} bytes is not a whole number of RDT records")
    return np.frombuffer(data, dtype=RDT_RECORD)
