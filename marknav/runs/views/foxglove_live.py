"""The run live in Foxglove (``foxglove-sdk``, the ``foxglove`` extra): ``marknav run --foxglove``.

The recording's channels (:data:`marknav.runs.records.mcap_recording.TOPICS`), ROS 2-encoded
(``ros2msg`` schemas, CDR), served over WebSocket on 127.0.0.1 while the mission runs. Foxglove
(Open connection → Foxglove WebSocket, ``ws://127.0.0.1:PORT``) decodes them as it decodes a
ROS 2 bag. The server speaks the ``foxglove.sdk.v1`` subprotocol only; Lichtblick, which speaks
``foxglove.websocket.v1``, opens the recorded file instead.
"""

from __future__ import annotations

import logging
from typing import Any

from marknav.core.errors import InputError
from marknav.runs.records.ros2_types import definition

log = logging.getLogger(__name__)

EXTRA_HINT = "pip install 'marknav[foxglove]'"
#: Where the server listens: this machine only (a run is not published to the network).
HOST = "127.0.0.1"
#: Foxglove's own default WebSocket port.
DEFAULT_PORT = 8765
PORT_MAX = 65535


def require_foxglove(option: str = "--foxglove") -> Any:
    """Import foxglove-sdk; InputError (exit 2) naming the extra when it is missing."""
    try:
        import foxglove
    except ImportError:
        raise InputError(f"needs the Foxglove SDK, which is not installed: {EXTRA_HINT}",
                         field=option) from None
    return foxglove


class FoxgloveLive:
    """A channel output (:class:`~marknav.runs.records.mcap_recording.ChannelOutput`) serving
    each topic on a Foxglove WebSocket server of its own context (``port`` 0: a free one)."""

    def __init__(self, port: int = DEFAULT_PORT, *, host: str = HOST) -> None:
        foxglove = require_foxglove()
        self._fg = foxglove
        self.context = foxglove.Context()
        try:
            self.server = foxglove.start_server(name="marknav", host=host, port=port,
                                                context=self.context)
        except Exception as exc:  # port taken, no permission
            raise InputError(f"cannot serve on {host}:{port}: {exc}",
                             field="--foxglove") from None
        self.port = int(self.server.port)
        self._channels: dict[str, Any] = {}
        log.info("Foxglove: ws://%s:%d", host, self.port)

    def write(self, topic: str, type_name: str, data: bytes, log_time_ns: int) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            schema = self._fg.Schema(name=type_name, encoding="ros2msg",
                                     data=definition(type_name).encode())
            channel = self._fg.Channel(topic, schema=schema, message_encoding="cdr",
                                       context=self.context)
            self._channels[topic] = channel
        if channel.has_sinks():
            channel.log(data, log_time=log_time_ns)

    def close(self) -> None:
        for channel in self._channels.values():
            channel.close()
        self._channels = {}
        self.server.stop()
