"""A ROS 2 node on plain DDS: what makes ``ros2 node list`` and ``ros2 topic info -v`` see
``parolkit ros2`` as a node rather than a bare DDS application.

A ROS 2 middleware (rmw) learns which node owns which reader and writer from the topic
``ros_discovery_info`` (rmw_dds_common/msg/ParticipantEntitiesInfo; reliable, transient local,
keep last 1): each participant publishes its GID and, per node, the node's name, namespace and
the GIDs of its readers and writers.  A GID is the entity's 16-byte DDS GUID.  Readers and
writers it cannot place get the node name ``_CREATED_BY_BARE_DDS_APP_``.  Since Iron each
reader and writer also carries its type's RIHS01 hash in its USER_DATA QoS
(``typehash=RIHS01_...;``, :mod:`parolkit.ros2.typehash`); without it tools report the hash as
INVALID.  The participant's USER_DATA names its security enclave (``enclave=/;``).

:class:`RosGraph` is one node on one participant: :meth:`RosGraph.writer` and
:meth:`RosGraph.reader` create endpoints with the ROS QoS given, the type hash added, and
announce them; entities made elsewhere are announced with :meth:`RosGraph.add` (their QoS
should come from :func:`endpoint_qos`).

The DDS domain (:func:`resolve_domain`): ``--domain``, else ``[ros2] domain`` when the config
file sets it, else the environment's ``ROS_DOMAIN_ID``, else 0 (ROS 2's own default); the
choice is logged with where it came from.
"""

from __future__ import annotations

import logging
import os
import threading
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cyclonedds.core import Entity, Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from parolkit.errors import ParolkitValueError
from parolkit.ros2.graph_types import Gid, NodeEntitiesInfo, ParticipantEntitiesInfo
from parolkit.ros2.interfaces import hash_of, ros_type_name
from parolkit.ros2.typehash import user_data

if TYPE_CHECKING:
    from parolkit.config import Config

__all__ = [
    "NODE_NAME", "DISCOVERY_TOPIC", "MAX_DOMAIN_ID",
    "ENCLAVE_USER_DATA", "DomainChoice", "resolve_domain", "make_participant", "gid_of", "type_name_of",
    "endpoint_qos", "discovery_qos", "RosGraph",
]

log = logging.getLogger("parolkit.ros2")

#: the node's name (``ros2 node list`` shows ``/<namespace>/parolkit_bridge``)
NODE_NAME = "parolkit_bridge"
#: the rmw's graph topic (a DDS topic name: no ``rt/`` prefix)
DISCOVERY_TOPIC = "ros_discovery_info"
#: the largest ROS_DOMAIN_ID ROS 2 accepts (its port mapping)
MAX_DOMAIN_ID = 232
#: the participant's USER_DATA: its security enclave, as rmw writes it
ENCLAVE_USER_DATA = b"enclave=/;"


@dataclass(frozen=True)
class DomainChoice:
    """The DDS domain and where it came from (for the log)."""

    domain: int
    source: str


