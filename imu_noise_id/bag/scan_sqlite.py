"""Scanning a rosbag2 sqlite3 file (https://www.sqlite.org/fileformat2.html) page by page for its rows, for
:mod:`.salvage`: table leaf pages and a write-ahead log's newer page images; rosbag2 rows recognised by their columns
(``messages``, ``topics``, ``message_definitions``)."""

from __future__ import annotations

import mmap
import struct
from pathlib import Path

from .salvage import Channel, Scan

MAGIC = b"SQLite format 3\x00"
_LEAF_TABLE = 0x0D
_WAL_MAGICS = (0x377F0682, 0x377F0683)


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    value = 0
    for i in range(9):
        byte = buf[pos + i]
        if i == 8:
            return (value << 8) | byte, pos + 9
        value = (value << 7) | (byte & 0x7F)
        if byte < 0x80:
            return value, pos + i + 1
    raise IndexError("varint")


def _values(payload: bytes) -> list[object]:
    """The column values of a record."""
    header_size, pos = _varint(payload, 0)
    types = []
    while pos < header_size:
        t, pos = _varint(payload, pos)
        types.append(t)
    out: list[object] = []
    pos = header_size
    sizes = {0: 0, 1: 1, 2: 2, 3: 3, 4: 4, 5: 6, 6: 8, 7: 8, 8: 0, 9: 0}
    for t in types:
        if t in sizes:
            n = sizes[t]
            if t == 0:
                out.append(None)
            elif t == 7:
                out.append(struct.unpack_from(">d", payload, pos)[0])
            elif t in (8, 9):
                out.append(t - 8)
            else:
                out.append(int.from_bytes(payload[pos : pos + n], "big", signed=True))
        elif t >= 12:
            n = (t - 12) // 2
            value = bytes(payload[pos : pos + n])
            if len(value) != n:
                raise IndexError("record runs past its payload")
            out.append(value if t % 2 == 0 else value.decode(errors="replace"))
        else:
            raise ValueError(f"serial type {t}")
        pos += n
    return out


class _Pages:
    """Page images of the database file, newer ones from its write-ahead log overriding them."""

    def __init__(self, db: Path) -> None:
        self.db = db
        with db.open("rb") as f:
            self.data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        (size,) = struct.unpack_from(">H", self.data, 16)
        self.size = 65536 if size == 1 else size
        self.usable = self.size - self.data[20]
        self.count = len(self.data) // self.size
        self.complete_bytes = self.count * self.size
        (announced,) = struct.unpack_from(">I", self.data, 28)
        self.announced_bytes = max(announced * self.size, len(self.data))
        self.wal_data: mmap.mmap | None = None
        self.wal: dict[int, int] = {}  # page number → offset of its newest image in the WAL
        self.wal_frames = 0
        wal = db.with_name(db.name + "-wal")
        if wal.is_file() and wal.stat().st_size > 32:
            with wal.open("rb") as f:
                raw = self.wal_data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
            magic, _, page_size, _, salt1, salt2 = struct.unpack_from(">IIIIII", raw, 0)
            if magic in _WAL_MAGICS and page_size == self.size:
                pos = 32
                while pos + 24 + self.size <= len(raw):
                    number, _, s1, s2 = struct.unpack_from(">IIII", raw, pos)
                    if (s1, s2) != (salt1, salt2):
                        break
                    self.wal[number] = pos + 24
                    self.wal_frames += 1
                    pos += 24 + self.size

    def numbers(self) -> list[int]:
        return sorted(set(range(1, self.count + 1)) | set(self.wal))

    def page(self, number: int) -> bytes | None:
        if number in self.wal and self.wal_data is not None:
            return self.wal_data[self.wal[number] : self.wal[number] + self.size]
        if 1 <= number <= self.count:
            return self.data[(number - 1) * self.size : number * self.size]
        return None

    def payload(self, page: bytes, pos: int, total: int) -> bytes:
        """A cell's payload of ``total`` bytes from ``pos``, following its overflow chain."""
        usable = self.usable
        local_max = usable - 35
        if total <= local_max:
            return page[pos : pos + total]
        m = (usable - 12) * 32 // 255 - 23
        k = m + (total - m) % (usable - 4)
        local = k if k <= local_max else m
        parts = [page[pos : pos + local]]
        (nxt,) = struct.unpack_from(">I", page, pos + local)
        remaining = total - local
        while remaining > 0 and nxt:
            over = self.page(nxt)
            if over is None:
                raise IndexError("overflow page missing")
            (nxt,) = struct.unpack_from(">I", over, 0)
            piece = over[4 : 4 + min(remaining, usable - 4)]
            parts.append(piece)
            remaining -= len(piece)
        if remaining:
            raise IndexError("overflow chain incomplete")
        return b"".join(parts)

    def rows(self, number: int) -> list[tuple[int, list[object]]]:
        """(rowid, values) of every readable cell of a table leaf page (empty for other pages)."""
        page = self.page(number)
        start = 100 if number == 1 else 0
        if page is None or len(page) < start + 8 or page[start] != _LEAF_TABLE:
            return []
        (cells,) = struct.unpack_from(">H", page, start + 3)
        out = []
        for i in range(cells):
            try:
                (ptr,) = struct.unpack_from(">H", page, start + 8 + 2 * i)
                total, pos = _varint(page, ptr)
                rowid, pos = _varint(page, pos)
                out.append((rowid, _values(self.payload(page, pos, total))))
            except (IndexError, ValueError, struct.error):
                continue
        return out


