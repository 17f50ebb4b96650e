"""Measure a scan over holecli serve's line protocol: python line_client.py SCAN [HOST:PORT]."""
import socket
import sys


def measure(path, host="127.0.0.1", port=8190, **keys):
    """Measure one scan; returns (id, holes, verdict), holes as dicts of floats (mm)."""
    words = ["MEASURE", '"%s"' % path.replace("\\", "\\\\").replace('"', '\\"')]
    words += ["%s=%s" % item for item in keys.items()]
    with socket.create_connection((host, port), timeout=120) as sock, sock.makefile("rb") as answers:
        sock.sendall((" ".join(words) + "\n").encode("utf-8"))
        fields = answers.readline().decode("utf-8").rstrip("\r\n").split(",")
    if fields[0] != "OK":
        raise RuntimeError("holecli: %s %s" % (fields[1], ",".join(fields[2:])))
    n = int(fields[2])
    holes = [dict(zip(("x", "y", "z", "d", "nx", "ny", "nz"), map(float, fields[3 + 8 * i:10 + 8 * i])),
                  verdict=fields[10 + 8 * i]) for i in range(n)]
    return fields[1], holes, fields[-1]


if __name__ == "__main__":
    host, port = (sys.argv[2] if len(sys.argv) > 2 else "127.0.0.1:8190").rsplit(":", 1)
    identifier, holes, verdict = measure(sys.argv[1], host, int(port), part="P-7", serial="S-0001")
    print(identifier[:8], holes, verdict)
