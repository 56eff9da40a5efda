"""Reading what is complete in a truncated bag (scanned from its start: :mod:`.scan_mcap`, :mod:`.scan_ros1`,
:mod:`.scan_sqlite`), and saying what was lost: :func:`salvage` returns a :class:`SalvagedReader` whose
:attr:`~SalvagedReader.note` says so (exact with ``metadata.yaml``, else estimated; docs/bags.md, "Damaged …")."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import BagError


@dataclass
class Channel:
    """A connection as a scanner found it: ROS 2 type name, definition (``msg``/``idl``/"" text) and digest."""

    id: int
    topic: str
    msgtype: str
    definition_format: str = ""
    definition: str = ""
    digest: str = ""


@dataclass
class Scan:
    """What a scanner read from a damaged file.

    Attributes
    ----------
    channels : connection id → :class:`Channel`; counts : connection id → complete messages
    blocks, read_block : units to read again (chunks, pages) and block → ``(connection id, receive [ns], raw)``
    file_bytes, read_bytes : file size, and bytes up to the end of the last complete record
    data_bytes : where the data ended when whole, if the file says (ROS 1 ``index_pos``, SQLite page count), else None
    data_complete : the data ended properly (only the index or summary is damaged)
    first_ns, last_ns : receive times of the first and last complete messages
    ros2 : CDR messages (rosbag2) rather than ROS 1
    """

    channels: dict[int, Channel]
    counts: dict[int, int]
    blocks: list[Any]
    read_block: Callable[[Any], list[tuple[int, int, bytes]]]
    file_bytes: int
    read_bytes: int
    data_complete: bool
    first_ns: int = 0
    last_ns: int = 0
    ros2: bool = True
    data_bytes: int | None = None
    extra_notes: list[str] = field(default_factory=list)

    @property
    def messages(self) -> int:
        return sum(self.counts.values())


def _typestore(channels: Sequence[Channel]) -> Any:
    """The message types of the channels from their own definitions where they carry them, else rosbags' latest."""
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    types: dict = {}
    for ch in channels:
        try:
            if ch.definition_format == "msg" and ch.definition:
                types.update(get_types_from_msg(ch.definition, ch.msgtype))
            elif ch.definition_format == "idl" and ch.definition:
                separator = "=" * 80 + "\n"
                parts = ch.definition.split(separator)[1:] if ch.definition.startswith(separator) else [
                    "IDL: x\n" + ch.definition]
                for part in parts:
                    types.update(get_types_from_idl(part.split("\n", 1)[1]))
        except Exception:  # an unparsable definition: the standard types below serve
            continue
    store = get_typestore(Stores.LATEST)
    if not types:
        return store
    fresh = get_typestore(Stores.EMPTY)
    fresh.register({**store.fielddefs, **types})  # the bag's own definitions win (ROS 1 headers have a seq)
    return fresh


class SalvagedReader:
    """The complete messages of a damaged bag, read like rosbags' ``AnyReader`` (the subset the reader uses)."""

    def __init__(self, scan: Scan, note: str) -> None:
        from rosbags.interfaces import (
            Connection,
            ConnectionExtRosbag1,
            ConnectionExtRosbag2,
            MessageDefinition,
            MessageDefinitionFormat,
            TopicInfo,
        )

        self.scan = scan
        self.note = note
        self.is2 = scan.ros2
        self.readers: list[Any] = []  # no rosbags storage behind it: the mcap fast path does not apply
        self.typestore = _typestore(list(scan.channels.values()))
        formats = {"msg": MessageDefinitionFormat.MSG, "idl": MessageDefinitionFormat.IDL}
        self.connections = []
        for ch in scan.channels.values():
            msgdef = MessageDefinition(formats.get(ch.definition_format, MessageDefinitionFormat.NONE), ch.definition)
            ext = ConnectionExtRosbag2("cdr", []) if scan.ros2 else ConnectionExtRosbag1(None, None)
            self.connections.append(Connection(ch.id, ch.topic, ch.msgtype, msgdef, ch.digest,
                                               scan.counts.get(ch.id, 0), ext, self))
        self.topics = {}
        for conn in self.connections:
            group = [c for c in self.connections if c.topic == conn.topic]
            types = {c.msgtype for c in group}
            self.topics[conn.topic] = TopicInfo(types.pop() if len(types) == 1 else None, group[0].msgdef,
                                                sum(c.msgcount for c in group), group)

    def deserialize(self, raw: bytes, msgtype: str) -> object:
        if self.is2:
            return self.typestore.deserialize_cdr(raw, msgtype)
        return self.typestore.deserialize_ros1(raw, msgtype)

    def messages(self, connections: Sequence[Any] = ()) -> Iterator[tuple[Any, int, bytes]]:
        by_id = {c.id: c for c in (connections or self.connections)}
        for block in self.scan.blocks:
            for cid, time_ns, raw in self.scan.read_block(block):
                conn = by_id.get(cid)
                if conn is not None:
                    yield conn, time_ns, raw

    def close(self) -> None:
        """Nothing to close: every block opens and closes its file."""


