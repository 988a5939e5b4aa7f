"""Record, replay and teach by demonstration: MCAP files that open in Foxglove and ROS 2 tools.

* :mod:`parolkit.record.schemas`: topic names, ROS 2 message definitions, joint names.
* :mod:`parolkit.record.messages`: a status object -> ROS 2 message dicts (JointState, PoseStamped).
* :mod:`parolkit.record.writer`: :class:`RecordingWriter`, the chunked, flushed MCAP writer.
* :mod:`parolkit.record.recorder`: :class:`Recorder`, a client of the controller's status stream.
* :mod:`parolkit.record.reader`: :func:`load_recording`, a recording (possibly cut short) as arrays.
* :mod:`parolkit.record.segments`: a recording cut into rests and moves, fitted with planned moves.
* :mod:`parolkit.record.replay`, :mod:`parolkit.record.teach`, :mod:`parolkit.record.plot`,
  :mod:`parolkit.record.export`: what the sub-commands do.
* :mod:`parolkit.record.cli`: the ``record``/``replay``/``plot``/``export``/``teach`` sub-commands.

See docs/record.md.
"""
