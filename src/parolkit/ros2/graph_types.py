"""The rmw_dds_common messages of the ROS 2 graph (:mod:`parolkit.ros2.graph`) as cyclonedds
IDL structs, with the field order and types of ROS 2 Jazzy's definitions
(:data:`parolkit.ros2.interfaces.DEFINITIONS`).

No ``from __future__ import annotations`` here: cyclonedds resolves the field annotations at
run time (as in :mod:`parolkit.ros2.msgs`).
"""


from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from cyclonedds.idl import IdlStruct

if TYPE_CHECKING:  # for the type checker: what the fields hold at run time
    from builtins import list as sequence

    Gid16 = list[int]
    String256 = str
else:
    from cyclonedds.idl.types import array, bounded_str, sequence, uint8

    Gid16 = array[uint8, 16]
    String256 = bounded_str[256]

__all__ = ["Gid", "NodeEntitiesInfo", "ParticipantEntitiesInfo"]


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    """rmw_dds_common/msg/Gid: an entity's 16-byte GUID."""

    data: Gid16 = field(default_factory=lambda: [0] * 16)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    """rmw_dds_common/msg/NodeEntitiesInfo: one node and the GIDs of its readers and writers."""

    node_namespace: String256 = "/"
    node_name: String256 = ""
    reader_gid_seq: sequence[Gid] = field(default_factory=list)
    writer_gid_seq: sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    """rmw_dds_common/msg/ParticipantEntitiesInfo: a participant's GID and its nodes."""

    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: sequence[NodeEntitiesInfo] = field(default_factory=list)
