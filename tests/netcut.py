"""A network between a station and its server that a test can cut and restore: a TCP relay
on 127.0.0.1 in front of the tests' PostgreSQL server. `cut()` closes the listening socket
and every connection through it (what a station sees when the server or the network goes
down: its connections end and new ones are refused); `restore()` listens again on the same
port. `silence()` keeps every connection open and accepts new ones but passes nothing on
(a pulled cable, a firewall that drops: nothing ends, no answer comes). The server itself,
shared by the worker's other tests, never stops."""

from __future__ import annotations

import contextlib
import select
import socket
import threading

import sqlalchemy as sa


class NetworkCut:
    def __init__(self, target_port: int, host: str = "127.0.0.1") -> None:
        self.target = (host, target_port)
        self.port = 0
        self._lock = threading.Lock()
        self._sockets: list[socket.socket] = []
        self._listener: socket.socket | None = None
        self.silent = False
        self.restore()

    def url(self, url: sa.URL) -> sa.URL:
        """`url` reaching its server through this network."""
        return url.set(host="127.0.0.1", port=self.port)

    def restore(self) -> None:
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(16)
        self.port = listener.getsockname()[1]
        self._listener = listener
        threading.Thread(target=self._accept, args=(listener,), daemon=True).start()

    def silence(self) -> None:
        """From now on what is sent either way is dropped, and nothing ends."""
        self.silent = True

    def cut(self) -> None:
        with self._lock:
            listener, self._listener = self._listener, None
            sockets, self._sockets = self._sockets, []
        for s in [listener, *sockets]:
            if s is not None:
                with contextlib.suppress(OSError):
                    s.shutdown(socket.SHUT_RDWR)
                s.close()

    def _accept(self, listener: socket.socket) -> None:
        while True:
            try:
                client, _ = listener.accept()
            except OSError:
                return  # cut
            try:
                server = socket.create_connection(self.target)
            except OSError:
                client.close()
                continue
            for end in (client, server):  # as the driver's own socket: no Nagle delay
                end.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                if self._listener is not listener:
                    client.close()
                    server.close()
                    return
                self._sockets += [client, server]
            threading.Thread(target=self._relay, args=(client, server), daemon=True).start()

    def _relay(self, a: socket.socket, b: socket.socket) -> None:
        peers = {a: b, b: a}
        try:
            while True:
                ready, _, _ = select.select([a, b], [], [])
                for s in ready:
                    data = s.recv(65536)
                    if not data:
                        return
                    if not self.silent:
                        peers[s].sendall(data)
        except (OSError, ValueError):
            return
        finally:
            for s in (a, b):
                with contextlib.suppress(OSError):
                    s.close()