def _check_domain(value: object, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_DOMAIN_ID:
        raise ParolkitValueError(f"{what} must be an integer 0..{MAX_DOMAIN_ID}, got {value!r}")
    return value


def _file_domain(path: str | None) -> object | None:
    """``[ros2] domain`` as the config file writes it (None when it does not)."""
    if path is None:
        return None
    try:
        data = tomllib.loads(open(path, encoding="utf-8").read())
    except (OSError, tomllib.TOMLDecodeError):
        return None  # load_config already read and checked it; nothing to add here
    section = data.get("ros2")
    return section.get("domain") if isinstance(section, dict) else None


def resolve_domain(flag: int | None, config: Config, environ: Mapping[str, str] | None = None) -> DomainChoice:
    """The domain (module docstring): the flag, the config file's ``[ros2] domain``, the
    environment's ``ROS_DOMAIN_ID``, or 0.  A bad value is an error naming where it came from."""
    if flag is not None:
        return DomainChoice(_check_domain(flag, "--domain"), "--domain")
    in_file = _file_domain(config.source)
    if in_file is not None:
        return DomainChoice(_check_domain(in_file, f"ros2.domain in {config.source}"),
                            f"[ros2] domain in {config.source}")
    env = os.environ if environ is None else environ
    text = env.get("ROS_DOMAIN_ID", "").strip()
    if text:
        if not text.isdigit():
            raise ParolkitValueError(f"ROS_DOMAIN_ID must be an integer 0..{MAX_DOMAIN_ID}, got {text!r}")
        return DomainChoice(_check_domain(int(text), "ROS_DOMAIN_ID"), "ROS_DOMAIN_ID")
    return DomainChoice(0, "the default (no --domain, [ros2] domain or ROS_DOMAIN_ID)")


def make_participant(domain: int) -> DomainParticipant:
    """A DDS participant on ``domain`` with ROS 2's enclave in its USER_DATA."""
    return DomainParticipant(_check_domain(domain, "the DDS domain"), qos=Qos(Policy.Userdata(ENCLAVE_USER_DATA)))


def gid_of(entity: Entity) -> Gid:
    """The rmw GID of a participant, reader or writer: its DDS GUID's 16 bytes."""
    return Gid(data=list(entity.guid.bytes))


def type_name_of(idl_type: type) -> str:
    """``pkg/msg/Name`` of a cyclonedds struct declared with typename ``pkg::msg::dds_::Name_``."""
    return ros_type_name(str(getattr(idl_type, "__idl_typename__", "")))


def endpoint_qos(qos: Qos, idl_type: type) -> Qos:
    """``qos`` with the type hash of ``idl_type`` in its USER_DATA, as Jazzy's rmw writes it."""
    return qos + Qos(Policy.Userdata(user_data(hash_of(type_name_of(idl_type)))))


def discovery_qos() -> Qos:
    """rmw's QoS of ``ros_discovery_info``: reliable, keep last 1, transient local."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.History.KeepLast(1), Policy.Durability.TransientLocal)


@dataclass
class _Endpoints:
    readers: list[Entity] = field(default_factory=list)
    writers: list[Entity] = field(default_factory=list)


class RosGraph:
    """One ROS 2 node, ``name`` in ``namespace`` (``""`` or ``"a/b"``), on participant ``dp``
    (best made by :func:`make_participant`): publishes the participant's entities on
    ``ros_discovery_info`` whenever an endpoint is added, so every ROS 2 tool places them."""

    def __init__(self, dp: DomainParticipant, name: str = NODE_NAME, namespace: str = "") -> None:
        self.dp = dp
        self.name = name
        self.namespace = "/" + namespace.strip("/")
        self._ends = _Endpoints()
        self._topics: dict[str, Topic[Any]] = {}
        self._lock = threading.Lock()
        self._info = DataWriter(dp, Topic(dp, DISCOVERY_TOPIC, ParticipantEntitiesInfo),
                                endpoint_qos(discovery_qos(), ParticipantEntitiesInfo))
        self.announce()

    def _topic(self, dds_name: str, idl_type: type) -> Topic[Any]:
        with self._lock:
            topic = self._topics.get(dds_name)
            if topic is None:
                topic = self._topics[dds_name] = Topic(self.dp, dds_name, idl_type)
            return topic

    def writer(self, dds_topic: str, idl_type: type, qos: Qos) -> DataWriter[Any]:
        """A writer of ``idl_type`` on DDS topic ``dds_topic`` (``rt/...``) with ``qos`` and
        the type's hash, announced as this node's."""
        w: DataWriter[Any] = DataWriter(self.dp, self._topic(dds_topic, idl_type), endpoint_qos(qos, idl_type))
        self.add(writers=[w])
        return w

    def reader(self, dds_topic: str, idl_type: type, qos: Qos) -> DataReader[Any]:
        """A reader, as :meth:`writer`."""
        r: DataReader[Any] = DataReader(self.dp, self._topic(dds_topic, idl_type), endpoint_qos(qos, idl_type))
        self.add(readers=[r])
        return r

    def add(self, readers: list[Entity] | None = None, writers: list[Entity] | None = None) -> None:
        """Announce readers and writers made elsewhere as this node's."""
        with self._lock:
            self._ends.readers.extend(readers or [])
            self._ends.writers.extend(writers or [])
        self.announce()

    def info(self) -> ParticipantEntitiesInfo:
        """What :meth:`announce` publishes."""
        with self._lock:
            node = NodeEntitiesInfo(node_namespace=self.namespace, node_name=self.name,
                                    reader_gid_seq=[gid_of(r) for r in self._ends.readers],
                                    writer_gid_seq=[gid_of(w) for w in self._ends.writers])
        return ParticipantEntitiesInfo(gid=gid_of(self.dp), node_entities_info_seq=[node])

    def announce(self) -> None:
        """Publish the participant's entities on ``ros_discovery_info`` (kept for late joiners)."""
        self._info.write(self.info())

    def close(self) -> None:
        """Tell the graph the node is gone (an empty node list), as rmw does when a node ends."""
        self._info.write(ParticipantEntitiesInfo(gid=gid_of(self.dp), node_entities_info_seq=[]))
