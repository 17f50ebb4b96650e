"""Measure a scan with holecli serve: python serve_client.py SCAN [URL]; prints each hole."""
import sys
import time

import httpx

scan, url = sys.argv[1], (sys.argv[2:] or ["http://127.0.0.1:8000"])[0]
with httpx.Client(base_url=url, timeout=120) as client:
    for attempt in range(120):  # the service may still be starting
        try:
            client.get("/v1/health").raise_for_status()
            break
        except httpx.TransportError:
            time.sleep(0.5)
    answer = client.post("/v1/measure", json={"path": scan, "meta": {"part": "WING-7", "serial": "S0042"}})
    if answer.status_code != 200:
        sys.exit(f"{scan}: {answer.json()['error']['message']} ({answer.status_code})")
    record = answer.json()
    for hole in record["holes"]:
        print(record["id"][:8], hole["index"], [round(c, 3) for c in hole["center"]], round(hole["diameter"], 4))
