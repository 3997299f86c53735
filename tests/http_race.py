#!/usr/bin/env python3
"""http_race.py: requests that must reach lensrayd at the same moment, or
slowly.

    http_race.py idempotency URL TOKEN BODY KEYS N
    http_race.py trickle URL SECONDS
    http_race.py reconnect URL THREADS REQUESTS
    http_race.py hold URL N

For each of KEYS Idempotency-Keys, N connections send POST /v1/jobs with
that key and BODY, all but the last byte first; the last bytes go together
once every connection is ready, so the N requests arrive as one.  Prints
the number of keys whose answers name more than one job (0 when a key
makes one job, as docs/api.md promises), or an answer that is not 202.

curl's --parallel opens its connections one after another, and did not
once give two jobs for a key where this gave one in twenty.

`trickle` declares a 100000-byte body for POST /v1/jobs and sends it a byte
every 0.2 s, for SECONDS at most.  Prints "closed after N bytes" when the
daemon closes the connection first, "still open after N bytes" otherwise.

`reconnect`: THREADS threads each send REQUESTS GET /healthz, each on a
new connection closed before the next opens (a script's or a page's
way); prints how many were not answered 200.  `hold` opens N
connections, keeps them open and asks GET /healthz on each: prints how
many were answered.
"""
import json
import socket
import sys
import threading
import time
from urllib.parse import urlsplit


def answer(sock):
    """The status and the JSON body of one HTTP/1.1 answer."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError("the daemon closed before answering")
        data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    status = int(lines[0].split()[1])
    length = 0
    for line in lines[1:]:
        name, _, value = line.partition(b":")
        if name.strip().lower() == b"content-length":
            length = int(value)
    while len(body) < length:
        chunk = sock.recv(65536)
        if not chunk:
            break
        body += chunk
    return status, json.loads(body)


def together(host, port, request, n):
    """Sends `request` on n connections at once; the answers."""
    socks = [socket.create_connection((host, port), timeout=60)
             for _ in range(n)]
    for s in socks:
        s.sendall(request[:-1])
    ready = threading.Barrier(n)
    answers = [None] * n

    def last_byte(i):
        ready.wait()
        socks[i].sendall(request[-1:])
        answers[i] = answer(socks[i])
        socks[i].close()

    threads = [threading.Thread(target=last_byte, args=(i,))
               for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return answers


def idempotency(url, token, body, keys, n):
    u = urlsplit(url)
    body = body.encode()
    bad = 0
    for k in range(keys):
        request = (
            "POST /v1/jobs HTTP/1.1\r\nHost: %s\r\n"
            "Authorization: Bearer %s\r\nContent-Type: application/json\r\n"
            "Idempotency-Key: race-%d\r\nConnection: close\r\n"
            "Content-Length: %d\r\n\r\n" % (u.netloc, token, k, len(body))
        ).encode() + body
        answers = together(u.hostname, u.port, request, n)
        ids = {a[1].get("id") for a in answers if a[0] == 202}
        if len(ids) != 1 or any(a[0] != 202 for a in answers):
            bad += 1
            print("key race-%d: %s" % (k, answers), file=sys.stderr)
    print(bad)


def trickle(url, seconds):
    u = urlsplit(url)
    s = socket.create_connection((u.hostname, u.port), timeout=60)
    s.sendall(("POST /v1/jobs HTTP/1.1\r\nHost: %s\r\n"
               "Content-Type: application/json\r\nContent-Length: 100000\r\n"
               "\r\n" % u.netloc).encode())
    s.settimeout(0.2)
    sent = 0
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            if s.recv(1) == b"":
                print("closed after %d bytes" % sent)
                return
        except socket.timeout:
            pass
        except OSError:
            print("closed after %d bytes" % sent)
            return
        try:
            s.sendall(b" ")
            sent += 1
        except OSError:
            print("closed after %d bytes" % sent)
            return
    print("still open after %d bytes" % sent)


def reconnect(url, threads, requests):
    u = urlsplit(url)
    lost = [0]
    lock = threading.Lock()

    def client():
        for _ in range(requests):
            try:
                with socket.create_connection((u.hostname, u.port),
                                              timeout=30) as s:
                    s.sendall(("GET /healthz HTTP/1.1\r\nHost: %s\r\n\r\n"
                               % u.netloc).encode())
                    ok = answer(s)[0] == 200
            except (OSError, ValueError):
                ok = False
            if not ok:
                with lock:
                    lost[0] += 1

    ts = [threading.Thread(target=client) for _ in range(threads)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    print(lost[0])


def hold(url, n):
    u = urlsplit(url)
    socks = [socket.create_connection((u.hostname, u.port), timeout=30)
             for _ in range(n)]
    time.sleep(0.5)  # every connection accepted (or closed) by now
    answered = 0
    for s in socks:
        try:
            s.sendall(("GET /healthz HTTP/1.1\r\nHost: %s\r\n\r\n"
                       % u.netloc).encode())
            answered += answer(s)[0] == 200
        except (OSError, ValueError):
            pass
        s.close()
    print(answered)


if __name__ == "__main__":
    if len(sys.argv) == 7 and sys.argv[1] == "idempotency":
        idempotency(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]),
                    int(sys.argv[6]))
    elif len(sys.argv) == 5 and sys.argv[1] == "reconnect":
        reconnect(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
    elif len(sys.argv) == 4 and sys.argv[1] == "hold":
        hold(sys.argv[2], int(sys.argv[3]))
    elif len(sys.argv) == 4 and sys.argv[1] == "trickle":
        trickle(sys.argv[2], float(sys.argv[3]))
    else:
        sys.exit(__doc__)
