"""``holecli serve``: the measuring service of a drilling cell.

One process loads once and answers measurement requests from the cell (HTTP/JSON, a line protocol over
TCP, OPC UA); warm worker processes measure; every answered measurement is committed to the results
store (:mod:`holecli.store`) before its answer leaves.

=============================  ===================================================================
``holecli.serve.service``      :class:`Service`: check a request, measure it, store it, answer
``holecli.serve.workers``      the warm worker processes
``holecli.serve.security``     the folders a request may read, the bearer token
``holecli.serve.specs``        the named specs and registrations (``--spec-dir``)
``holecli.serve.metrics``      the Prometheus counters (``GET /metrics``)
``holecli.serve.http``         the HTTP/JSON front end (FastAPI)
``holecli.serve.lines``        the line protocol over TCP
``holecli.serve.opcua``        the OPC UA front end (asyncua)
``holecli.serve.server``       the one event loop that runs the front ends, and its stop on signals
=============================  ===================================================================

The web framework, the ASGI server, the metrics and OPC UA libraries (the extras ``serve`` and
``opcua``) are imported by these modules only, never by ``holecli --help`` or the other commands.
"""
