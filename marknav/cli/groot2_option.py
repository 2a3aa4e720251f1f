"""``--groot2 [HOST:]PORT``: where ``marknav run`` serves its live tree to Groot2."""

from __future__ import annotations

from marknav.core.errors import InputError

GROOT2_HELP = ("serve the live tree to Groot2 (BehaviorTree.CPP's monitor) on PORT (default "
               "1667) and PORT+1, on 127.0.0.1 unless HOST is given (0.0.0.0: every "
               "interface, to watch a robot from another computer); extra: groot2")
#: TCP ports a server may bind without privileges, leaving room for PORT + 1.
MIN_PORT, MAX_PORT = 1024, 65534


def groot2_address(text: str | None) -> tuple[str, int] | None:
    """``PORT`` or ``HOST:PORT`` as (host, port); :class:`InputError` (exit 2) otherwise."""
    if text is None:
        return None
    try:
        import msgpack  # noqa: F401
        import zmq  # noqa: F401
    except ImportError:
        raise InputError("needs the 'groot2' extra: pip install 'marknav[groot2]'",
                         field="--groot2") from None
    host, _, port_text = text.rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        raise InputError(f"not a port number: {port_text!r}", field="--groot2") from None
    if not MIN_PORT <= port <= MAX_PORT:
        raise InputError(f"port {port} is outside {MIN_PORT}..{MAX_PORT} (Groot2 also uses "
                         "PORT + 1)", field="--groot2")
    return host or "127.0.0.1", port
