"""Scanning an mcap file (https://mcap.dev/spec) from its start for complete records, for :mod:`.salvage`: Schema,
Channel, Message, Chunk and DataEnd records; a chunk when whole with its CRC matching, the cut one's complete
records when uncompressed."""

from __future__ import annotations

import struct
from pathlib import Path

from .salvage import Channel, Scan

MAGIC = b"\x89MCAP0\r\n"
_RECORD = struct.Struct("<BQ")
_CHUNK = struct.Struct("<QQQI")
_MESSAGE = struct.Struct("<HIQQ")
_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END, _OP_FOOTER = 0x03, 0x04, 0x05, 0x06, 0x0F, 0x02
_FORMATS = {"ros2msg": "msg", "ros2idl": "idl", "omgidl": "idl"}


def _string(buf: bytes, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, pos)
    return bytes(buf[pos + 4 : pos + 4 + n]).decode(errors="replace"), pos + 4 + n


class _State:
    def __init__(self) -> None:
        self.schemas: dict[int, tuple[str, str, str]] = {}
        self.channels: dict[int, Channel] = {}
        self.counts: dict[int, int] = {}
        self.first_ns: int | None = None
        self.last_ns = 0

    def schema(self, rec: bytes) -> None:
        (sid,) = struct.unpack_from("<H", rec, 0)
        name, pos = _string(rec, 2)
        encoding, pos = _string(rec, pos)
        (n,) = struct.unpack_from("<I", rec, pos)
        self.schemas[sid] = (name, encoding, bytes(rec[pos + 4 : pos + 4 + n]).decode(errors="replace"))

    def channel(self, rec: bytes) -> None:
        cid, sid = struct.unpack_from("<HH", rec, 0)
        topic, _ = _string(rec, 4)
        name, encoding, data = self.schemas.get(sid, ("", "", ""))
        self.channels.setdefault(cid, Channel(cid, topic, name, _FORMATS.get(encoding, ""), data))

    def message(self, rec: bytes) -> tuple[int, int]:
        cid, _, log_time, _ = _MESSAGE.unpack_from(rec, 0)
        self.counts[cid] = self.counts.get(cid, 0) + 1
        self.first_ns = log_time if self.first_ns is None else min(self.first_ns, log_time)
        self.last_ns = max(self.last_ns, log_time)
        return cid, log_time


def _records(buf: bytes) -> list[tuple[int, bytes]]:
    """The complete (opcode, content) records of an uncompressed chunk."""
    out, pos = [], 0
    while pos + 9 <= len(buf):
        op, length = _RECORD.unpack_from(buf, pos)
        if pos + 9 + length > len(buf):
            break
        out.append((op, buf[pos + 9 : pos + 9 + length]))
        pos += 9 + length
    return out


def _chunk_data(rec: bytes, partial: bool = False) -> bytes | None:
    """A chunk record's uncompressed records, or None when damaged; ``partial``: the file ends inside it."""
    from rosbags.rosbag2.storage_mcap import decompress

    try:
        _, _, size, crc = _CHUNK.unpack_from(rec, 0)
        compression, pos = _string(rec, 28)
        (n,) = struct.unpack_from("<Q", rec, pos)
        data = rec[pos + 8 : pos + 8 + n]
        if partial:
            return bytes(data) if compression == "" else None
        if len(data) != n:
            return None
        return decompress(bytes(data), compression, size, crc)
    except Exception:  # any damage in the chunk: the chunk is lost, the scan goes on
        return None


def scan_mcap(path: Path) -> Scan | None:
    """The complete records of an mcap file (None: it does not start with the mcap magic)."""
    with path.open("rb") as f:
        if f.read(8) != MAGIC:
            return None
        size = path.stat().st_size
        state = _State()
        blocks: list[tuple[int, int, bool]] = []  # (offset, length, cut) of chunk records or loose messages
        pos, complete, ended = 8, 8, False
        while pos + 9 <= size:
            f.seek(pos)
            op, length = _RECORD.unpack(f.read(9))
            if pos + 9 + length > size:
                if op == _OP_CHUNK:  # the cut falls in this chunk: its complete records, if uncompressed
                    rec = f.read()
                    inner = _records(_chunk_data(rec, partial=True) or b"")
                    for iop, irec in inner:
                        _apply(state, iop, irec)
                    if any(iop == _OP_MESSAGE for iop, _ in inner):
                        blocks.append((pos, len(rec), True))
                        header = 28 + 4 + struct.unpack_from("<I", rec, 28)[0] + 8
                        complete = pos + 9 + header + sum(9 + len(irec) for _, irec in inner)
                break
            if op in (_OP_DATA_END, _OP_FOOTER):
                ended = True
                complete = pos + 9 + length
                break
            if op in (_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK):
                rec = f.read(length)
                if op == _OP_CHUNK:
                    data = _chunk_data(rec)
                    if data is not None:
                        inner = _records(data)
                        for iop, irec in inner:
                            _apply(state, iop, irec)
                        if any(iop == _OP_MESSAGE for iop, _ in inner):
                            blocks.append((pos, length, False))
                else:
                    _apply(state, op, rec)
                    if op == _OP_MESSAGE:
                        blocks.append((pos, length, False))
            pos += 9 + length
            complete = pos

    def read_block(block: tuple[int, int, bool]) -> list[tuple[int, int, bytes]]:
        offset, length, cut = block
        with path.open("rb") as fh:
            fh.seek(offset)
            op, _ = _RECORD.unpack(fh.read(9))
            rec = fh.read(length)
        records = _records(_chunk_data(rec, cut) or b"") if op == _OP_CHUNK else [(op, rec)]
        out = []
        for iop, irec in records:
            if iop == _OP_MESSAGE and len(irec) >= 22:
                cid, _, log_time, _ = _MESSAGE.unpack_from(irec, 0)
                out.append((cid, log_time, bytes(irec[22:])))
        out.sort(key=lambda m: m[1])
        return out

    return Scan(channels=state.channels, counts=state.counts, blocks=blocks, read_block=read_block,
                file_bytes=size, read_bytes=complete, data_complete=ended, first_ns=state.first_ns or 0,
                last_ns=state.last_ns, ros2=True)


def _apply(state: _State, op: int, rec: bytes) -> None:
    try:
        if op == _OP_SCHEMA:
            state.schema(rec)
        elif op == _OP_CHANNEL:
            state.channel(rec)
        elif op == _OP_MESSAGE and len(rec) >= 22:
            state.message(rec)
    except (struct.error, UnicodeDecodeError):
        return
