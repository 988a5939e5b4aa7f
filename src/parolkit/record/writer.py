"""The MCAP writer of a recording: chunked, compressed, and flushed to the file at least once
per ``flush_interval_s`` so that a recorder killed mid-way (even with SIGKILL) leaves a file
readable up to its last complete chunk.  :meth:`RecordingWriter.close` writes the summary
section (indexes, statistics) and a ``parolkit.recording`` metadata record.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from mcap_ros2._dynamic import serialize_dynamic

from parolkit import __version__
from parolkit.record.schemas import JSON_SCHEMA, PROFILE, RECORDING_METADATA, ROS2_DEFINITIONS

__all__ = ["RecordingWriter"]


class RecordingWriter:
    """Writes ROS 2 (CDR) and JSON messages to one MCAP file.

    ``chunk_size`` (bytes, uncompressed) closes a chunk when it is full; ``flush_interval_s``
    closes it after that long anyway (so at most that much is lost to a SIGKILL).
    """

    def __init__(self, path: str | Path, *, chunk_size: int = 512 * 1024, flush_interval_s: float = 1.0,
                 compression: CompressionType = CompressionType.ZSTD) -> None:
        if flush_interval_s <= 0:
            raise ValueError(f"flush_interval_s must be > 0 s, got {flush_interval_s!r}")
        self.path = Path(path)
        # buffered; flush() (every flush_interval_s) hands everything written to the kernel
        self._file = open(self.path, "wb")
        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=compression)
        self._mcap.start(profile=PROFILE, library=f"parolkit {__version__}")
        self._channels: dict[str, int] = {}
        self._encoders: dict[int, Callable[[Any], bytes]] = {}
        self._schema_ids: dict[str, int] = {}
        self._json_schema = self._mcap.register_schema("parolkit/json", SchemaEncoding.JSONSchema, JSON_SCHEMA)
        self.flush_interval_s = flush_interval_s
        self._last_flush = time.monotonic()
        self.messages = 0
        self.closed = False

    def _ros_channel(self, topic: str, datatype: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            sid = self._schema_ids.get(datatype)
            if sid is None:
                text = ROS2_DEFINITIONS[datatype]
                sid = self._mcap.register_schema(datatype, SchemaEncoding.ROS2, text.encode())
                self._encoders[sid] = serialize_dynamic(datatype, text)[datatype]
                self._schema_ids[datatype] = sid
            cid = self._mcap.register_channel(topic, MessageEncoding.CDR, sid)
            self._channels[topic] = cid
        return cid

    def _json_channel(self, topic: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            cid = self._mcap.register_channel(topic, MessageEncoding.JSON, self._json_schema)
            self._channels[topic] = cid
        return cid

    def write_ros(self, topic: str, datatype: str, message: dict[str, Any], time_ns: int, sequence: int) -> None:
        """One ROS 2 message (a dict in the layout of ``datatype``) at UNIX time ``time_ns``."""
        cid = self._ros_channel(topic, datatype)
        sid = self._schema_ids[datatype]
        self._add(cid, self._encoders[sid](message), time_ns, sequence)

    def write_json(self, topic: str, payload: bytes | dict[str, Any], time_ns: int, sequence: int) -> None:
        """One JSON message (already encoded bytes, or a dict)."""
        data = payload if isinstance(payload, bytes) else json.dumps(payload, separators=(",", ":")).encode()
        self._add(self._json_channel(topic), data, time_ns, sequence)

    def _add(self, cid: int, data: bytes, time_ns: int, sequence: int) -> None:
        if self.closed:
            raise ValueError(f"{self.path}: the recording is closed")
        self._mcap.add_message(channel_id=cid, log_time=time_ns, publish_time=time_ns,
                               sequence=sequence & 0xFFFFFFFF, data=data)
        self.messages += 1

    def maybe_flush(self) -> bool:
        """Flush when ``flush_interval_s`` has passed since the last flush (call it between
        ticks, so a chunk never splits the messages of one tick); True if it flushed."""
        if time.monotonic() - self._last_flush >= self.flush_interval_s:
            self.flush()
            return True
        return False

    def flush(self) -> None:
        """Close the chunk in progress and hand it to the operating system."""
        self._mcap.flush()  # type: ignore[no-untyped-call]
        self._last_flush = time.monotonic()

    def close(self, summary: dict[str, Any] | None = None) -> None:
        """Write the summary section (and ``summary`` as the metadata record); idempotent."""
        if self.closed:
            return
        if summary is not None:
            self._mcap.add_metadata(RECORDING_METADATA, {k: str(v) for k, v in summary.items()})
        self._mcap.finish()  # type: ignore[no-untyped-call]
        self._file.flush()
        self._file.close()
        self.closed = True
