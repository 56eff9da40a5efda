"""Scanning a ROS 1 bag (http://wiki.ros.org/Bags/Format/2.0) from its start for complete chunks, for
:mod:`.salvage`: a chunk when complete and decompressing to its size; the cut one's complete records when
uncompressed."""

from __future__ import annotations

import bz2
import struct
from pathlib import Path

from .salvage import Channel, Scan

MAGIC = b"#ROSBAG V2.0\n"
_OP_MESSAGE, _OP_BAG_HEADER, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONNECTION = 0x02, 0x03, 0x05, 0x06, 0x07


def _fields(buf: bytes) -> dict[str, bytes]:
    out, pos = {}, 0
    while pos + 4 <= len(buf):
        (n,) = struct.unpack_from("<I", buf, pos)
        name, _, value = bytes(buf[pos + 4 : pos + 4 + n]).partition(b"=")
        out[name.decode(errors="replace")] = value
        pos += 4 + n
    return out


def _records(buf: bytes) -> tuple[list[tuple[dict[str, bytes], bytes]], int]:
    """The complete (header fields, data) records of ``buf``, and where the last of them ends."""
    out, pos = [], 0
    while pos + 4 <= len(buf):
        (hlen,) = struct.unpack_from("<I", buf, pos)
        if pos + 8 + hlen > len(buf):
            break
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        end = pos + 8 + hlen + dlen
        if end > len(buf):
            break
        out.append((_fields(buf[pos + 4 : pos + 4 + hlen]), buf[pos + 8 + hlen : end]))
        pos = end
    return out, pos


def _op(fields: dict[str, bytes]) -> int:
    return fields.get("op", b"\xff")[0]


def _decompress(fields: dict[str, bytes], data: bytes) -> bytes | None:
    try:
        compression = fields.get("compression", b"none").decode()
        (size,) = struct.unpack("<I", fields["size"])
        if compression == "none":
            raw = data
        elif compression == "bz2":
            raw = bz2.decompress(data)
        elif compression == "lz4":
            from lz4.frame import decompress

            raw = decompress(data)
        else:
            return None
        return raw if len(raw) == size else None
    except Exception:  # a damaged chunk is lost, the scan goes on
        return None


def _normalize(topic: str) -> str:
    return ("/" if topic.startswith("/") else "") + "/".join(p for p in topic.split("/") if p)


def _channel(fields: dict[str, bytes], data: bytes) -> Channel:
    from rosbags.typesys.msg import normalize_msgtype

    (cid,) = struct.unpack("<I", fields["conn"])
    info = _fields(data)
    return Channel(cid, _normalize(fields.get("topic", b"").decode(errors="replace")),
                   normalize_msgtype(info.get("type", b"").decode()), "msg",
                   info.get("message_definition", b"").decode(errors="replace"), info.get("md5sum", b"").decode())


def _time_ns(fields: dict[str, bytes]) -> int:
    sec, nsec = struct.unpack("<II", fields["time"])
    return sec * 1_000_000_000 + nsec


def _chunk_records(buf: bytes) -> tuple[list[tuple[dict[str, bytes], bytes]], int] | None:
    """The records inside a chunk record and the bytes they use (all of a complete chunk; the complete ones of an
    uncompressed chunk the file ends in), or None."""
    (hlen,) = struct.unpack_from("<I", buf, 0)
    fields = _fields(buf[4 : 4 + hlen])
    (dlen,) = struct.unpack_from("<I", buf, 4 + hlen)
    data = buf[8 + hlen : 8 + hlen + dlen]
    if len(data) == dlen:
        inner = _decompress(fields, data)
        return None if inner is None else (_records(inner)[0], len(buf))
    if fields.get("compression", b"none") != b"none":
        return None
    records, used = _records(data)
    return records, 8 + hlen + used


class _Found:
    """Connections, message counts and receive-time range of the chunks read so far."""

    def __init__(self) -> None:
        self.channels: dict[int, Channel] = {}
        self.counts: dict[int, int] = {}
        self.first, self.last = 2**63, 0

    def add(self, records: list[tuple[dict[str, bytes], bytes]]) -> dict[int, int]:
        """Take a chunk's records; returns its messages per connection."""
        per_connection: dict[int, int] = {}
        for fields, data in records:
            op = _op(fields)
            if op == _OP_CONNECTION:
                ch = _channel(fields, data)
                self.channels.setdefault(ch.id, ch)
            elif op == _OP_MESSAGE:
                (cid,) = struct.unpack("<I", fields["conn"])
                self.counts[cid] = self.counts.get(cid, 0) + 1
                per_connection[cid] = per_connection.get(cid, 0) + 1
                stamp = _time_ns(fields)
                self.first, self.last = min(self.first, stamp), max(self.last, stamp)
        return per_connection


def scan_ros1(path: Path) -> Scan | None:
    """The complete chunks of a ROS 1 bag (None: it does not start with the ROS 1 bag magic)."""
    with path.open("rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            return None
        size = path.stat().st_size
        found = _Found()
        blocks: list[tuple[int, int]] = []
        pos = complete = len(MAGIC)
        ended = False
        index_pos: int | None = None
        last_chunk: tuple[int, dict[int, int]] = (0, {})  # (end offset, messages per connection) of the last chunk
        while pos + 8 <= size:
            f.seek(pos)
            (hlen,) = struct.unpack("<I", f.read(4))
            fields = _fields(f.read(hlen))
            raw_dlen = f.read(4)
            if len(raw_dlen) < 4:
                break
            end = pos + 8 + hlen + struct.unpack("<I", raw_dlen)[0]
            op = _op(fields)
            if op == _OP_BAG_HEADER and len(fields.get("index_pos", b"")) == 8:
                index_pos = struct.unpack("<Q", fields["index_pos"])[0] or None
            if op in (_OP_CONNECTION, _OP_CHUNK_INFO):  # the index: every chunk is behind us
                ended = True
                break
            if op == _OP_CHUNK:
                f.seek(pos)
                got = _chunk_records(f.read(min(end, size) - pos))
                if got is not None:
                    per_connection = found.add(got[0])
                    if per_connection:
                        blocks.append((pos, min(end, size) - pos))
                    last_chunk = (pos + got[1], per_connection)
                    if end > size:
                        complete = pos + got[1]
            if end > size:
                break
            pos = complete = end
        # After a chunk come its index data records, 55 + 12·n bytes per connection with n messages in it: when
        # they fill exactly the bytes up to index_pos, the cut fell in the index and no message was lost.
        index_bytes = sum(55 + 12 * n for n in last_chunk[1].values())
        ended = ended or (index_pos is not None and (complete >= index_pos or last_chunk[0] + index_bytes == index_pos))

    def read_block(block: tuple[int, int]) -> list[tuple[int, int, bytes]]:
        offset, length = block
        with path.open("rb") as fh:
            fh.seek(offset)
            got = _chunk_records(fh.read(length))
        records = got[0] if got is not None else []
        return [(struct.unpack("<I", fl["conn"])[0], _time_ns(fl), bytes(d)) for fl, d in records
                if _op(fl) == _OP_MESSAGE]

    return Scan(channels=found.channels, counts=found.counts, blocks=blocks, read_block=read_block,
                file_bytes=size, read_bytes=complete, data_complete=ended, first_ns=found.first if found.last else 0,
                last_ns=found.last, ros2=False, data_bytes=index_pos)