def _is_message(values: list[object]) -> bool:
    return (len(values) == 4 and isinstance(values[1], int) and isinstance(values[2], int)
            and isinstance(values[3], bytes))


def scan_sqlite(path: Path) -> Scan | None:
    """The rows of a rosbag2 sqlite3 file (None: it does not start with the SQLite magic)."""
    with path.open("rb") as f:
        if f.read(16) != MAGIC:
            return None
    pages = _Pages(path)
    topics: dict[int, tuple[str, str]] = {}
    definitions: dict[str, tuple[str, str]] = {}
    counts: dict[int, int] = {}
    leaves: list[tuple[int, int]] = []  # (first rowid, page number) of pages holding messages
    first, last = 2**63, 0
    for number in pages.numbers():
        rows = pages.rows(number)
        found = [(rowid, v) for rowid, v in rows if _is_message(v)]
        for rowid, values in rows:
            if len(values) >= 5 and all(isinstance(x, str) for x in values[1:5]):
                if str(values[1]).startswith("/"):
                    topics[rowid] = (str(values[1]), str(values[2]))
                elif str(values[2]) in ("ros2msg", "ros2idl"):
                    definitions[str(values[1])] = ("msg" if values[2] == "ros2msg" else "idl", str(values[3]))
        for _, values in found:
            counts[values[1]] = counts.get(values[1], 0) + 1
            first, last = min(first, values[2]), max(last, values[2])
        if found:
            leaves.append((min(r for r, _ in found), number))
    channels = {}
    for tid, (name, msgtype) in topics.items():
        fmt, text = definitions.get(msgtype, ("", ""))
        channels[tid] = Channel(tid, name, msgtype, fmt, text)

    def read_block(number: int) -> list[tuple[int, int, bytes]]:
        rows = sorted((rowid, v) for rowid, v in pages.rows(number) if _is_message(v))
        return [(v[1], v[2], v[3]) for _, v in rows]  # type: ignore[misc]

    notes = []
    if pages.wal_frames:
        notes.append(f"{pages.wal_frames} page(s) of its write-ahead log {path.name}-wal were read too (rosbags "
                     "alone ignores them)")
    return Scan(channels=channels, counts=counts, blocks=[n for _, n in sorted(leaves)], read_block=read_block,
                file_bytes=path.stat().st_size, read_bytes=pages.complete_bytes, data_bytes=pages.announced_bytes,
                data_complete=pages.complete_bytes >= pages.announced_bytes and not pages.wal_frames,
                first_ns=first if last else 0, last_ns=last, ros2=True, extra_notes=notes)
