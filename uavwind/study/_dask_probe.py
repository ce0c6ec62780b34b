"""The dask scheduler a fill runs on (``fill_cache(scheduler=...)``), checked before it is
trusted.

This module owns :func:`_check_scheduler`, which turns a scheduler address or a
``distributed.Client`` into the client the fill submits its tasks to, and
:func:`_probe_scheduler`, the raw-socket handshake behind it: a ``tcp://`` address is
connected to and its first message read (dask's handshake, an 8-byte length then msgpack
frames naming a ``pickle-protocol``) within :data:`PROBE_SECONDS`, so an address that
refuses, stays silent or is not a dask scheduler (an HTTP dashboard) is a ``ValueError``
naming it at once, where dask's own client would wait for ever or read ``"HTTP/1.1"`` as a
length of exabytes. What runs on the cluster is :mod:`uavwind.study._pools`' and the fill's.
"""

from __future__ import annotations

import os
import time


#: Seconds a scheduler address has to accept a connection and send dask's handshake.
PROBE_SECONDS = 5.0
#: The largest handshake a dask scheduler sends [bytes] (its first message is a few hundred).
_HANDSHAKE_MAX = 1 << 20


def _probe_scheduler(scheduler, stop=None, seconds=PROBE_SECONDS):
    """Connect to the ``tcp://`` address ``scheduler`` and read the handshake a dask
    scheduler sends on every new connection (an 8-byte length, then msgpack frames naming
    its ``pickle-protocol``), within ``seconds``; ``ValueError`` naming the address if it
    is refused, silent, or answers something else (an HTTP server waits silently; dask's own
    client would wait for ever, or read "HTTP/1.1" as a length of exabytes). Checks
    ``stop`` every 0.1 s (``KeyboardInterrupt`` once set). Other schemes are not probed."""
    import errno
    import select
    import socket
    import struct

    from distributed.comm import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(scheduler)
        if scheme != "tcp":
            return
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"scheduler must be an address such as 'tcp://host:8786', got "
                         f"{scheduler!r} ({exc})") from None
    deadline = time.monotonic() + seconds

    def left():
        if stop is not None and stop.is_set():
            raise KeyboardInterrupt
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        return min(remaining, 0.1)

    def read(sock, n):
        data = b""
        while len(data) < n:
            sock.settimeout(left())
            try:
                chunk = sock.recv(n - len(data))
            except (socket.timeout, BlockingIOError):
                continue
            if not chunk:
                raise ConnectionResetError("the server closed the connection")
            data += chunk
        return data

    sock = None
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        family, kind, proto, _, addr = infos[0]
        sock = socket.socket(family, kind, proto)
        sock.setblocking(False)
        err = sock.connect_ex(addr)
        if err not in (0, errno.EINPROGRESS, errno.EWOULDBLOCK):
            raise OSError(err, os.strerror(err))
        while err:  # wait for the connection, a slice at a time
            _, writable, _ = select.select([], [sock], [], left())
            if writable:
                err = sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
                if err:
                    raise OSError(err, os.strerror(err))
                break
        (size,) = struct.unpack("<Q", read(sock, 8))
        if not 0 < size <= _HANDSHAKE_MAX:
            raise ValueError(f"its first message claims {size} bytes, not a dask handshake")
        if b"pickle-protocol" not in read(sock, size):
            raise ValueError("its first message is not a dask handshake")
    except TimeoutError:
        raise ValueError(f"scheduler: no dask scheduler answered at {scheduler!r} within "
                         f"{seconds:g} s (the server is silent: is this a dask scheduler's "
                         f"port, and not e.g. its dashboard's?)") from None
    except OSError as exc:
        raise ValueError(f"scheduler: cannot reach a dask scheduler at {scheduler!r} "
                         f"({type(exc).__name__}: {exc})") from None
    except ValueError as exc:
        raise ValueError(f"scheduler: the server at {scheduler!r} is not a dask scheduler "
                         f"({exc})") from None
    finally:
        if sock is not None:
            sock.close()


def _check_scheduler(scheduler, stop=None):
    """``scheduler``: a ``dask.distributed`` scheduler address (``"tcp://host:8786"``) or a
    ``Client``; ``(client, owned)`` (``owned``: made here, to be closed here). An address is
    probed first (:func:`_probe_scheduler`): refused, silent or not dask, it fails within
    :data:`PROBE_SECONDS`."""
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - distributed is pinned in environment.txt
        raise ValueError("scheduler needs dask.distributed (pip install distributed)") from exc
    if isinstance(scheduler, Client):
        return scheduler, False
    if not isinstance(scheduler, str):
        raise TypeError(f"scheduler must be a dask.distributed address (str, e.g. "
                        f"'tcp://host:8786') or a Client, got {type(scheduler).__name__}")
    if not scheduler.strip() or any(c.isspace() for c in scheduler):
        raise ValueError(f"scheduler must be an address such as 'tcp://host:8786', got "
                         f"{scheduler!r}")
    _probe_scheduler(scheduler, stop)
    try:  # a scheduler answered: connecting takes a moment (at most dask's connect timeout)
        return Client(scheduler, timeout=max(PROBE_SECONDS, 1.0)), True
    except (OSError, TimeoutError) as exc:
        raise ValueError(f"scheduler: cannot reach a dask scheduler at {scheduler!r} "
                         f"({type(exc).__name__}: {exc})") from None
