"""Results folders written atomically, every file stamped with the run that wrote it, nothing stale left beside it.

Staging, stamping (:func:`stamp`: :class:`RunRecord` as ``run:``, a ``# imu-noise-id run:`` line, a ``<meta>`` or a
PNG ``tEXt`` chunk), the manifest (:data:`MANIFEST`), what a run supersedes and ``NAME.stale``: docs/analysis.md,
"Results folders".
"""

from __future__ import annotations

import datetime as dt
import html
import json
import os
import shutil
import struct
import sys
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import yaml

#: The manifest of a results folder.
MANIFEST = "imu_noise_id_runs.yaml"
#: Prefix of the staging folders inside a results folder.
STAGING = ".imu_noise_id_partial-"
#: Names (glob patterns) the commands write; unaccounted files matching one that are this package's are marked stale.
KNOWN_OUTPUTS = ("imu.yaml", "model.yaml", "report.html", "allan.csv", "hadamard.csv", "total.csv", "modified.csv",
                 "allan.png", "allan_model.png", "hypotheses.yaml", "hypotheses_probabilities.csv",
                 "hypotheses_probabilities.png", "cmkf.yaml", "cmkf.csv", "cmkf.png", "criteria.json",
                 "criteria_case*.png", "exports/*")
#: Text in the first kilobytes of a file that marks it as written by this package.
SIGNATURES = (b"imu-noise-id", b"imu_noise_id", b"variance of rate samples", b"source_hypotheses",
              b"axis,t_s,hypothesis", b"command: analyze", b"command: fit", b"command: loop", b"error_probability",
              b"accel_bias_std", b"IMU noise analysis", b"closed loop")
#: Package YAML files that take a ``run:`` key (the others get a comment line).
OWN_YAML = ("imu.yaml", "model.yaml", "hypotheses.yaml", "cmkf.yaml")


def now() -> str:
    """The current UTC time, ISO 8601 to the second."""
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat()


@dataclass
class RunRecord:
    """One run of a command: what it read, how it was called, when, and whether it finished."""

    command: str
    argv: list[str]
    source: str | None
    topic: str | None
    options: dict
    started: str
    finished: str | None = None
    completed: bool = False
    run_id: str = field(default_factory=lambda: f"{dt.datetime.now(dt.timezone.utc):%Y%m%dT%H%M%S%f}-{os.getpid()}")

    def as_dict(self) -> dict:
        from .. import __version__

        return {"id": self.run_id, "command": self.command, "source": self.source, "topic": self.topic,
                "argv": list(self.argv), "options": self.options, "started": self.started,
                "finished": self.finished, "completed": self.completed, "imu_noise_id": __version__}


def _png_text(data: bytes, key: str, text: str) -> bytes:
    """``data`` (a PNG) with a tEXt chunk ``key``/``text`` after its header chunk."""
    payload = key.encode("latin-1") + b"\x00" + text.encode("latin-1", errors="replace")
    chunk = struct.pack(">I", len(payload)) + b"tEXt" + payload + struct.pack(">I", zlib.crc32(b"tEXt" + payload))
    ihdr_end = 8 + 8 + struct.unpack(">I", data[8:12])[0] + 4
    return data[:ihdr_end] + chunk + data[ihdr_end:]


def _with_run_footer(text: str, record: dict) -> str:
    """``text`` (HTML) with the run's command, id and times shown as its last paragraph: the time a reader sees is
    the run record's, not the moment a writer rendered the page."""
    footer = (f"<p class=small id=run>Written by imu-noise-id {html.escape(str(record.get('command')))}, "
              f"run {html.escape(str(record.get('id')))}, started {html.escape(str(record.get('started')))}, "
              f"finished {html.escape(str(record.get('finished')))}.</p>")
    at = text.rfind("</body>")
    return text[:at] + footer + text[at:] if at >= 0 else text + footer


def stamp(path: Path, relative: str, record: dict) -> None:
    """Put ``record`` into the file ``path`` (named ``relative`` in the results folder) in its format's way."""
    line = json.dumps(record, separators=(",", ":"))
    suffix = path.suffix.lower()
    if suffix == ".png":
        _write_atomically(path, _png_text(path.read_bytes(), "imu-noise-id run", line))
        return
    text = path.read_text(encoding="utf-8")
    if suffix == ".json":
        text = json.dumps({"run": record, **json.loads(text)})
    elif suffix == ".html":
        meta = f'<meta name="imu-noise-id-run" content="{html.escape(line)}">'
        at = text.find("<head>")
        text = text[: at + 6] + meta + text[at + 6 :] if at >= 0 else meta + text
        text = _with_run_footer(text, record)
    elif suffix in (".yaml", ".yml") and relative in OWN_YAML:
        lines = text.splitlines(keepends=True)
        head = 0
        while head < len(lines) and lines[head].startswith("#"):
            head += 1
        block = yaml.safe_dump({"run": record}, sort_keys=False, allow_unicode=True, width=120)
        text = "".join(lines[:head]) + block + "".join(lines[head:])
    else:  # CSV and foreign formats: a comment line (after a %YAML directive, which must come first)
        comment = f"# imu-noise-id run: {line}\n"
        first, _, rest = text.partition("\n")
        text = f"{first}\n{comment}{rest}" if first.startswith("%YAML") else comment + text
    _write_atomically(path, text.encode("utf-8"))


