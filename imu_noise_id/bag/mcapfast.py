"""Faster raw message iteration over indexed rosbag2 mcap files (same messages, same order as rosbags) when the
chunks do not overlap in time; otherwise ``AnyReader.messages`` (docs/bags.md, "Why the mcap fast path exists")."""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from itertools import pairwise
from typing import Any

_RECORD = struct.Struct("<BQ")  # opcode, content length
_MESSAGE = struct.Struct("<HIQ")  # channel id, sequence, log time (publish time and data follow)
_OP_MESSAGE = 0x05
_MESSAGE_HEADER = 22  # channel id (2) + sequence (4) + log time (8) + publish time (8)


class McapFormatError(ValueError):
    """A chunk's records do not add up (truncated or corrupt file)."""


def _mcap_storages(reader: Any) -> list[Any] | None:
    """The McapReader storages behind an open AnyReader, or None if it is not a plain rosbag2 mcap bag."""
    from rosbags.rosbag2.storage_mcap import McapReader

    if not getattr(reader, "is2", False) or len(reader.readers) != 1:
        return None
    inner = reader.readers[0].storage
    if isinstance(inner, McapReader):
        storages = [inner]
    elif getattr(inner, "metadata", None) is not None and inner.metadata.compression_mode in (None, "", "none"):
        storages = list(getattr(inner, "storages", []))
    else:
        return None
    if not storages or not all(isinstance(s, McapReader) and s.chunks for s in storages):
        return None
    for storage in storages:
        chunks = sorted(storage.chunks, key=lambda c: (c.message_start_time, c.chunk_start_offset))
        if any(b.message_start_time <= a.message_end_time for a, b in pairwise(chunks)):
            return None
    return storages


def fast_mcap_batches(reader: Any, connections: Sequence[Any]) -> Iterator[list[tuple[Any, int, bytes]]] | None:
    """The messages of ``reader.messages(connections)``, one list per chunk, or None when not applicable (not a plain
    rosbag2 mcap, per-message compression, no chunk index, overlapping chunks)."""
    storages = _mcap_storages(reader)
    if storages is None:
        return None
    return _iterate(storages, connections)


def fast_mcap_messages(reader: Any, connections: Sequence[Any]) -> Iterator[tuple[Any, int, bytes]] | None:
    """Like ``reader.messages(connections)`` (one message at a time), or None when not applicable."""
    batches = fast_mcap_batches(reader, connections)
    return None if batches is None else (message for batch in batches for message in batch)


def _iterate(storages: list[Any], connections: Sequence[Any]) -> Iterator[list[tuple[Any, int, bytes]]]:
    from rosbags.rosbag2.storage_mcap import decompress

    for storage in storages:
        wanted = {}
        for channel in storage.connections:
            for conn in connections:
                if conn.topic == channel.topic and conn.msgtype == channel.msgtype:
                    wanted[channel.id] = conn
        if not wanted:
            continue
        bio = storage.bio
        for chunk in sorted(storage.chunks, key=lambda c: (c.message_start_time, c.chunk_start_offset)):
            if not any(chunk.channel_count.get(cid, 0) for cid in wanted):
                continue
            bio.seek(chunk.chunk_start_offset + 9 + 24)
            (crc,) = struct.unpack("<I", bio.read(4))
            bio.seek(chunk.chunk_start_offset + 9 + 40 + len(chunk.compression))
            compressed = bio.read(chunk.compressed_size)
            if len(compressed) != chunk.compressed_size:
                raise McapFormatError("chunk data ends early")
            data = decompress(compressed, chunk.compression, chunk.uncompressed_size, crc)
            yield _chunk_messages(data, wanted)


def _chunk_messages(data: bytes, wanted: dict[int, Any]) -> list[tuple[Any, int, bytes]]:
    """Wanted message records of one uncompressed chunk, stably sorted by log time (as rosbags yields them)."""
    record, message = _RECORD.unpack_from, _MESSAGE.unpack_from
    out: list[tuple[Any, int, bytes]] = []
    pos, end = 0, len(data)
    ordered, last = True, -1
    while pos < end:
        if pos + 9 > end:
            raise McapFormatError("record header runs past the end of its chunk")
        op, length = record(data, pos)
        pos += 9
        if pos + length > end:
            raise McapFormatError("record runs past the end of its chunk")
        if op == _OP_MESSAGE:
            if length < _MESSAGE_HEADER:
                raise McapFormatError(f"message record of {length} bytes")
            cid, _, log_time = message(data, pos)
            conn = wanted.get(cid)
            if conn is not None:
                out.append((conn, log_time, data[pos + _MESSAGE_HEADER : pos + length]))
                ordered = ordered and log_time >= last
                last = log_time
        pos += length
    if not ordered:
        out.sort(key=lambda m: m[1])
    return out
