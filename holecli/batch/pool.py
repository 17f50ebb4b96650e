"""Measuring a batch's files in worker processes (:func:`measure_all`): the pool, each worker's
setup (dying with its parent, a time limit per file), and the records yielded as files finish.
"""

from __future__ import annotations

import importlib
import math
import os
import re
import signal
import stat
import time
from collections import deque
from contextlib import contextmanager

from holecli.batch.discover import default_jobs
from holecli.batch.record import FileTimeout, error_record, internal_error_message, measure_record

#: Seconds a worker may spend on one file (``--file-timeout``; 0 or None: no limit): far more than a
#: scan of 10^7 points takes, so that only a file that makes a reader or a library loop or wait
#: forever reaches it.
DEFAULT_FILE_TIMEOUT = 600.0


# Files handed to the pool ahead of the free workers, per worker: enough to keep every worker busy
# while the parent writes, few enough that an interrupt has little queued work to throw away.
_QUEUED_PER_WORKER = 2

# A binary_compressed PCD needs open3d; its header (a dozen short lines) is within this many bytes.
_PCD_HEADER_BYTES = 4096
_COMPRESSED_PCD = re.compile(rb"^DATA[ \t]+binary_compressed\b", re.IGNORECASE | re.MULTILINE)

_WORKER = {}

# Descriptors of the parent that a forked worker must not keep open: the locked output file (a
# worker holding it would keep the lock after the parent is gone).
PARENT_ONLY_DESCRIPTORS = set()

_PR_SET_PDEATHSIG = 1


def _start_worker(options, spec, preload, parent, explain=False, timeout=None, reading=None):
    """Pool initializer: runs once in every worker process (``parent``: the batch's process id;
    ``explain``: records with their ``rejected`` list; ``timeout``: seconds per file, or None;
    ``reading``: the ``scan`` and ``units`` keyword arguments of :func:`measure_record` that are given)."""
    become_worker(parent, no_core_dumps=bool(timeout))
    for descriptor in PARENT_ONLY_DESCRIPTORS:
        try:
            os.close(descriptor)
        except OSError:
            pass
    # Pay the heavy imports here, once per worker, rather than in the first file's measurement.
    importlib.import_module("holecli.pipeline")
    for name in preload:
        try:
            importlib.import_module(name)
        except (ImportError, OSError):
            pass  # the file that needs it reports the problem itself
    _WORKER.update(options=options, spec=spec, explain=explain, timeout=timeout, reading=reading or {})


def become_worker(parent, no_core_dumps=False):
    """What a worker process does first, a batch's or ``holecli serve``'s: ignore Ctrl-C and take
    SIGTERM's default, die with ``parent`` (:func:`_die_with_parent`) and, with ``no_core_dumps``, dump
    no core when its CPU limit kills it (:func:`_time_limit`).

    The parent handles Ctrl-C and SIGTERM and then ends its workers; a worker must not die of the
    terminal's SIGINT on its own (it would break the pool and lose its record). A worker killed by its
    CPU limit (SIGXCPU) gets an error record or answer instead, and a core file would be litter.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _die_with_parent(parent)
    if no_core_dumps:
        import resource

        try:
            resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
        except (ValueError, OSError):
            pass


def _die_with_parent(parent):
    """Have the kernel kill this worker when the batch's process dies, even by SIGKILL (Linux); a
    worker whose parent is already gone exits at once."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the pool's own checks end the worker later
        pass
    if os.getppid() != parent:
        os._exit(1)


def _measure_in_worker(path):
    """The record of ``path``, in a worker: always a record that can be sent to the parent.

    Whatever the file makes a reader or a library raise (a Rust panic, a KeyboardInterrupt or
    SystemExit of a library: the worker ignores SIGINT and is ended by the parent with SIGKILL, so
    none of them is a request to stop) becomes an error record here: an exception sent to the parent
    would end the batch there, or break the pool when it cannot be pickled. A file that takes longer
    than the time limit gets an error record too (:func:`_time_limit`).
    """
    return measure_guarded(path, _WORKER["options"], _WORKER["spec"], _WORKER["explain"], _WORKER["reading"],
                           _WORKER.get("timeout"))


def measure_guarded(path, options, spec, explain, reading, timeout=None):
    """The record of ``path`` as a batch worker makes it (:func:`_measure_in_worker`, a cluster's
    task too): :func:`measure_record` with ``reading`` (``scan``, ``units``, ``plots``: those given),
    within ``timeout`` seconds (None: no limit; the caller's main thread only), anything raised
    turned into an error record, the record one that can be pickled.

    Returns
    -------
    dict
    """
    reading = dict(reading)
    plots = reading.pop("plots", None)
    if plots is not None and path in plots:
        reading["plot_file"] = plots[path]
    try:
        with _time_limit(timeout):
            record = measure_record(path, options, spec, explain, **reading)
    except FileTimeout:
        record = error_record(path, timeout_message(path, timeout))
    except BaseException as error:  # noqa: BLE001 - see the docstring
        record = error_record(path, internal_error_message(path, error))
    return _sendable(path, record)


