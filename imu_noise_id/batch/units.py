"""Units of work: every (bag, IMU topic) pair of the inputs, the options every unit runs with, and the content hash
that decides a rerun."""

from __future__ import annotations

import dataclasses
import glob
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from ..bag.topics import BAG_SUFFIXES, IMU_TYPE, open_bag
from ..core.errors import InputError
from ..pipelines.analyze import AnalyzeOptions


@dataclass(frozen=True)
class BatchOptions:
    """What every unit of a batch is asked: ``analyze``'s options, shipped as they are to the Dask workers.

    Attributes
    ----------
    analysis : the analysis (``jobs`` set to 1: a unit's axes run one after another in its worker)
    rate : the declared sample rate [Hz] (``--rate``), or None: estimated from the stamps
    temperature_topic : the sensor_msgs/Temperature topic of the loop's thermal test (None: a bag's only one)
    overbound_exports : also write the overbound's exports (``--overbound``)
    limits : noise-density limits [u/√Hz] per sensor ("gyro", "accel") from ``--spec``: each axis is tested against
        its sensor's as ``compare --spec`` does (:func:`~imu_noise_id.pipelines.compare.beyond_spec`); None: not
    """

    analysis: AnalyzeOptions = field(default_factory=AnalyzeOptions)
    rate: float | None = None
    temperature_topic: str | None = None
    overbound_exports: bool = False
    limits: dict[str, float] | None = None

    def __post_init__(self) -> None:
        if self.analysis.jobs != 1:
            object.__setattr__(self, "analysis", dataclasses.replace(self.analysis, jobs=1))

    def as_dict(self) -> dict:
        """Every option as plain JSON values, nested as the dataclasses are (the same text for equal options in any
        process: the content hash and ``unit.json``); an unbounded ``--span`` end is the string ``"inf"``."""

        def plain(value):
            if isinstance(value, float) and not math.isfinite(value):
                return str(value)
            if isinstance(value, dict):
                return {k: plain(v) for k, v in value.items()}
            if isinstance(value, list | tuple):
                return [plain(v) for v in value]
            return value

        return plain(dataclasses.asdict(self))


@dataclass(frozen=True)
class Unit:
    """One bag and one IMU topic, with the folder its outputs go to.

    Attributes
    ----------
    bag : the bag (file or rosbag2 directory)
    topic : the sensor_msgs/Imu topic (None: the bag's only one, or the bag could not be listed)
    name : the unit's folder name under the batch output (bag name, topic with '/' → '_')
    """

    bag: Path
    topic: str | None
    name: str


def _unit_name(bag: Path, topic: str | None) -> str:
    stem = bag.name if bag.is_dir() else bag.stem
    return stem if not topic else f"{stem}{topic.replace('/', '_')}"


def imu_topics(bag: Path) -> list[str]:
    """The bag's sensor_msgs/Imu topics (raises :class:`~imu_noise_id.bag.errors.BagError` if unreadable)."""
    with open_bag(bag) as reader:
        return sorted({c.topic for c in reader.connections if c.msgtype == IMU_TYPE})


def _expand(pattern: str) -> list[Path]:
    """The paths ``pattern`` names: itself, or a glob's matches less the files that are not bags (a README beside the
    bags is no unit; a directory may be a rosbag2 bag, a corrupt ``.mcap`` fails as a unit). InputError if none."""
    matches = [Path(p) for p in sorted(glob.glob(str(Path(pattern).expanduser()), recursive=True))]
    if not matches:
        raise InputError(f"{pattern!r}: no such bag (nothing matches)")
    found = ([p for p in matches if not p.is_file() or p.suffix in BAG_SUFFIXES] if glob.has_magic(pattern)
             else matches)
    if not found:
        raise InputError(f"{pattern!r}: no bag among the {len(matches)} files it matches (a bag is a "
                         f"{', '.join(BAG_SUFFIXES)} file or a rosbag2 directory)")
    return found


#: The suffixes of a YAML manifest (:func:`read_manifest`; any other is read as one path per line).
YAML_MANIFEST_SUFFIXES = (".yaml", ".yml")
#: The suffixes of a manifest: such a file named among the bags is refused, pointed at --manifest.
MANIFEST_SUFFIXES = (*YAML_MANIFEST_SUFFIXES, ".txt")


def read_manifest(path: Path) -> list[tuple[str, list[str] | None]]:
    """(bag path or glob, topics or None) from a manifest: YAML ``bags: [{path: …, topics: [...]}, …]`` or one
    path per line (``#`` comments)."""
    if not path.is_file():
        raise InputError(f"--manifest {str(path)!r}: no such file")
    text = path.read_text()
    if path.suffix in YAML_MANIFEST_SUFFIXES:
        try:
            doc = yaml.safe_load(text) or {}
            entries = doc["bags"]
            return [(str(e["path"]), list(e["topics"]) if e.get("topics") else None) if isinstance(e, dict)
                    else (str(e), None) for e in entries]
        except (yaml.YAMLError, KeyError, TypeError) as exc:
            raise InputError(f"--manifest {str(path)!r}: expected 'bags: [{{path: …, topics: […]}}, …]' "
                             f"({exc})") from None
    base = path.parent
    lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()]
    return [(str(p if Path(p).is_absolute() else base / p), None) for p in lines if p]


def discover_units(inputs: list[str], topics: list[str] | None, manifest: Path | None = None) -> list[Unit]:
    """The units of ``inputs`` (paths or globs) and the manifest's entries; ``topics`` None or ``["all"]``: every IMU
    topic of each bag (an unlistable bag is one unit, failing with the reader's message), else those in every bag."""
    for pattern in inputs:  # named itself (a glob's other files stay units, failing as a bag would)
        named = Path(pattern).expanduser()
        if named.is_file() and named.suffix in MANIFEST_SUFFIXES:
            raise InputError(f"{pattern!r} is a list of bags, not a bag: give it as --manifest {pattern}")
    entries = [(p, None) for p in inputs] + (read_manifest(manifest) if manifest is not None else [])
    if not entries:
        raise InputError("no bags given: pass BAG_OR_GLOB arguments or --manifest FILE")
    units: dict[str, Unit] = {}
    for pattern, own_topics in entries:
        for bag in _expand(pattern):
            wanted = own_topics or (None if topics in (None, ["all"]) else topics)
            if wanted is None:
                try:
                    wanted = imu_topics(bag) or [None]
                except InputError:
                    wanted = [None]
            for topic in wanted:
                unit = Unit(bag.resolve(), topic, _unit_name(bag, topic if len(wanted) > 1 else None))
                if unit.name in units and units[unit.name].bag != unit.bag:
                    unit = Unit(unit.bag, topic, f"{unit.name}_{hashlib.sha1(str(unit.bag).encode()).hexdigest()[:6]}")
                units[unit.name] = unit
    return list(units.values())


def content_hash(unit: Unit, options: BatchOptions) -> str:
    """SHA-256 of the bag's bytes (every file of a rosbag2 directory), the topic and every option
    (:meth:`BatchOptions.as_dict`): a changed option runs the unit again."""
    h = hashlib.sha256()
    files = sorted(p for p in unit.bag.rglob("*") if p.is_file()) if unit.bag.is_dir() else [unit.bag]
    for f in files:
        h.update(str(f.relative_to(unit.bag) if unit.bag.is_dir() else f.name).encode())
        with f.open("rb") as fh:
            for chunk in iter(lambda fh=fh: fh.read(1 << 20), b""):
                h.update(chunk)
    h.update(json.dumps({"topic": unit.topic, "options": options.as_dict()}, sort_keys=True, allow_nan=False).encode())
    return h.hexdigest()
