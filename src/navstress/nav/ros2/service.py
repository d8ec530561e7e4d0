"""ROS 2 services over Zenoh, as rmw_zenoh carries them: type registration, the service type
hash, the key expression, and a client.

rmw_zenoh (``rmw_client_data.cpp``, ``rmw_service_data.cpp``) makes a service request a Zenoh
query on the service's key expression ``<domain>/<service>/<DDS service type>/<type hash>`` with
the CDR request as payload and the client's attachment (sequence number, timestamp, GID); the
server replies on the same key with its attachment carrying the request's sequence number and the
client's GID. A client declares a liveliness token of kind ``SC`` per service.

The type hash of a service (REP 2011) is the RIHS01 hash of the *service's* type description: a
type named after the service whose fields are ``request_message``, ``response_message`` and
``event_message`` (``<Srv>_Event``: ``service_msgs/ServiceEventInfo info``, the request and the
response as sequences bounded to 1), with all referenced types. Humble writes
``TypeHashNotSupported`` for every type (:data:`rmw.TYPE_HASH_NOT_SUPPORTED`).
"""

from __future__ import annotations

import functools
import re
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from navstress.nav.ros2 import rmw

__all__ = ["ServiceClient", "register", "register_service", "service_key", "service_type_hash"]

_PLACEHOLDER = "navstress_tmp/msg/Placeholder"


def register(store: Any, defs: dict[str, str]) -> None:
    """Register message definitions under their exact names (rosbags rewrites ``pkg/srv/X`` names
    it parses, so each is parsed under a placeholder and renamed; references to types of
    ``defs`` are written ``@Name`` in the text and resolved here)."""
    from rosbags.typesys import get_types_from_msg
    from rosbags.interfaces import Nodetype

    def fix(f: Any) -> Any:
        kind, spec = f
        if kind == Nodetype.NAME:
            return (kind, spec[1:] if spec.startswith("@") else spec)
        if kind in (Nodetype.SEQUENCE, Nodetype.ARRAY):
            return (kind, (fix(spec[0]), spec[1]))
        return f

    for name, text in defs.items():
        if name in store.fielddefs:
            continue
        refs = {}
        for i, m in enumerate(sorted(set(re.findall(r"@(\S+?)(?=[\[\s])", text)))):
            refs[f"navstress_ref{i}/msg/R"] = m
        for k, m in refs.items():
            text = text.replace(f"@{m}", k)
        parsed = get_types_from_msg(text, _PLACEHOLDER)
        consts, fields = parsed[_PLACEHOLDER]
        fields = [(fn, fix(_rename(ft, refs))) for fn, ft in fields]
        store.register({name: (consts, fields)})


def _rename(f: Any, refs: dict[str, str]) -> Any:
    from rosbags.interfaces import Nodetype

    kind, spec = f
    if kind == Nodetype.NAME:
        return (kind, refs.get(spec, spec))
    if kind in (Nodetype.SEQUENCE, Nodetype.ARRAY):
        return (kind, (_rename(spec[0], refs), spec[1]))
    return f


def register_service(store: Any, srv: str) -> None:
    """The service type itself and its event type (for the type hash)."""
    register(store, {
        f"{srv}_Event": (f"service_msgs/ServiceEventInfo info\n@{srv}_Request[<=1] request\n"
                         f"@{srv}_Response[<=1] response\n"),
        srv: (f"@{srv}_Request request_message\n@{srv}_Response response_message\n"
              f"@{srv}_Event event_message\n"),
    })


_LOCK = threading.Lock()


@functools.cache
def _hash_store(distro: str) -> Any:
    """A private typestore for service hashes: rosbags writes ``service_msgs/ServiceEventInfo``'s
    ``char[16] client_gid`` as ``char``, but rosidl maps ``.msg``'s ``char`` to IDL ``uint8``
    before it hashes (rmw_zenoh's design.md: AddTwoInts is ``RIHS01_e118de6b...``)."""
    from rosbags.interfaces import Nodetype

    store = rmw.fresh_typestore(distro)
    name = "service_msgs/msg/ServiceEventInfo"
    consts, fields = store.fielddefs[name]
    store.fielddefs[name] = (consts, [(fn, (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16)))
                                      if fn == "client_gid" else (fn, ft) for fn, ft in fields])
    return store


