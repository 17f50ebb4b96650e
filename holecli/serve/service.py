"""The measuring service behind every front end of ``holecli serve`` (HTTP, the TCP line protocol,
OPC UA): check a request, measure its scan in a warm worker, store the record, answer.

:meth:`Service.measure` is the one road: the front ends only translate their protocol into a
:class:`MeasureRequest` and the answer (or the :class:`ServiceError`) back. An answer leaves only after
the store has committed it. The store is used from one thread (its own), the workers from the event
loop through futures: nothing here blocks the loop.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Mapping, Optional

from holecli import __version__
from holecli.io.formats import INPUT_FORMATS
from holecli.serve.security import AccessError, confine
from holecli.serve.specs import SpecLibrary, SpecLookupError
from holecli.serve.workers import WorkerDied, WorkerPool
from holecli.store.schema import META_COLUMNS, check_meta, utc_text

__all__ = ["META_KEYS", "OPTIONS", "MeasureRequest", "Service", "ServiceError", "utc_now"]

#: The detection options a request may give, with what each must be (as ``holecli detect``'s options).
OPTIONS = {
    "method": "robust or paper",
    "min_diameter": "a number > 0",
    "max_holes": "an integer >= 1",
    "full_only": "true or false",
    "gauge_depth": "a number > 0",
    "view_dir": "three numbers",
    "units": "mm, m or in (the file's unit)",
    "output_units": "mm, m or in (the record's unit)",
    "scan": "an integer >= 0 (E57)",
    "columns": "three column names or numbers (text tables)",
    "explain": "true or false",
}

#: The metadata keys a measurement is filed under (any other word key is kept too).
META_KEYS = META_COLUMNS
_UNITS = ("mm", "m", "in")


class ServiceError(Exception):
    """A request the service cannot answer with a measurement.

    Attributes
    ----------
    status : int
        HTTP-like: 400 malformed, 401 no or wrong token, 403 outside the allowed folders, 404 unknown
        (file, spec, result), 408 out of time, 413 too large, 422 not measurable (the scan cannot be
        read or holds no cloud), 500 a bug, 503 unavailable (stopping, too many requests waiting, the
        store down).
    code : str
        The status as a word (``not_found``, ...).
    message : str
        One line, naming the file or value.
    """

    CODES = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found", 408: "timeout",
             413: "too_large", 422: "unmeasurable", 500: "internal_error", 503: "unavailable"}

    def __init__(self, status, message):
        message = " ".join(str(message).splitlines())
        super().__init__(message)
        self.status = status
        self.code = self.CODES.get(status, "error")
        self.message = message


@dataclass(frozen=True)
class MeasureRequest:
    """One measurement asked for.

    Attributes
    ----------
    path : str or None
        A scan the service may read (inside an ``--allow-dir`` folder; relative to the first).
    upload : bytes or None
        Or the scan itself.
    format : str or None
        The upload's format (``ply``, ``pcd``, ``csv``, ``txt``, ``xyz``, ``e57``, ``las``, ``laz``);
        with ``path``, read the file in this format whatever its extension.
    options : Mapping
        Detection options (:data:`OPTIONS`).
    spec, registration : str or None
        Names in the ``--spec-dir`` folder.
    meta : Mapping
        ``part``, ``serial``, ``cell``, ``operator`` (strings): what the store files it under.
    channel : str
        The front end (``http``, ``tcp``, ``opcua``), for the metrics.
    """

    path: Optional[str] = None
    upload: Optional[bytes] = None
    format: Optional[str] = None
    options: Mapping = field(default_factory=dict)
    spec: Optional[str] = None
    registration: Optional[str] = None
    meta: Mapping = field(default_factory=dict)
    channel: str = "http"


def utc_now() -> str:
    """Now, as the store writes moments (:func:`holecli.store.schema.utc_text`):
    ``2026-12-03T22:41:07.123Z``."""
    return utc_text(datetime.now(timezone.utc))


def detection_keywords(options) -> dict:
    """The :func:`holecli.measure_scan` keyword arguments of a request's ``options``.

    Raises
    ------
    ServiceError
        400, naming the option, when one is unknown or not what :data:`OPTIONS` says.
    """
    from holecli.units import UnitChoice

    if not isinstance(options, Mapping):
        raise ServiceError(400, "options: must be an object")
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise ServiceError(400, f"options: unknown {', '.join(map(str, unknown))} (known: {', '.join(OPTIONS)})")

    def bad(name):
        return ServiceError(400, f"options.{name}: must be {OPTIONS[name]}, not {options[name]!r}"[:300])

    def number(name, positive=True):
        value = options[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value \
                or value in (float("inf"), float("-inf")) or (positive and value <= 0):
            raise bad(name)
        return float(value)

    def integer(name, least):
        value = options[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < least or value > 2**31:
            raise bad(name)
        return value

    def flag(name):
        if not isinstance(options[name], bool):
            raise bad(name)
        return options[name]

    given = {name: value for name, value in options.items() if value is not None}
    options = given
    keywords, units = {}, {}
    for name in given:
        if name == "method":
            if options[name] not in ("robust", "paper"):
                raise bad(name)
            keywords[name] = options[name]
        elif name in ("min_diameter", "gauge_depth"):
            keywords[name] = number(name)
        elif name == "max_holes":
            keywords[name] = integer(name, 1)
        elif name in ("full_only", "explain"):
            keywords[name] = flag(name)
        elif name == "scan":
            keywords[name] = integer(name, 0)
        elif name == "view_dir":
            value = options[name]
            if not isinstance(value, (list, tuple)) or len(value) != 3:
                raise bad(name)
            direction = tuple(number_of(item, bad(name)) for item in value)
            if not any(direction):
                raise bad(name)
            keywords[name] = direction
        elif name == "columns":
            value = options[name]
            if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(map(_column, value)):
                raise bad(name)
            keywords[name] = tuple(value)
        elif name in ("units", "output_units"):
            if options[name] not in _UNITS:
                raise bad(name)
            units["file" if name == "units" else "output"] = options[name]
    if keywords.get("method") == "paper":
        others = sorted(set(keywords) & {"min_diameter", "max_holes", "full_only", "gauge_depth", "view_dir"})
        if others:
            raise ServiceError(400, f"options: {', '.join(others)} cannot be used with method paper")
    if units:
        keywords["units"] = UnitChoice(**units)
    return keywords


def _column(item):
    """Whether ``item`` names a column of a text table: a name, or a 0-based number."""
    if isinstance(item, str):
        return 0 < len(item) <= 100
    return isinstance(item, int) and not isinstance(item, bool) and 0 <= item < 10**6


def number_of(value, error):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value or abs(value) == float("inf"):
        raise error
    return float(value)


def checked_meta(meta) -> dict:
    """The request's ``meta`` as the store files it (:func:`holecli.store.schema.check_meta`).

    Raises
    ------
    ServiceError
        400, when the store would refuse it.
    """
    if not isinstance(meta, Mapping):
        raise ServiceError(400, "meta: must be an object of strings")
    try:
        return check_meta(meta)
    except ValueError as error:
        raise ServiceError(400, str(error)) from None


class Service:
    """Measures scans in warm workers and stores what it answers.

    Parameters
    ----------
    store : holecli.store.Store
        Where every answered measurement is committed before the answer leaves.
    workers : int
        Worker processes.
    allow_dirs : sequence of str
        The folders whose files a request may name (none: uploads only).
    spec_dir : str, optional
        The named specs and registrations (:class:`holecli.serve.specs.SpecLibrary`).
    max_upload_bytes : int
        The largest scan a request may carry.
    request_timeout : float or None
        Seconds a scan may take to measure.
    worker_memory_mb : float or None
        Address space a worker may add to its warm size.
    max_waiting : int, optional
        Requests that may wait for a worker beyond those being measured (default 16 per worker);
        past it a request gets 503 at once rather than a long wait.
    metrics : bool
        Count requests, errors and latency for ``GET /metrics`` (:class:`holecli.serve.metrics.Metrics`,
        prometheus_client: the extra ``serve``).
    """

    def __init__(self, store, workers=1, allow_dirs=(), spec_dir=None, max_upload_bytes=256 * 2**20,
                 request_timeout=60.0, worker_memory_mb=None, max_waiting=None, metrics=True):
        self.store = store
        self.allow_dirs = tuple(os.path.realpath(folder) for folder in allow_dirs)
        self.specs = SpecLibrary(spec_dir)
        self.max_upload_bytes = int(max_upload_bytes)
        self.request_timeout = request_timeout
        self.version = __version__
        self.last = None
        self.stopping = False
        self._subscribers = []
        self._pool = WorkerPool(workers, memory_mb=worker_memory_mb, timeout=request_timeout)
        self.workers = self._pool.workers
        self.max_waiting = 16 * self.workers if max_waiting is None else int(max_waiting)
        self._in_flight = 0
        self.metrics = None
        if metrics:
            from holecli.serve.metrics import Metrics

            self.metrics = Metrics(lambda: self._in_flight, self.workers)
        self._store_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="holecli-store")
        self._uploads = tempfile.mkdtemp(prefix="holecli-serve-uploads-")  # mode 0700
        self._started = time.time()

    # -- life ---------------------------------------------------------------------------------------

    def warm(self):
        """Start the workers and wait until their imports are done."""
        self._pool.warm()

    def close(self):
        """Stop the workers (after the jobs in flight), close the store, remove the uploads' folder."""
        self.stopping = True
        self._pool.close(wait=True)
        self._store_thread.submit(self.store.close).result()
        self._store_thread.shutdown(wait=True)
        shutil.rmtree(self._uploads, ignore_errors=True)

    def subscribe(self, callback):
        """Call ``callback(answer)`` (on the event loop) after every stored measurement."""
        self._subscribers.append(callback)

    @property
    def queue_depth(self) -> int:
        """Requests being measured or waiting for a worker."""
        return self._in_flight

    def health(self) -> dict:
        """What ``GET /v1/health`` answers."""
        return {"status": "stopping" if self.stopping else "ok", "version": self.version, "workers": self.workers,
                "worker_restarts": self._pool.restarts, "queue": self._in_flight,
                "store": getattr(self.store, "location", None), "uptime_s": round(time.time() - self._started, 3)}

    # -- measuring ----------------------------------------------------------------------------------

    async def measure(self, request) -> dict:
        """Measure, store and answer one request (counted in :attr:`metrics`).

        Returns
        -------
        dict
            The record ``holecli detect`` writes for the scan, with ``id``, ``received``,
            ``processing_ms`` (from receipt to the record, in ms), ``stored`` (true) and ``meta``.

        Raises
        ------
        ServiceError
        """
        started = time.perf_counter()
        try:
            answer = await self._measure(request, started)
        except ServiceError as error:
            if self.metrics is not None:
                self.metrics.observe(request.channel, time.perf_counter() - started, error.status)
            raise
        if self.metrics is not None:
            self.metrics.observe(request.channel, time.perf_counter() - started)
        return answer

    async def _measure(self, request, started):
        received = utc_now()
        if self.stopping:
            raise ServiceError(503, "the service is stopping")
        if self._in_flight >= self.workers + self.max_waiting:
            raise ServiceError(503, f"too many requests waiting ({self._in_flight}): try again")
        meta = checked_meta(request.meta)
        how = detection_keywords(request.options)
        try:
            inspection = self.specs.inspection(request.spec, request.registration)
        except SpecLookupError as error:
            raise ServiceError(error.status, str(error)) from None
        if inspection is not None:
            how["spec"] = inspection
        self._in_flight += 1
        upload_path = None
        try:
            if (request.path is None) == (request.upload is None):
                raise ServiceError(400, "give either a path or the scan itself")
            if request.upload is not None:
                fmt = request.format
                if fmt not in INPUT_FORMATS:
                    raise ServiceError(400, f"format: the upload's format must be one of {', '.join(INPUT_FORMATS)}, "
                                            f"not {fmt!r}"[:300])
                if len(request.upload) > self.max_upload_bytes:
                    raise ServiceError(413, f"the scan is larger than {self.max_upload_bytes} bytes (--max-upload-mb)")
                shown = f"upload.{fmt}"
                upload_path = await asyncio.get_running_loop().run_in_executor(
                    None, self._save_upload, request.upload, fmt)
                path, how["name"] = upload_path, shown
            else:
                try:
                    path = confine(request.path, self.allow_dirs)
                except AccessError as error:
                    raise ServiceError(error.status, str(error)) from None
                shown = request.path
                how["name"] = shown
                how["resolve_path"] = True
                if request.format is not None:
                    if request.format not in INPUT_FORMATS:
                        raise ServiceError(400, f"format: must be one of {', '.join(INPUT_FORMATS)}, "
                                                f"not {request.format!r}"[:300])
                    how["input_format"] = request.format
            try:
                result = await asyncio.wrap_future(self._pool.submit(path, how))
            except WorkerDied as error:
                raise ServiceError(503, str(error)) from None
            if "error" in result:
                raise ServiceError(result["status"], result["error"])
            record = result["record"]
            record["file"] = shown  # as the request named it (the service read the file's real path)
            processing_ms = (time.perf_counter() - started) * 1e3
            identifier = uuid.uuid4().hex
            try:
                await asyncio.get_running_loop().run_in_executor(
                    self._store_thread, lambda: self.store.add(record, id=identifier, received=received,
                                                               processing_ms=processing_ms, meta=meta,
                                                               source="serve"))
            except Exception as error:  # noqa: BLE001 - a store that cannot take it: nothing is acknowledged
                raise ServiceError(503, f"the store did not take the measurement: {type(error).__name__}: {error}")
        finally:
            self._in_flight -= 1
            if upload_path is not None:
                try:
                    os.unlink(upload_path)
                except OSError:
                    pass
        answer = dict(record, id=identifier, received=received, processing_ms=processing_ms, stored=True, meta=meta)
        self.last = answer
        for callback in list(self._subscribers):
            try:
                callback(answer)
            except Exception:  # noqa: BLE001 - a subscriber's bug must not undo a stored measurement
                pass
        return answer

    def _save_upload(self, data, fmt):
        handle, path = tempfile.mkstemp(suffix="." + fmt, dir=self._uploads)
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        return path

    async def result(self, identifier) -> dict:
        """The stored answer ``identifier``.

        Raises
        ------
        ServiceError
            404 when the store does not hold it; 400 when it is not an id.
        """
        if not isinstance(identifier, str) or not 1 <= len(identifier) <= 64 or not identifier.isalnum():
            raise ServiceError(400, f"{str(identifier)[:64]!r}: not a result id")
        answer = await self._in_store(self.store.get, identifier)
        if answer is None:
            raise ServiceError(404, f"result {identifier}: not in the store")
        return answer

    async def results(self, **filters) -> list:
        """The summaries of the stored measurements that match ``filters`` (see
        :meth:`holecli.store.Store.find`), newest first."""
        return await self._in_store(lambda: self.store.find(**filters))

    async def _in_store(self, function, *args):
        try:
            return await asyncio.get_running_loop().run_in_executor(self._store_thread, function, *args)
        except ValueError as error:  # a filter the store cannot take
            raise ServiceError(400, str(error)) from None
        except Exception as error:  # noqa: BLE001
            raise ServiceError(503, f"the store cannot be read: {type(error).__name__}: {error}") from None
