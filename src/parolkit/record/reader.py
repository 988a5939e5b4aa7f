"""Read a recording back: every message in file order, decoded, and the status stream as arrays.

The file is read as a stream (record by record), so a recording whose writer was killed
mid-way is read up to its last complete chunk (:attr:`Recording.complete` is then False);
ROS 2 messages are decoded with mcap-ros2-support, JSON channels with :mod:`json`.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.exceptions import McapError
from mcap.records import Channel, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from numpy.typing import NDArray

from parolkit.errors import ParolkitValueError
from parolkit.record.schemas import (
    RECORDING_METADATA,
    TOPIC_ACKS,
    TOPIC_COMMANDS,
    TOPIC_JOINT_STATES,
    TOPIC_PLANS,
    TOPIC_STATUS,
)

__all__ = ["RecordedMessage", "Recording", "iter_messages", "load_recording"]


@dataclass(frozen=True)
class RecordedMessage:
    """One message: topic, log time (UNIX ns), sequence (the controller tick), decoded value."""

    topic: str
    log_time_ns: int
    sequence: int
    value: Any


class _Scan:
    """Streaming pass over a file; remembers whether it reached the footer."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.complete = False
        self.error: str | None = None
        self.metadata: dict[str, dict[str, str]] = {}

    def messages(self) -> Iterator[RecordedMessage]:
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        factory = DecoderFactory()
        decoders: dict[int, Any] = {}
        with open(self.path, "rb") as f:
            reader = StreamReader(f, validate_crcs=True)
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
            except (McapError, EOFError, ValueError, KeyError, struct.error) as exc:
                # a file cut short (killed writer): everything before the cut is kept
                self.error = f"{type(exc).__name__}: {exc}"


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
    if not p.is_file():
        raise ParolkitValueError(f"{p}: no such recording")
    scan = _Scan(p)
    statuses: list[dict[str, Any]] = []
    joints: list[list[float]] = []
    commands: list[dict[str, Any]] = []
    acks: list[dict[str, Any]] = []
    plans: list[dict[str, Any]] = []
    for m in scan.messages():
        if m.topic == TOPIC_STATUS:
            statuses.append(m.value)
        elif m.topic == TOPIC_JOINT_STATES:
            joints.append(list(m.value.position))
        elif m.topic == TOPIC_COMMANDS:
            commands.append(m.value)
        elif m.topic == TOPIC_ACKS:
            acks.append(m.value)
        elif m.topic == TOPIC_PLANS:
            plans.append(m.value)
    if not statuses:
        raise ParolkitValueError(f"{p}: no {TOPIC_STATUS} messages"
                                 + (f" (the file ends early: {scan.error})" if scan.error else ""))
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
    )


def summary_of(rec: Recording) -> dict[str, Any]:
    """The recording's closing summary (empty when it was not closed normally)."""
    return dict(rec.metadata.get(RECORDING_METADATA, {}))