def timeout_message(path, timeout) -> str:
    """The message of a file that reached the batch's time limit (``--file-timeout``).

    Parameters
    ----------
    path : str or os.PathLike
    timeout : float
        The limit, in seconds.

    Returns
    -------
    str
    """
    return (f"{path}: not measured within the time limit of {timeout:g} s per file (--file-timeout): a reader or "
            f"a library looped or waited on this file, or the file is too large for the limit")


def _sendable(path, record):
    """``record``, or an error record when it cannot be pickled (sent to the parent)."""
    import pickle

    try:
        pickle.dumps(record)
    except BaseException as error:  # noqa: BLE001 - a record the pool cannot send would break it
        return error_record(path, f"{path}: internal error (a bug: please report it): its record cannot be sent to "
                                  f"the batch: {type(error).__name__}")
    return record


def _cpu_seconds():
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


@contextmanager
def _time_limit(seconds):
    """Limit the block to ``seconds`` (None or 0: no limit), in a worker's main thread.

    Two limits, for the two ways a file can hang a worker. SIGALRM after ``seconds`` of wall-clock
    time raises :class:`FileTimeout` as soon as Python code runs (a reader looping in Python, a
    blocked read, which the signal interrupts). A loop in native code never returns to Python, so a
    CPU limit backs it: the soft RLIMIT_CPU is set to the CPU time used so far plus ``seconds`` times
    the cores the worker may use (all its threads count, so that a file measured in several threads
    is not cut before its wall-clock limit), and put back after the block. Past it the kernel sends
    SIGXCPU, which kills the worker; :func:`measure_all` then gives the file an error record.
    """
    if not seconds:
        yield
        return
    import resource

    def expired(number, frame):
        raise FileTimeout

    previous_handler = signal.signal(signal.SIGALRM, expired)
    soft, hard = resource.getrlimit(resource.RLIMIT_CPU)
    budget = math.ceil(_cpu_seconds() + seconds * default_jobs()) + 1
    if hard != resource.RLIM_INFINITY:
        budget = min(budget, hard)
    limited = soft == resource.RLIM_INFINITY or budget < soft
    if limited:
        resource.setrlimit(resource.RLIMIT_CPU, (budget, hard))
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous_handler)
        if limited:
            resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))


