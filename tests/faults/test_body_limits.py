"""Request bodies are limited by the bytes received, chunked too: a 200 MB chunked sign-up is
refused with 413 before the rest is read, and the API's memory stays flat."""

from __future__ import annotations

import socket
import time


def chunked_post(port: int, path: str, total_mb: int, content_type: str,
                 head: bytes = b"") -> tuple[int, bytes, int]:
    """POST total_mb of chunked body on a raw socket; (status, response, bytes sent) as soon as the
    server answers (it may answer and close before everything is sent)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=60)
    sock.sendall((f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: {content_type}\r\n"
                  "Transfer-Encoding: chunked\r\n\r\n").encode())
    chunk, sent = b"a" * (1 << 20), 0
    sock.setblocking(False)
    answer = b""
    if head:
        _send_all(sock, b"%x\r\n" % len(head) + head + b"\r\n")
    try:
        for _ in range(total_mb):
            answer += _read_some(sock)
            if answer:
                break
            _send_all(sock, b"%x\r\n" % len(chunk) + chunk + b"\r\n")
            sent += len(chunk)
        else:
            _send_all(sock, b"0\r\n\r\n")
    except OSError:
        pass  # the server answered and closed while we were still sending
    sock.setblocking(True)
    sock.settimeout(60)
    while not _complete(answer):  # the body may arrive in a later packet than the headers
        more = sock.recv(65536)
        if not more:
            break
        answer += more
    sock.close()
    return int(answer.split(b" ", 2)[1]) if answer else 0, answer, sent


def _complete(answer: bytes) -> bool:
    """Whether answer holds the response's headers and all of its content-length."""
    head, found, body = answer.partition(b"\r\n\r\n")
    if not found:
        return False
    for line in head.split(b"\r\n")[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"content-length":
            return len(body) >= int(value)
    return True


def _read_some(sock: socket.socket) -> bytes:
    try:
        return sock.recv(65536)
    except BlockingIOError:
        return b""


def _send_all(sock: socket.socket, data: bytes) -> None:
    view = memoryview(data)
    while view:
        try:
            view = view[sock.send(view):]
        except BlockingIOError:
            time.sleep(0.001)


def test_chunked_bodies_are_cut_at_their_limit(live_factory):
    api = live_factory(max_upload_mb=5)
    before = api.rss_mb()
    status, answer, sent = chunked_post(api.port, "/api/v1/users", 200, "application/json")
    assert status == 413, answer[:300]
    assert b"1 MB" in answer, answer
    assert sent < 50 << 20, "the API must answer before reading the rest"
    assert api.rss_mb() - before < 50
    part = b'--x\r\nContent-Disposition: form-data; name="files"; filename="a.jpg"\r\n\r\n'
    status, answer, _ = chunked_post(api.port, "/api/v1/projects/1/images", 200,
                                     "multipart/form-data; boundary=x", part)
    assert status == 413 and b"5 MB" in answer, answer[:300]
    assert api.rss_mb() - before < 50
    assert api.request("GET", "/api/v1/health")[0] == 200