@functools.cache
def service_type_hash(srv: str, distro: str) -> str:
    """The type hash of service type ``srv`` (``pkg/srv/Name`` or ``pkg/action/Name_SendGoal``)
    in ``distro``'s key expressions and tokens; its request and response types must be
    registered (:func:`register_action_types`)."""
    if distro == "humble":
        return rmw.TYPE_HASH_NOT_SUPPORTED
    store, hs = rmw.typestore(distro), _hash_store(distro)
    with _LOCK:
        for t in (f"{srv}_Request", f"{srv}_Response"):
            if t not in hs.fielddefs:
                _copy(store, hs, t)
        register_service(hs, srv)
    return str(hs.hash_rihs01(srv))


def _copy(src: Any, dst: Any, name: str) -> None:
    """Register ``name`` and the types it uses from ``src`` into ``dst``."""
    from rosbags.interfaces import Nodetype

    if name in dst.fielddefs:
        return
    consts, fields = src.fielddefs[name]
    dst.register({name: (consts, fields)})
    for _, (kind, spec) in fields:
        inner = spec[0] if kind in (Nodetype.SEQUENCE, Nodetype.ARRAY) else (kind, spec)
        if inner[0] == Nodetype.NAME:
            _copy(src, dst, inner[1])


def service_key(domain_id: int, service: str, srv: str, distro: str) -> str:
    return f"{domain_id}/{service.strip('/')}/{rmw.dds_type_name(srv)}/{service_type_hash(srv, distro)}"


class ServiceClient:
    """A client of ``service`` (type ``srv``, whose ``_Request`` and ``_Response`` types are
    registered in ``node``'s typestore) on ``node``: its ``SC`` liveliness token, and
    :meth:`call_async` / :meth:`call` (a Zenoh query with rmw_zenoh's attachment)."""

    def __init__(self, node: Any, service: str, srv: str) -> None:
        self.node, self.service, self.srv = node, service, srv
        self._seq = 0
        eid = node._entity()
        self._gid = node.gid(eid)
        self._token: Any = node.session.liveliness().declare_token(
            f"{rmw.ADMIN_SPACE}/{node.domain_id}/{node.zid}/{node.node_id}/{eid}/SC/%/"
            f"{rmw.mangle(node.namespace)}/{rmw.mangle(node.name)}/{rmw.mangle(service)}/"
            f"{rmw.dds_type_name(srv)}/{service_type_hash(srv, node.distro)}/{rmw.Qos().keyexpr()}")

    def call_async(self, request: Any, timeout_s: float, on_reply: Callable[[Any, str | None], None]) -> None:
        """Send ``request``; ``on_reply(response, None)`` when a reply comes, or ``on_reply(None,
        why)`` for one navstress cannot decode (nothing is called when none comes)."""
        store, node, srv = self.node.store, self.node, self.srv
        self._seq += 1
        att = rmw.Attachment(self._seq, time.time_ns(), self._gid).to_bytes()
        payload = bytes(store.serialize_cdr(request, f"{srv}_Request"))

        def cb(reply: zenoh.Reply) -> None:
            ok = reply.ok
            if ok is None:
                return
            try:
                msg = store.deserialize_cdr(ok.payload.to_bytes(), f"{srv}_Response")
            except Exception as e:  # the server's fault: reported to the caller
                on_reply(None, f"a {srv} reply navstress cannot decode ({type(e).__name__}: {e})")
                return
            on_reply(msg, None)

        node.session.get(service_key(node.domain_id, self.service, srv, node.distro), cb, payload=payload,
                         attachment=att, encoding=zenoh.Encoding("application/cdr"), timeout=timeout_s)

    def call(self, request: Any, timeout_s: float) -> tuple[Any, str | None]:
        """:meth:`call_async` and wait: ``(response, None)``, ``(None, why)`` for a reply that does
        not decode, ``(None, None)`` when nothing answered within ``timeout_s``."""
        done, box = threading.Event(), []

        def got(msg: Any, err: str | None) -> None:
            box.append((msg, err))
            done.set()

        self.call_async(request, timeout_s, got)
        if not done.wait(timeout_s):
            return None, None
        return box[0]

    def close(self) -> None:
        try:
            self._token.undeclare()
        except Exception:  # the session is closing: the token goes with it
            pass
