"""The MCAP writer of a recording: chunked, compressed, and flushed to the file at least once
per ``flush_interval_s`` so that a recorder killed mid-way (even with SIGKILL) leaves a file
readable up to its last complete chunk.  :meth:`RecordingWriter.close` writes the summary
section (indexes, statistics) and a ``parolkit.recording`` metadata record.

Every channel is CDR with its ROS 2 message type's ``ros2msg`` schema and rosbag2's channel
metadata (:mod:`parolkit.record.schemas`), as ``ros2 bag record`` writes MCAP; messages are
encoded by :mod:`parolkit.ros2.cdr`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

from parolkit import __version__
from parolkit.record import messages
from parolkit.record.schemas import PROFILE, RECORDING_METADATA, STATUS, TOPIC_STATUS, channel_metadata, schema_text
from parolkit.ros2.cdr import encoder

__all__ = ["RecordingWriter"]


class RecordingWriter:
    """Writes ROS 2 messages (CDR) to one MCAP file.

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
        self._channel_types: dict[str, str] = {}
        self.flush_interval_s = flush_interval_s
        self._last_flush = time.monotonic()
        self.messages = 0
        self.closed = False

    def _ros_channel(self, topic: str, datatype: str) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            sid = self._schema_ids.get(datatype)
            if sid is None:
                text = schema_text(datatype)
                sid = self._mcap.register_schema(datatype, SchemaEncoding.ROS2, text.encode())
                self._encoders[sid] = encoder(datatype)
                self._schema_ids[datatype] = sid
            cid = self._mcap.register_channel(topic, MessageEncoding.CDR, sid, channel_metadata(topic, datatype))
            self._channels[topic] = cid
            self._channel_types[topic] = datatype
        elif self._channel_types[topic] != datatype:
            raise ValueError(f"{self.path}: topic {topic} carries {self._channel_types[topic]}, not {datatype}")
        return cid

    def write_ros(self, topic: str, datatype: str, message: dict[str, Any], time_ns: int, sequence: int,
                  publish_time_ns: int | None = None) -> None:
        """One ROS 2 message (a dict in the layout of ``datatype``) received at UNIX time
        ``time_ns`` (the log time) and published at ``publish_time_ns`` (default: the same)."""
        cid = self._ros_channel(topic, datatype)
        sid = self._schema_ids[datatype]
        self._add(cid, self._encoders[sid](message), time_ns, sequence,
                  time_ns if publish_time_ns is None else publish_time_ns)

    def write_status(self, status: dict[str, Any], time_ns: int, sequence: int, *, json_text: str | None = None,
                     publish_time_ns: int | None = None) -> None:
        """One status object on ``/parolkit/status`` (parolkit_msgs/msg/Status, stamped
        ``publish_time_ns``, default ``time_ns``); ``json_text``: the object as the controller
        sent it (default: ``status`` encoded here)."""
        text = json.dumps(status, separators=(",", ":")) if json_text is None else json_text
        stamp_ns = time_ns if publish_time_ns is None else publish_time_ns
        self.write_ros(TOPIC_STATUS, STATUS, messages.status_message(status, text, stamp_ns), time_ns, sequence,
                       stamp_ns)

    def _add(self, cid: int, data: bytes, time_ns: int, sequence: int, publish_time_ns: int) -> None:
        if self.closed:
            raise ValueError(f"{self.path}: the recording is closed")
        self._mcap.add_message(channel_id=cid, log_time=time_ns, publish_time=publish_time_ns,
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
