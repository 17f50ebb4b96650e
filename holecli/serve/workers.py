"""The service's warm worker processes: each measures one scan at a time, its imports paid once.

:class:`WorkerPool` is a :class:`concurrent.futures.ProcessPoolExecutor` of ``spawn``-ed processes
(the service's process has threads by the time a worker may need replacing, and ``fork`` from a
threaded process can copy a held lock). Each worker, once (:func:`_start_worker`): dies with the
service (the kernel's parent-death signal, even after ``kill -9``), ignores Ctrl-C (the service stops
its workers itself), runs BLAS on one thread (inherited ``OPENBLAS_NUM_THREADS=1``, see
:mod:`holecli.threads`), imports the pipeline, and caps the address space it may add to what the warm
worker holds (``--worker-memory-mb``). Each job (:func:`measure_job`) runs under the batch's time
limit (:func:`holecli.batch.pool._time_limit`: a wall-clock alarm backed by a CPU limit).

A worker that dies (a crash in a library, the CPU limit, the out-of-memory killer) breaks the pool;
:meth:`WorkerPool.submit` then starts a new one, and the job that was running gets a
:class:`WorkerDied` answer.
"""

from __future__ import annotations

import os
import threading
import time

from holecli.interrupts import deferred

__all__ = ["JobResult", "WorkerDied", "WorkerPool", "measure_job"]



class WorkerDied(Exception):
    """The worker measuring a job died (killed by its CPU limit, a crash, the out-of-memory killer)."""


class JobResult(dict):
    """What a worker sends back: ``record`` (the detect record) and ``measuring_ms``, or ``error``
    (one line) with ``status`` (HTTP-like: 408 out of time, 413 out of memory, 422 not measurable, 500
    a bug)."""


def _start_worker(parent, memory_mb):
    """Pool initializer: runs once in every worker (``parent``: the service's process id)."""
    import resource

    from holecli.batch.pool import become_worker

    become_worker(parent, no_core_dumps=True)  # a job may meet its CPU limit (--request-timeout)
    _warm_up()
    if memory_mb:
        # What this worker may add to its warm size: the address space it holds now (the libraries'
        # mappings, which are large and mostly never touched) plus memory_mb.
        held = _address_space_bytes()
        if held is not None:
            limit = held + int(memory_mb * 2**20)
            try:
                resource.setrlimit(resource.RLIMIT_AS, (limit, resource.getrlimit(resource.RLIMIT_AS)[1]))
            except (ValueError, OSError):
                pass


def _warm_up():
    """Pay the imports and first-call costs (the libraries' lazy imports, numpy's and scipy's first
    uses) once, by measuring the paper's Table I scene: the first request would otherwise take 0.3 s
    more than the next."""
    import holecli.inspection  # noqa: F401
    from holecli.pipeline import detect
    from holecli.simulation import synth
    from holecli.threads import single_blas_thread

    with single_blas_thread():
        detect(synth.make_scan(synth.table1_scene(), 0).points).to_dict()


def _address_space_bytes():
    """This process's virtual size (VmSize of /proc/self/status), in bytes; None off Linux."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        return None
    return None


def _ready(_=None):
    return os.getpid()


def measure_job(path, how, timeout):
    """Measure the scan ``path`` in a worker: a :class:`JobResult`, never an exception.

    Parameters
    ----------
    path : str
        The scan (a file the service checked it may read, or its copy of an upload).
    how : dict
        Keyword arguments of :func:`holecli.measure_scan` (``spec``, ``units``, ``input_format``,
        ``scan``, ``columns``, ``explain``, ``name`` and the detection options).
    timeout : float or None
        Seconds the job may take (None: no limit).

    Returns
    -------
    JobResult
    """
    from holecli.batch.pool import _time_limit
    from holecli.batch.record import FileTimeout, internal_error_message
    from holecli.measure import MeasureError, measure_scan
    from holecli.threads import single_blas_thread

    started = time.perf_counter()
    name = how.get("name") or path
    try:
        with _time_limit(timeout), single_blas_thread():
            record = measure_scan(path, **how).record
    except FileTimeout:
        return JobResult(error=f"{name}: not measured within the time limit of {timeout:g} s (--request-timeout)",
                         status=408)
    except MeasureError as error:
        status = 413 if isinstance(error.__cause__, MemoryError) else 422
        # a reader's message names the file it opened: the service's real path, or its copy of an
        # upload; the client is told the name it gave
        return JobResult(error=str(error).replace(path, name), status=status)
    except MemoryError:
        return JobResult(error=f"{name}: the scan needs more memory than a worker may use (--worker-memory-mb)",
                         status=413)
    except BaseException as error:  # noqa: BLE001 - a bug must not kill the worker or the service
        return JobResult(error=internal_error_message(name, error), status=500)
    return JobResult(record=record, measuring_ms=(time.perf_counter() - started) * 1e3)


class WorkerPool:
    """``workers`` warm processes measuring scans (:func:`measure_job`); replaced when one dies.

    Parameters
    ----------
    workers : int
        Processes (at least 1).
    memory_mb : float or None
        Address space each may add to its warm size (None: no cap).
    timeout : float or None
        Seconds a job may take (None: no limit).
    """

    def __init__(self, workers, memory_mb=None, timeout=None):
        self.workers = max(1, int(workers))
        self.memory_mb = memory_mb
        self.timeout = timeout
        self.restarts = 0
        self._lock = threading.Lock()
        self._executor = self._new_executor()

    def _new_executor(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_start_worker, initargs=(os.getpid(), self.memory_mb))

    def warm(self):
        """Start every worker now and wait until each has paid its imports (the service says it is ready
        only then)."""
        # More jobs than workers: every process is started (by the submissions, in this thread), and each
        # job waits for an initialized one. A signal waits until every process is launched and has its
        # start-up data (a process cut off in between dies with a traceback on the shared stderr).
        with deferred():
            jobs = [self._executor.submit(_ready, index) for index in range(self.workers * 2)]
        for job in jobs:
            job.result()

    def submit(self, path, how):
        """Measure ``path`` in a worker: a :class:`concurrent.futures.Future` of a :class:`JobResult`
        (or of :class:`WorkerDied`)."""
        from concurrent.futures import Future
        from concurrent.futures.process import BrokenProcessPool

        with self._lock:
            try:
                inner = self._executor.submit(measure_job, path, how, self.timeout)
            except BrokenProcessPool:
                self._replace()
                inner = self._executor.submit(measure_job, path, how, self.timeout)
        outer = Future()

        def relay(done):
            if outer.cancelled():  # the request was given up (its client went, the service stops)
                return
            try:
                outer.set_result(done.result())
            except BrokenProcessPool:
                with self._lock:
                    if self._executor is executor:
                        self._replace()
                outer.set_exception(WorkerDied(f"{how.get('name') or path}: the worker measuring it died "
                                               "(a crash in a library, or out of its CPU time or memory)"))
            except BaseException as error:  # noqa: BLE001 - the future must be answered
                outer.set_exception(error)

        executor = self._executor
        inner.add_done_callback(relay)
        return outer

    def _replace(self):
        old, self._executor = self._executor, self._new_executor()
        self.restarts += 1
        threading.Thread(target=old.shutdown, kwargs={"wait": True, "cancel_futures": True}, daemon=True).start()

    def close(self, wait=True):
        """Stop the workers (after their jobs when ``wait``; killed otherwise)."""
        if not wait:
            for process in list((getattr(self._executor, "_processes", None) or {}).values()):
                try:
                    process.kill()
                except (OSError, ValueError):
                    pass
        self._executor.shutdown(wait=True, cancel_futures=True)