def _files(root: Path) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())


def _read_manifest(out: Path) -> list[dict]:
    try:
        runs = yaml.safe_load((out / MANIFEST).read_text()).get("runs", [])
        return [r for r in runs if isinstance(r, dict) and isinstance(r.get("files"), list)]
    except (OSError, yaml.YAMLError, AttributeError):
        return []


def _write_atomically(path: Path, data: bytes | str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
    os.replace(tmp, path)


def _head(path: Path) -> bytes:
    with path.open("rb") as f:
        return f.read(4096)


def _legacy(out: Path, accounted: set[str]) -> set[str]:
    """Files with this package's output names that no manifest accounts for and that are recognisably its own."""
    found = {p.relative_to(out).as_posix(): p for pattern in KNOWN_OUTPUTS for p in out.glob(pattern) if p.is_file()}
    found = {name: p for name, p in found.items() if name not in accounted}
    ours = {name for name, p in found.items() if p.suffix != ".png" and any(sig in _head(p) for sig in SIGNATURES)}
    return ours | ({name for name in found if name.endswith(".png")} if ours else set())


def _supersedes(new: RunRecord, new_files: set[str], old: dict) -> bool:
    run = old.get("run", {})
    return (run.get("command") == new.command or run.get("source") != new.source or run.get("topic") != new.topic
            or bool(new_files & set(old["files"])))


class ResultsFolder:
    """``with ResultsFolder(out, record) as staging:`` write into ``staging``; on success the files are stamped and
    moved into ``out`` and what they supersede is removed; on an exception ``out`` is left as it was."""

    def __init__(self, out: Path, record: RunRecord) -> None:
        self.out = Path(out)
        self.record = record
        self.staging = self.out / f"{STAGING}{record.run_id}"
        self.removed: list[str] = []
        self.marked: list[str] = []

    def __enter__(self) -> Path:
        self.out.mkdir(parents=True, exist_ok=True)
        for old in self.out.glob(f"{STAGING}*"):  # left by a run that was killed
            shutil.rmtree(old, ignore_errors=True)
        self.staging.mkdir()
        return self.staging

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        try:
            if exc_type is None:
                self._commit()
        finally:
            shutil.rmtree(self.staging, ignore_errors=True)

    def _commit(self) -> None:
        files = _files(self.staging)
        record = self.record
        record.finished, record.completed = now(), True
        for name in files:
            stamp(self.staging / name, name, record.as_dict())
        new = set(files)
        kept, stale = [], set()
        for old in _read_manifest(self.out):
            if _supersedes(record, new, old):
                stale |= set(old["files"]) - new
            else:
                kept.append(old)
        accounted = new | {f for old in kept for f in old["files"]}
        unknown = _legacy(self.out, accounted | stale)
        entry = {"run": record.as_dict(), "files": files}
        pending = {**entry, "run": {**entry["run"], "completed": False}}  # until every file is in place
        _write_atomically(self.out / MANIFEST, yaml.safe_dump({"runs": [*kept, pending]}, sort_keys=False))
        for name in files:
            target = self.out / name
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self.staging / name, target)
        for name in sorted(stale):
            if (self.out / name).is_file():
                (self.out / name).unlink()
                self.removed.append(name)
        for name in sorted(unknown):
            os.replace(self.out / name, self.out / f"{name}.stale")
            self.marked.append(name)
        _write_atomically(self.out / MANIFEST, yaml.safe_dump({"runs": [*kept, entry]}, sort_keys=False))

    def report(self) -> None:
        """Say on stderr what an earlier run left that this one removed or marked."""
        if self.removed:
            print(f"note: removed {len(self.removed)} file(s) an earlier run left in {self.out}/: "
                  + ", ".join(self.removed), file=sys.stderr)
        if self.marked:
            print(f"note: {len(self.marked)} file(s) in {self.out}/ were not written by this run and are renamed "
                  "*.stale: " + ", ".join(self.marked), file=sys.stderr)


def options_of(namespace: object, skip: tuple[str, ...] = ()) -> dict:
    """The command's options as plain values (paths as text), for the run record."""
    out = {}
    for key, value in sorted(vars(namespace).items()):
        if key in ("run", "command", "argv", "started", *skip) or callable(value):
            continue
        out[key] = str(value) if isinstance(value, Path) else value
    return json.loads(json.dumps(out, default=str))


__all__ = ["MANIFEST", "ResultsFolder", "RunRecord", "now", "options_of", "stamp"]
