"""A real S3 HTTP endpoint for tests: moto's server mode in a subprocess on a free port (not an
in-process mock), with a fresh bucket per store."""

from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import boto3
from botocore.config import Config

from tests.required import missing

CREDENTIALS = {"AWS_ACCESS_KEY_ID": "test-key", "AWS_SECRET_ACCESS_KEY": "test-secret",
               "AWS_DEFAULT_REGION": "us-east-1"}


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


class MotoServer:
    """`python -m moto.server` on 127.0.0.1:<free port>; stop() ends the process it started."""

    def __init__(self, log: Path) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = open(log, "ab")  # noqa: SIM115 (open as long as the server runs)
        self.process = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1",
                                         "-p", str(self.port)], stdout=self.log, stderr=self.log)
        self._wait()

    def _wait(self, timeout: float = 120.0) -> None:  # a loaded machine starts it slowly
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                missing(f"moto's server exited with {self.process.returncode}; see {self.log.name}")
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.5).close()
                return
            except OSError:
                time.sleep(0.1)
        self.stop()
        missing(f"moto's server did not answer on port {self.port} within {timeout} s")

    def client(self):
        return boto3.session.Session(aws_access_key_id=CREDENTIALS["AWS_ACCESS_KEY_ID"],
                                     aws_secret_access_key=CREDENTIALS["AWS_SECRET_ACCESS_KEY"],
                                     region_name=CREDENTIALS["AWS_DEFAULT_REGION"]).client(
            "s3", endpoint_url=self.url, config=Config(s3={"addressing_style": "path"}))

    def new_bucket(self) -> str:
        name = f"gsfm-{uuid.uuid4().hex[:12]}"
        self.client().create_bucket(Bucket=name)
        return name

    def objects(self, bucket: str) -> list[str]:
        pages = self.client().get_paginator("list_objects_v2").paginate(Bucket=bucket)
        return [item["Key"] for page in pages for item in page.get("Contents", [])]

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait(timeout=10)
        self.log.close()


_SLOW_DOWN_BODY = b"<Error><Code>SlowDown</Code><Message>Please reduce your request rate.</Message></Error>"
SLOW_DOWN = (b"HTTP/1.1 503 Slow Down\r\nContent-Type: application/xml\r\nConnection: close\r\n"
             b"Content-Length: %d\r\n\r\n%s" % (len(_SLOW_DOWN_BODY), _SLOW_DOWN_BODY))


class Gate:
    """A TCP gate in front of an S3 endpoint, so a test can take the store away while the server
    keeps its objects: `open` forwards every byte, `busy` answers each request 503 SlowDown (as S3
    does under load), `hung` reads each request and answers nothing, `closed` listens on nothing
    (connections refused, live ones cut)."""

    def __init__(self, target_port: int) -> None:
        self.target, self.port = target_port, free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.state, self.live, self.listener = "closed", set(), None
        self.open()

    def open(self) -> None:
        self.state = "open"
        if self.listener is None:
            self.listener = socket.socket()
            self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.listener.bind(("127.0.0.1", self.port))
            self.listener.listen(64)
            self.listener.settimeout(0.1)
            threading.Thread(target=self._accept, args=(self.listener,), daemon=True).start()

    def busy(self) -> None:
        self.open()
        self.state = "busy"
        self._cut()

    def hang(self) -> None:
        """Accept and read each request, answer nothing (an endpoint hung after the connect)."""
        self.open()
        self.state = "hung"
        self._cut()

    def close(self) -> None:
        self.state, listener, self.listener = "closed", self.listener, None
        if listener is not None:
            listener.close()
        self._cut()

    def _cut(self) -> None:
        for conn in list(self.live):
            with contextlib.suppress(OSError):
                conn.shutdown(socket.SHUT_RDWR)
            conn.close()
        self.live.clear()

    def _accept(self, listener: socket.socket) -> None:
        while self.listener is listener:
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.settimeout(None)
            handler = {"busy": self._slow_down, "hung": self._hold}.get(self.state, self._forward)
            threading.Thread(target=handler, args=(conn,), daemon=True).start()

    def _slow_down(self, conn: socket.socket) -> None:
        with conn, contextlib.suppress(OSError):
            head = b""
            while b"\r\n\r\n" not in head:
                chunk = conn.recv(65536)
                if not chunk:
                    return
                head += chunk
            conn.sendall(SLOW_DOWN)

    def _hold(self, conn: socket.socket) -> None:
        self.live.add(conn)
        with contextlib.suppress(OSError):
            while conn.recv(65536):
                pass

    def _forward(self, conn: socket.socket) -> None:
        try:
            upstream = socket.create_connection(("127.0.0.1", self.target))
        except OSError:
            conn.close()
            return
        self.live.update((conn, upstream))
        threading.Thread(target=_pipe, args=(upstream, conn), daemon=True).start()
        _pipe(conn, upstream)


def _pipe(source: socket.socket, target: socket.socket) -> None:
    with contextlib.suppress(OSError):
        while chunk := source.recv(65536):
            target.sendall(chunk)
    for end in (source, target):
        with contextlib.suppress(OSError):
            end.shutdown(socket.SHUT_RDWR)
