"""Vectorised decoding of serialised ROS messages (CDR or ROS 1) with numpy at fixed byte offsets: a flat type's
messages grouped by layout and read through strided views, the rest fully deserialised, so values always equal the
full deserialiser's (how: docs/bags.md, "How the fast path works")."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: Primitive types that have a fixed size: name → (numpy kind, size in bytes).
PRIMITIVES: dict[str, tuple[str, int]] = {
    "bool": ("u1", 1), "byte": ("u1", 1), "char": ("u1", 1), "int8": ("i1", 1), "uint8": ("u1", 1),
    "int16": ("i2", 2), "uint16": ("u2", 2), "int32": ("i4", 4), "uint32": ("u4", 4),
    "int64": ("i8", 8), "uint64": ("u8", 8), "float32": ("f4", 4), "float64": ("f8", 8),
}  # fmt: skip

_BASE, _NAME, _ARRAY = 1, 2, 3  # rosbags' Nodetype values

#: Layouts tried per message length and batch before the remaining messages are fully deserialised.
MAX_LAYOUTS_PER_LENGTH = 8


@dataclass(frozen=True)
class Leaf:
    """One primitive field (``count`` elements, ``count == 1`` for a scalar) or a string of a flat message."""

    path: str
    kind: str  # a key of PRIMITIVES, or "string"
    count: int = 1


class NotFlatError(TypeError):
    """The type contains sequences, bounded strings or other parts without a fixed layout per string length."""


def flatten(fielddefs: Mapping[str, tuple], msgtype: str, prefix: str = "") -> list[Leaf]:
    """Leaves of ``msgtype`` in serialisation order from a typestore's ``fielddefs``; NotFlatError for a sequence, an
    array of non-primitives, a bounded string or an unknown type."""
    leaves: list[Leaf] = []
    for name, (node, detail) in fielddefs[msgtype][1]:
        path = f"{prefix}{name}"
        if node == _NAME:
            leaves.extend(flatten(fielddefs, detail, f"{path}."))
        elif node == _BASE and detail[0] == "string" and detail[1] == 0:
            leaves.append(Leaf(path, "string"))
        elif node == _BASE and detail[0] in PRIMITIVES:
            leaves.append(Leaf(path, detail[0]))
        elif node == _ARRAY and detail[0][0] == _BASE and detail[0][1][0] in PRIMITIVES:
            leaves.append(Leaf(path, detail[0][1][0], int(detail[1])))
        else:
            raise NotFlatError(f"{msgtype}.{path} has no fixed layout")
    return leaves


def _align(pos: int, size: int) -> int:
    return (pos + size - 1) // size * size


def walk_layout(raw: bytes | memoryview, leaves: Sequence[Leaf], ros1: bool) -> tuple[list[int], int] | None:
    """Byte offset of every leaf in ``raw`` (strings: of the length field) and the end; None if ``raw`` is too short."""
    base = 0 if ros1 else 4
    pos = base
    offsets: list[int] = []
    size = len(raw)
    for leaf in leaves:
        if leaf.kind == "string":
            if not ros1:
                pos = base + _align(pos - base, 4)
            if pos + 4 > size:
                return None
            offsets.append(pos)
            pos += 4 + int.from_bytes(raw[pos : pos + 4], "big" if not ros1 and raw[1] == 0 else "little")
        else:
            item = PRIMITIVES[leaf.kind][1]
            if not ros1:
                pos = base + _align(pos - base, item)
            offsets.append(pos)
            pos += item * leaf.count
        if pos > size:
            return None
    return offsets, pos


@dataclass
class DecodeStats:
    """How many messages went through the numpy path and how many through full deserialisation."""

    fast: int = 0
    fallback: int = 0


class FlatDecoder:
    """Decode chosen leaves of many serialised messages of one type into numpy arrays.

    Parameters
    ----------
    fielddefs, msgtype : the bag typestore's definitions and the type, e.g. ``'sensor_msgs/msg/Imu'``
    outputs : output name → leaf paths filling its columns, e.g. ``{'gyro': ('angular_velocity.x', …)}``; an array
        leaf fills ``count`` columns, an element (``'orientation_covariance[0]'``) one
    strings : string leaf paths whose first value is wanted, e.g. ``('header.frame_id',)``
    ros1 : ROS 1 serialisation instead of CDR
    deserialize : the full deserialiser ``(raw, msgtype) -> message`` for what numpy cannot take
    fast : False forces full deserialisation (reference path)
    """

    def __init__(
        self,
        fielddefs: Mapping[str, tuple],
        msgtype: str,
        outputs: Mapping[str, Sequence[str]],
        *,
        strings: Sequence[str],
        ros1: bool,
        deserialize: Callable[[bytes, str], object],
        fast: bool = True,
    ) -> None:
        self.msgtype = msgtype
        self.ros1 = ros1
        self.deserialize = deserialize
        self.outputs = {name: tuple(paths) for name, paths in outputs.items()}
        self.string_paths = tuple(strings)
        self.stats = DecodeStats()
        self.strings: dict[str, str] = {}
        self.varying_strings: set[str] = set()
        try:
            self.leaves: list[Leaf] | None = flatten(fielddefs, msgtype)
        except NotFlatError:
            self.leaves = None
        self.fast = fast and self.leaves is not None
        by_path = {leaf.path: i for i, leaf in enumerate(self.leaves or [])}
        self._leaf_index = {p: by_path.get(_split_index(p)[0]) for paths in self.outputs.values() for p in paths}
        self._leaf_index.update({p: by_path.get(p) for p in self.string_paths})
        for p, i in self._leaf_index.items():  # an element index must lie inside its array leaf
            index = _split_index(p)[1]
            if i is not None and index is not None and not 0 <= index < self.leaves[i].count:
                self._leaf_index[p] = None
        if self.leaves is not None and any(i is None for i in self._leaf_index.values()):
            self.fast = False

    def widths(self, reference: Mapping[str, tuple] | None = None) -> dict[str, int]:
        """Number of columns of every output, from the leaves (of ``reference`` fielddefs if the type is not flat)."""
        leaves = self.leaves
        if leaves is None and reference is not None:
            leaves = flatten(reference, self.msgtype)
        counts = {leaf.path: leaf.count for leaf in leaves or []}
        return {
            name: sum(1 if _split_index(p)[1] is not None else counts.get(p, 1) for p in paths)
            for name, paths in self.outputs.items()
        }

    # --- numpy path --------------------------------------------------------------------------------------
    def decode(self, raws: Sequence[bytes], out: Mapping[str, np.ndarray]) -> None:
        """Decode ``raws`` into the rows ``0 … len(raws) - 1`` of the arrays in ``out`` (one per output)."""
        if not raws:
            return
        if not self.fast:
            self._fallback(raws, range(len(raws)), out)
            return
        lengths = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
        unique = np.unique(lengths)
        for length in unique:
            if unique.size == 1:
                rows = np.arange(len(raws))
                joined = b"".join(raws)
            else:
                rows = np.flatnonzero(lengths == length)
                joined = b"".join([raws[i] for i in rows])
            for _ in range(MAX_LAYOUTS_PER_LENGTH):
                rows = self._decode_group(joined, int(length), rows, raws, out)
                if rows.size == 0:
                    break
                joined = b"".join([raws[i] for i in rows])
            else:
                self._fallback(raws, rows, out)

    def _decode_group(
        self,
        joined: bytes,
        length: int,
        rows: np.ndarray,
        raws: Sequence[bytes],
        out: Mapping[str, np.ndarray],
    ) -> np.ndarray:
        """Decode the rows that share the layout of the first one; return the rows left for another pass."""
        n = rows.size
        assert self.leaves is not None
        first = raws[rows[0]]
        layout = walk_layout(first, self.leaves, self.ros1) if length >= 4 else None
        if layout is None or length - layout[1] > 3 or (not self.ros1 and first[1] not in (0, 1)):
            self._fallback(raws, rows[:1], out)
            return rows[1:]
        offsets = layout[0]
        order = "<" if self.ros1 or first[1] == 1 else ">"
        good = np.ones(n, dtype=bool)
        if not self.ros1:
            header = np.ndarray((n,), dtype="<u4", buffer=joined, offset=0, strides=(length,))
            good &= header == int.from_bytes(first[:4], "little")
        for i, leaf in enumerate(self.leaves):
            if leaf.kind == "string":
                lens = np.ndarray((n,), dtype=f"{order}u4", buffer=joined, offset=offsets[i], strides=(length,))
                good &= lens == lens[0]
        rest = rows[~good]
        if rest.size:
            # Re-join only the good rows so that the strided views below see one layout.
            rows = rows[good]
            joined = b"".join([raws[i] for i in rows])
            n = rows.size
        targets = rows
        for name, paths in self.outputs.items():
            dest = out[name]
            col = 0
            for path in paths:
                i = self._leaf_index[path]
                leaf = self.leaves[i]
                kind, size = PRIMITIVES[leaf.kind]
                index = _split_index(path)[1]
                count, offset = (leaf.count, offsets[i]) if index is None else (1, offsets[i] + index * size)
                view = np.ndarray(
                    (n, count), dtype=f"{order}{kind}", buffer=joined, offset=offset, strides=(length, size)
                )
                if dest.ndim == 1:
                    dest[targets] = view[:, 0]
                else:
                    dest[targets, col : col + count] = view
                col += count
        for path in self.string_paths:
            i = self._leaf_index[path]
            strlen = int.from_bytes(first[offsets[i] : offsets[i] + 4], "little" if order == "<" else "big")
            text_len = strlen if self.ros1 else max(strlen - 1, 0)
            block = np.ndarray((n, strlen), dtype="u1", buffer=joined, offset=offsets[i] + 4, strides=(length, 1))
            if n > 1 and not (block == block[0]).all():
                self.varying_strings.add(path)
            value = bytes(first[offsets[i] + 4 : offsets[i] + 4 + text_len]).decode("utf-8", "replace")
            self._note_string(path, value)
        self.stats.fast += n
        return rest

    # --- full deserialisation ----------------------------------------------------------------------------
    def _note_string(self, path: str, value: str) -> None:
        if path not in self.strings:
            self.strings[path] = value
        elif self.strings[path] != value:
            self.varying_strings.add(path)

    def _fallback(self, raws: Sequence[bytes], rows: Sequence[int], out: Mapping[str, np.ndarray]) -> None:
        for row in rows:
            msg = self.deserialize(raws[row], self.msgtype)
            for name, paths in self.outputs.items():
                values = np.concatenate([np.atleast_1d(np.asarray(_get(msg, p))) for p in paths])
                dest = out[name]
                if dest.ndim == 1:
                    dest[row] = values[0]
                else:
                    dest[row, :] = values
            for path in self.string_paths:
                self._note_string(path, str(_get(msg, path)))
        self.stats.fallback += len(rows)


def _split_index(path: str) -> tuple[str, int | None]:
    """``'a.b[3]'`` → ``('a.b', 3)``; a path without an element index → ``(path, None)``."""
    if path.endswith("]") and "[" in path:
        base, _, index = path[:-1].rpartition("[")
        return base, int(index)
    return path, None


def _get(msg: object, path: str) -> object:
    path, index = _split_index(path)
    for part in path.split("."):
        msg = getattr(msg, part)
    return msg if index is None else msg[index]
