#!/usr/bin/env python3
"""Attacks HTTP endpoints as a hostile or broken client would, for SECONDS.

Against each HOST:PORT: TRICKLE clients that send a request one byte a second and never finish
it, SILENT clients that connect and send nothing (each reconnects at once when the server drops
it, so the attack holds its share for the whole time), and once a second one of: random bytes,
an oversized request, a half-closed request, a request with a body and a bad method, a header
without an end. Prints one JSON line: connections made, dropped by the server, refused.

  metrics_attacker.py SECONDS TRICKLE SILENT HOST:PORT...
"""
import json
import os
import random
import selectors
import socket
import sys
import time

seconds, trickle, silent = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
targets = [(a.rsplit(":", 1)[0], int(a.rsplit(":", 1)[1])) for a in sys.argv[4:]]
counts = {"connections": 0, "dropped_by_server": 0, "refused": 0, "garbage_sent": 0}
selector = selectors.DefaultSelector()
trickle_line = b"GET /metrics HTTP/1.1\r\nHost: x\r\nX-Slow: " + b"a" * 100000


def connect(target, kind):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setblocking(False)
    try:
        s.connect(target)
    except BlockingIOError:
        pass
    except OSError:
        counts["refused"] += 1
        s.close()
        return
    counts["connections"] += 1
    selector.register(s, selectors.EVENT_READ, {"target": target, "kind": kind, "sent": 0})


def garbage(target, i):
    """One malformed request; the socket is left for the server to close."""
    kinds = [
        lambda: os.urandom(random.randint(1, 4096)),
        lambda: b"GET /metrics HTTP/1.1\r\n" + b"X-Big: " + b"b" * (1 << 20) + b"\r\n\r\n",
        lambda: b"GET /metr",  # then half-closed
        lambda: b"PUT /metrics HTTP/1.1\r\nContent-Length: 99999999\r\n\r\nxx",
        lambda: b"GET /metrics HTTP/1.1\r\nHost: x\r\n" + b"X: y\r\n" * 2000,
        lambda: b"GET /\x00\xff../../etc/passwd HTTP/9.9\r\n\r\n",
        lambda: b"\r\n" * 1000,
    ]
    payload = kinds[i % len(kinds)]()
    try:
        s = socket.create_connection(target, timeout=1)
        s.settimeout(0.2)
        try:
            s.sendall(payload)
        except OSError:
            pass  # the server may close an oversized request early: that is its right
        if i % len(kinds) == 2:
            s.shutdown(socket.SHUT_WR)
        counts["garbage_sent"] += 1
        s.close()
    except OSError:
        counts["refused"] += 1


for target in targets:
    for _ in range(trickle):
        connect(target, "trickle")
    for _ in range(silent):
        connect(target, "silent")

end = time.monotonic() + seconds
next_tick = time.monotonic()
tick = 0
while time.monotonic() < end:
    for key, _ in selector.select(timeout=0.05):
        s, data = key.fileobj, key.data
        try:
            closed = s.recv(65536) == b""
        except OSError:
            closed = True
        if closed:  # the server gave up on this client: come back at once
            counts["dropped_by_server"] += 1
            selector.unregister(s)
            s.close()
            connect(data["target"], data["kind"])
    if time.monotonic() >= next_tick:
        next_tick += 1.0
        for key in list(selector.get_map().values()):
            data = key.data
            if data["kind"] != "trickle":
                continue
            try:
                key.fileobj.send(trickle_line[data["sent"]:data["sent"] + 1])
                data["sent"] += 1
            except OSError:
                pass
        for target in targets:
            garbage(target, tick)
        tick += 1

for key in list(selector.get_map().values()):
    key.fileobj.close()
print(json.dumps(counts))
