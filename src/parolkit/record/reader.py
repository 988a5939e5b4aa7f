"""Read a recording back: every message in file order, decoded, and the status stream as arrays.

The file is read as a stream (record by record), so a recording whose writer was killed
mid-way is read up to its last complete chunk (:attr:`Recording.complete` is then False);
ROS 2 messages are decoded with mcap-ros2-support.  Recordings made before every channel was
CDR (the status, commands, acks and plans as JSON channels) are read too: JSON channels are
decoded with :mod:`json`, and :func:`load_recording` gives the same dicts either way.
"""

from __future__ import annotations

import json
import os
import struct
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from mcap.exceptions import InvalidMagic, McapError
from mcap.records import Channel, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from numpy.typing import NDArray
from zstandard import ZstdError

from parolkit.errors import ParolkitValueError
from parolkit.record import messages
from parolkit.record.schemas import (
    RECORDING_METADATA,
    TOPIC_ACKS,
    TOPIC_COMMANDS,
    TOPIC_JOINT_STATES,
    TOPIC_PLANS,
    TOPIC_STATUS,
)

__all__ = ["RecordedMessage", "Recording", "iter_messages", "load_recording", "warn_if_damaged"]


@dataclass(frozen=True)
class RecordedMessage:
    """One message: topic, log time (UNIX ns), sequence (the controller tick), decoded value."""

    topic: str
    log_time_ns: int
    sequence: int
    value: Any


#: What the MCAP reader and its decompressors raise on a damaged file (a torn end, a corrupted
#: chunk, a file that is not MCAP at all): the read stops there and keeps everything before.
#: lz4 reports a corrupted frame as a RuntimeError; a corrupted length or size field asks for
#: more memory than exists (OverflowError, MemoryError) although reads are capped at the file.
_DAMAGED = (McapError, EOFError, ValueError, KeyError, struct.error, ZstdError, RuntimeError, OverflowError,
            MemoryError)


#: length of the magic bytes every MCAP file starts with
_MAGIC_BYTES = 8


class _BoundedFile:
    """A binary file whose reads never ask for more than is left in it: a corrupted length
    field (up to 2**64) would otherwise make the MCAP reader allocate that much."""

    def __init__(self, f: BinaryIO, size: int) -> None:
        self._f = f
        self._size = size

    def read(self, n: int = -1) -> bytes:
        left = self._size - self._f.tell()
        return self._f.read(left if n < 0 or n > left else n)