def measure_all(paths, options, spec=None, *, jobs=1, should_stop=None, poll_seconds=0.2, explain=False, scan=None,
                units=None, plots=None, file_timeout=None):
    """Measure ``paths`` in ``jobs`` worker processes and yield each record as its file finishes.

    Parameters
    ----------
    paths : sequence of str
        The files, measured in this order (records come in the order they finish).
    options : dict
        Keyword arguments of :func:`holecli.detect_file` (see :func:`measure_record`).
    spec : holecli.tolerance.Spec, optional
        Tolerances checked in the workers.
    jobs : int
        Worker processes (at most one per file). They live for the whole batch: the heavy imports
        (the pipeline, and open3d when a binary_compressed PCD is among the files) are paid once per
        worker, in the pool initializer.
    should_stop : callable, optional
        Called without arguments whenever files have finished (after their records are yielded) and
        at least every ``poll_seconds``; when it returns true the workers are ended at once and the
        generator returns. The records already yielded are the finished ones.
    poll_seconds : float
        See ``should_stop``.
    explain : bool
        Records with their ``rejected`` list (see :func:`measure_record`).
    scan : int, optional
        The scan of each E57 file (see :func:`measure_record`).
    units : holecli.units.UnitChoice, optional
        The file's and the record's units (see :func:`measure_record`).
    plots : dict, optional
        ``{path: PNG}`` (:func:`plot_files`): each file's holes are also drawn, in the worker that
        measures it (see ``plot_file`` of :func:`measure_record`).
    file_timeout : float, optional
        Seconds a worker may spend on one file (None or 0: no limit): past them the file gets an
        error record (:func:`timeout_message`) and the batch goes on. Wall-clock time while Python
        code runs; a loop in native code is ended by a CPU limit of as many seconds per core, which
        kills the worker (see :func:`_time_limit`).

    Yields
    ------
    dict
        The record of each file, see :func:`measure_record`. Whatever a file makes a library raise
        becomes its error record. A file whose worker process dies (a crash in a library, the
        out-of-memory killer, a kill from outside, the CPU limit of ``file_timeout``) is measured
        again alone in a fresh pool, and gets an error record when that worker dies too.
    """
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    should_stop = should_stop or (lambda: False)
    waiting = deque(paths)
    suspects = deque()  # files in flight when a worker died: each is run alone to find the culprit
    alone = set()
    submitted = {}  # path: when it was last given to a worker (time.monotonic)
    context = _pool_context()
    input_format = options.get("input_format")
    preload = ("open3d",) if any(_is_compressed_pcd(path, input_format) for path in paths) else ()
    # --scan and --units/--output-units, passed on only when given
    reading = {key: value for key, value in (("scan", scan), ("units", units), ("plots", plots)) if value is not None}
    while waiting or suspects:
        executor = ProcessPoolExecutor(max_workers=max(1, min(jobs, len(waiting) + len(suspects))),
                                       mp_context=context, initializer=_start_worker,
                                       initargs=(options, spec, preload, os.getpid(), explain, file_timeout or None)
                                       + ((reading,) if reading else ()))
        in_flight = {}
        finished = False
        try:
            while waiting or suspects or in_flight:
                solo = bool(suspects) or any(path in alone for path in in_flight.values())
                limit = 1 if solo else jobs * _QUEUED_PER_WORKER
                while len(in_flight) < limit and (suspects or waiting):
                    path = suspects.popleft() if suspects else waiting.popleft()
                    in_flight[executor.submit(_measure_in_worker, path)] = path
                    submitted[path] = time.monotonic()
                done, _ = wait(in_flight, timeout=poll_seconds, return_when=FIRST_COMPLETED)
                records, broken = [], []
                for future in done:
                    path = in_flight.pop(future)
                    try:
                        records.append(future.result())
                    except BrokenProcessPool:
                        broken.append(path)
                    except BaseException as error:  # noqa: BLE001 - a worker sends records only; never lose a file
                        records.append(error_record(path, internal_error_message(path, error)))
                yield from records
                if broken:
                    # Every file in flight fails with the pool. A file that was measured alone in
                    # its own pool is known to be the one that killed its worker; every other one is
                    # measured again, alone (the killer may have been the out-of-memory killer, or
                    # a signal from outside, rather than the file).
                    wait(in_flight)
                    for future, path in in_flight.items():
                        if future.exception() is None:
                            yield future.result()
                        else:
                            broken.append(path)
                    in_flight.clear()
                    out_of_time = _a_worker_ran_out_of_cpu_time(executor)
                    for path in sorted(broken):
                        # Killed alone by its CPU limit: the exit status says so when the pool still
                        # holds the dead worker; the pool may have dropped it already (a loaded machine),
                        # and a worker alone that died after the time limit ran out was killed by it.
                        overran = file_timeout and time.monotonic() - submitted.get(path, math.inf) >= file_timeout
                        if path in alone and file_timeout and (out_of_time or overran):
                            yield error_record(path, timeout_message(path, file_timeout))
                        elif path in alone:
                            yield error_record(path, f"{path}: the worker process measuring this file died twice, "
                                                     f"the second time measuring it alone (a crash in a library, "
                                                     f"or out of memory)")
                        else:
                            suspects.append(path)
                            alone.add(path)
                    break
                if should_stop():
                    return
            finished = True
        finally:
            _end_pool(executor, graceful=finished)


def _a_worker_ran_out_of_cpu_time(executor):
    """Whether a worker of the broken pool ``executor`` was killed by its CPU limit (SIGXCPU)."""
    processes = list((getattr(executor, "_processes", None) or {}).values())
    for process in processes:
        try:
            process.join(timeout=5)
        except (OSError, ValueError, AssertionError):
            continue
    return any(getattr(process, "exitcode", None) == -signal.SIGXCPU for process in processes)


def _pool_context():
    import multiprocessing

    # fork: a worker starts at once with what the parent has imported (numpy, the readers) and pays
    # only the pipeline's imports, in parallel with the other workers and with the parent's own
    # start. The parent has no other thread when it forks (the progress display is refreshed by hand).
    if "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def _end_pool(executor, graceful):
    if not graceful:
        # The workers ignore SIGINT; kill them rather than wait for the files they are measuring.
        for process in list((getattr(executor, "_processes", None) or {}).values()):
            try:
                process.kill()
            except (OSError, ValueError):
                pass
    executor.shutdown(wait=True, cancel_futures=True)


def _is_compressed_pcd(path, input_format=None) -> bool:
    if (input_format or os.path.splitext(str(path))[1].lower()[1:]) != "pcd":
        return False
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False  # never open a FIFO or a device here: it could block the batch forever
        with open(path, "rb") as stream:
            head = stream.read(_PCD_HEADER_BYTES)
    except OSError:
        return False
    return _COMPRESSED_PCD.search(head) is not None
