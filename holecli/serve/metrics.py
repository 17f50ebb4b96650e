"""The service's Prometheus metrics (``GET /metrics``): requests and errors by front end, latency,
the queue, the workers. A registry of its own, not the process-global one, so that two services in
one process (the tests) do not share counts.
"""

from __future__ import annotations

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram, generate_latest
from prometheus_client.exposition import CONTENT_TYPE_LATEST

__all__ = ["CONTENT_TYPE", "Metrics"]

CONTENT_TYPE = CONTENT_TYPE_LATEST

# Seconds: a 10^4-point scan takes ~0.1 s, a 10^6-point one a few seconds.
_BUCKETS = (0.01, 0.025, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0)


class Metrics:
    """The counters of one service.

    Parameters
    ----------
    queue_depth : callable
        Returns the requests being measured or waiting.
    workers : int
    """

    def __init__(self, queue_depth=lambda: 0, workers=0):
        self.registry = CollectorRegistry(auto_describe=True)
        self.requests = Counter("holecli_requests", "Measurement requests answered, by front end and outcome "
                                "(ok or the error's status)", ["channel", "outcome"], registry=self.registry)
        self.errors = Counter("holecli_errors", "Requests answered with an error, by front end and status",
                              ["channel", "status"], registry=self.registry)
        self.latency = Histogram("holecli_request_seconds", "Time from a measurement request's receipt to its "
                                 "answer (stored), by front end", ["channel"], buckets=_BUCKETS,
                                 registry=self.registry)
        self.queue = Gauge("holecli_queue_depth", "Requests being measured or waiting for a worker",
                           registry=self.registry)
        self.queue.set_function(queue_depth)
        self.workers = Gauge("holecli_workers", "Worker processes", registry=self.registry)
        self.workers.set(workers)
        self.stored = Counter("holecli_stored_measurements", "Measurements committed to the store",
                              registry=self.registry)

    def observe(self, channel, seconds, status=None):
        """Count one answered request: ``status`` None for a stored measurement, else its error status."""
        outcome = "ok" if status is None else str(status)
        self.requests.labels(channel, outcome).inc()
        if status is None:
            self.stored.inc()
            self.latency.labels(channel).observe(seconds)
        else:
            self.errors.labels(channel, str(status)).inc()

    def text(self) -> bytes:
        """The Prometheus text exposition."""
        return generate_latest(self.registry)