class _Scan:
    """Streaming pass over a file; remembers whether it reached the footer, and where and why
    the read stopped early (``error``, ``stopped_at``: bytes read before the damage)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.complete = False
        self.error: str | None = None
        self.stopped_at = 0
        self.size = 0
        self.not_mcap = False
        self.metadata: dict[str, dict[str, str]] = {}

    def messages(self) -> Iterator[RecordedMessage]:
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        factory = DecoderFactory()
        decoders: dict[int, Any] = {}
        with open(self.path, "rb") as f:
            self.size = os.fstat(f.fileno()).st_size
            reader = StreamReader(_BoundedFile(f, self.size), validate_crcs=True,  # type: ignore[arg-type]
                                  record_size_limit=self.size)
            try:
                for rec in reader.records:
                    if isinstance(rec, Schema):
                        schemas[rec.id] = rec
                    elif isinstance(rec, Channel):
                        channels[rec.id] = rec
                    elif isinstance(rec, Message):
                        ch = channels[rec.channel_id]
                        if ch.message_encoding == "json":
                            value: Any = json.loads(rec.data)
                        else:
                            dec = decoders.get(ch.id)
                            if dec is None:
                                dec = factory.decoder_for(ch.message_encoding, schemas.get(ch.schema_id))
                                if dec is None:
                                    raise ParolkitValueError(
                                        f"{self.path}: no decoder for {ch.topic} ({ch.message_encoding})")
                                decoders[ch.id] = dec
                            value = dec(rec.data)
                        yield RecordedMessage(ch.topic, rec.log_time, rec.sequence, value)
                    elif isinstance(rec, Metadata):
                        self.metadata[rec.name] = dict(rec.metadata)
                    elif isinstance(rec, (DataEnd, Footer)):
                        self.complete = True
            except _DAMAGED as exc:
                # a file cut short (killed writer) or damaged: everything before is kept
                self.error = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
                self.stopped_at = f.tell()
                self.not_mcap = isinstance(exc, InvalidMagic) or self.size < _MAGIC_BYTES


def iter_messages(path: str | Path) -> Iterator[RecordedMessage]:
    """Every message of ``path`` in file order, decoded (stops quietly at a cut-off end)."""
    yield from _Scan(Path(path)).messages()


@dataclass
class Recording:
    """The status stream of a recording as arrays (one row per tick received).

    ``ticks``: controller tick (status ``seq``); ``time_s``: controller time (s);
    ``steps``: board step counters; ``angles_deg``; ``speeds_deg_s``; ``pose``: TCP
    ``[x, y, z, A, B, C]`` (mm, deg); ``joint_positions_rad``: /joint_states as decoded.
    """

    path: Path
    ticks: NDArray[np.int64]
    time_s: NDArray[np.float64]
    steps: NDArray[np.int64]
    angles_deg: NDArray[np.float64]
    speeds_deg_s: NDArray[np.float64]
    pose: NDArray[np.float64]
    joint_positions_rad: NDArray[np.float64]
    statuses: list[dict[str, Any]]
    commands: list[dict[str, Any]] = field(default_factory=list)
    acks: list[dict[str, Any]] = field(default_factory=list)
    plans: list[dict[str, Any]] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = True
    read_error: str | None = None
    #: bytes read before the damage that stopped the read, and the file's size
    read_stopped_at: int = 0
    size_bytes: int = 0

    @property
    def damage(self) -> str | None:
        """One line saying that the file ended early or is damaged, where, and what was kept
        (None when the read reached the end of the recording).  The tools print it: a
        recording is never used in part without saying so."""
        if self.complete or self.read_error is None:
            return None
        return (f"{self.path}: the recording ends early or is damaged at byte {self.read_stopped_at} of "
                f"{self.size_bytes} ({self.read_error}): only the {len(self)} ticks before it are used")

    @property
    def rate_hz(self) -> float:
        """Control rate (from the status's loop object; 100 Hz when absent)."""
        for s in self.statuses:
            r = (s.get("loop") or {}).get("rate_hz")
            if r:
                return float(r)
        return 100.0

    @property
    def dropped_ticks(self) -> int:
        """Ticks missing between the first and the last one received."""
        if len(self.ticks) < 2:
            return 0
        return int(self.ticks[-1] - self.ticks[0] + 1 - len(np.unique(self.ticks)))

    def __len__(self) -> int:
        return len(self.ticks)


def load_recording(path: str | Path) -> Recording:
    """Read ``path`` (see the module docstring); ParolkitValueError if it holds no status."""
    p = Path(path)
    if p.is_dir():
        raise ParolkitValueError(f"{p}: is a folder, not a recording (an .mcap file)")
    if not p.is_file():
        raise ParolkitValueError(f"{p}: no such recording")
    scan = _Scan(p)
    statuses: list[dict[str, Any]] = []
    joints: list[list[float]] = []
    commands: list[dict[str, Any]] = []
    acks: list[dict[str, Any]] = []
    plans: list[dict[str, Any]] = []
    for m in scan.messages():
        v = m.value
        legacy = isinstance(v, dict)  # a JSON channel of a recording made before parolkit_msgs
        if m.topic == TOPIC_STATUS:
            statuses.append(v if legacy else messages.status_from_message(v))
        elif m.topic == TOPIC_JOINT_STATES:
            joints.append(list(v.position))
        elif m.topic == TOPIC_COMMANDS:
            commands.append(v if legacy else messages.command_event_dict(v))
        elif m.topic == TOPIC_ACKS:
            acks.append(v if legacy else messages.ack_dict(v))
        elif m.topic == TOPIC_PLANS:
            plans.append(v if legacy else messages.plan_dict(v))
    if not statuses:
        if scan.size == 0:
            raise ParolkitValueError(f"{p}: the file is empty, not a recording")
        if scan.not_mcap:
            raise ParolkitValueError(f"{p}: not an MCAP recording (it does not start with the MCAP magic bytes)")
        raise ParolkitValueError(f"{p}: no {TOPIC_STATUS} messages"
                                 + (f" (the file ends early or is damaged: {scan.error})" if scan.error else ""))
    n = min(len(statuses), len(joints)) if joints else len(statuses)
    statuses = statuses[:n]
    return Recording(
        path=p,
        ticks=np.array([int(s["seq"]) for s in statuses], dtype=np.int64),
        time_s=np.array([float(s["time"]) for s in statuses]),
        steps=np.array([s["steps"] for s in statuses], dtype=np.int64).reshape(-1, 6),
        angles_deg=np.array([s["angles"] for s in statuses], dtype=float).reshape(-1, 6),
        speeds_deg_s=np.array([s["speeds_deg_s"] for s in statuses], dtype=float).reshape(-1, 6),
        pose=np.array([s["pose"] for s in statuses], dtype=float).reshape(-1, 6),
        joint_positions_rad=np.array(joints[:n], dtype=float).reshape(-1, 6),
        statuses=statuses, commands=commands, acks=acks, plans=plans,
        metadata=scan.metadata, complete=scan.complete, read_error=scan.error,
        read_stopped_at=scan.stopped_at, size_bytes=scan.size,
    )


def warn_if_damaged(rec: Recording, command: str) -> None:
    """Print :attr:`Recording.damage` as a warning of ``parolkit COMMAND`` on stderr (the tools
    that read recordings use it: a damaged file is used up to the damage, and says so)."""
    if rec.damage is not None:
        print(f"parolkit {command}: warning: {rec.damage}", file=sys.stderr)


def summary_of(rec: Recording) -> dict[str, Any]:
    """The recording's closing summary (empty when it was not closed normally)."""
    return dict(rec.metadata.get(RECORDING_METADATA, {}))