def _metadata_counts(directory: Path | None) -> tuple[dict[str, int], int | None]:
    """Topic → message count and the end time [ns] from a rosbag2 ``metadata.yaml``, if there is a readable one."""
    import yaml

    if directory is None or not (directory / "metadata.yaml").is_file():
        return {}, None
    try:
        info = yaml.safe_load((directory / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        counts = {t["topic_metadata"]["name"]: int(t["message_count"]) for t in info["topics_with_message_count"]}
        end = int(info["starting_time"]["nanoseconds_since_epoch"]) + int(info["duration"]["nanoseconds"])
        return counts, end
    except Exception:  # a damaged metadata.yaml: estimate from the bytes instead
        return {}, None


def loss_note(scan: Scan, path: Path, directory: Path | None) -> str:
    """What was read and what was lost, per topic where ``metadata.yaml`` knows the counts."""
    seconds = (scan.last_ns - scan.first_ns) * 1e-9
    head = (f"{path.name} is damaged ({'index/summary' if scan.data_complete else 'cut short'}): read "
            f"{scan.messages} complete messages ({seconds:.1f} s) from the first {scan.read_bytes} of "
            f"{scan.file_bytes} bytes")
    counts, end_ns = _metadata_counts(directory)
    if counts:
        found: dict[str, int] = {}
        for cid, n in scan.counts.items():
            topic = scan.channels[cid].topic if cid in scan.channels else "?"
            found[topic] = found.get(topic, 0) + n
        lost = {t: counts[t] - found.get(t, 0) for t in counts if counts[t] > found.get(t, 0)}
        after = f", the last {(end_ns - scan.last_ns) * 1e-9:.1f} s" if end_ns and end_ns > scan.last_ns else ""
        if not lost:
            return head + ": nothing lost (every message metadata.yaml counts was read)"
        listed = ", ".join(f"{t} {n} of {counts[t]}" for t, n in lost.items())
        return head + f"; lost (metadata.yaml counts): {listed}{after}"
    if scan.data_complete:
        return head + ": the data end properly, nothing lost"
    known = scan.data_bytes is not None and scan.data_bytes > scan.read_bytes
    missing = (scan.data_bytes if known else scan.file_bytes) - scan.read_bytes
    lost_messages = round(missing * scan.messages / max(scan.read_bytes, 1))
    lost_s = lost_messages * seconds / max(scan.messages, 1)
    if known:
        return head + (f"; the file announces {missing} more bytes of data: about {lost_messages} messages "
                       f"(≈{lost_s:.1f} s) lost")
    return head + (f"; it ends inside a record: about {lost_messages} messages (≈{lost_s:.1f} s) in its last "
                   f"{missing} bytes are lost, and whatever was recorded after the cut")


def _storage_file(path: Path) -> tuple[Path, Path | None] | None:
    """(the data file, the rosbag2 directory or None) of a bag path, or None when there is nothing to salvage."""
    if path.is_file():
        return path, (path.parent if (path.parent / "metadata.yaml").is_file() and path.suffix != ".bag" else None)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix in (".mcap", ".db3") and p.is_file())
        if len(files) == 1:
            return files[0], path
    return None


def salvage(path: Path) -> SalvagedReader | None:
    """A reader over the complete messages of a bag rosbags cannot open, or None (not a file this can read); BagError
    when a salvageable file holds no complete message."""
    found = _storage_file(path)
    if found is None:
        return None
    data, directory = found
    if data.suffix == ".mcap":
        from .scan_mcap import scan_mcap as scanner
    elif data.suffix == ".bag":
        from .scan_ros1 import scan_ros1 as scanner
    elif data.suffix == ".db3":
        from .scan_sqlite import scan_sqlite as scanner
    else:
        return None
    scan = scanner(data)
    if scan is None:
        return None
    if scan.messages == 0:
        raise BagError(f"{data.name} is damaged and holds no complete message (read {scan.read_bytes} of "
                       f"{scan.file_bytes} bytes): re-record it")
    note = loss_note(scan, data, directory)
    return SalvagedReader(scan, "; ".join([note, *scan.extra_notes]))
