"""Measuring a batch's files on a Dask cluster (``holecli batch --cluster``): the files grouped into
tasks of many files each, each task measuring its files as a local batch worker does
(:func:`holecli.batch.pool.measure_guarded`), the records yielded as tasks finish.

A task costs the scheduler 0.2-1 ms, so a task per file would cost hours at 10^7 files: a task holds
:func:`files_per_task` files. A worker lost mid-task costs only its task, which the scheduler runs
again on another worker; the records of a task come back together when it has finished, so a task
run twice never gives a record twice. The scans must be readable from the workers (a shared file
system): a worker that cannot read a file gives that file's error record.

Dask (``distributed``) is the extra ``cluster``: it is imported only by :func:`require_distributed`,
so that this module's pure parts (:func:`parse_address`, :func:`group_files`, :func:`measure_files`)
import without it.
"""

from __future__ import annotations

import logging
import math
import os
import re
from contextlib import contextmanager

from holecli.batch.manifest import file_fingerprint
from holecli.batch.pool import measure_guarded
from holecli.batch.record import error_record, internal_error_message
from holecli.errors import HoleCliError

#: What a user is told when ``--cluster`` is given without Dask.
MISSING_DASK = "--cluster needs dask: pip install 'holecli[cluster]'"

#: At most this many files in a task (the default of :func:`files_per_task`): a lost task costs no
#: more than that, and the records stream back in steps no larger.
MAX_FILES_PER_TASK = 256

#: Tasks per worker at least (the default of :func:`files_per_task`), so that the workers finish
#: together rather than one waiting for the last long task.
TASKS_PER_WORKER = 4

#: Times a task whose code raised is run again (a worker lost mid-task is the scheduler's to
#: reschedule: ``distributed.scheduler.allowed-failures`` times, 3 by default).
TASK_RETRIES = 2

_LOCAL = re.compile(r"local:([0-9]+)")


class ClusterError(HoleCliError):
    """The cluster cannot be used: Dask is missing, the scheduler cannot be reached, or the address is
    neither ``local:N`` nor a scheduler's."""


def parse_address(address):
    """The cluster ``--cluster ADDRESS`` names.

    Parameters
    ----------
    address : str
        ``local:N`` (a cluster of N worker processes on this machine) or a Dask scheduler's address
        (``tcp://host:8786``, ``host:8786``).

    Returns
    -------
    int or str
        N for ``local:N``, else the address as given.

    Raises
    ------
    ClusterError
        For ``local:0``, ``local:`` followed by something else than a number, or an empty address.

    Examples
    --------
    >>> parse_address("local:2"), parse_address("tcp://10.0.0.5:8786")
    (2, 'tcp://10.0.0.5:8786')
    """
    address = address.strip()
    match = _LOCAL.fullmatch(address)
    if match:
        workers = int(match.group(1))
        if workers < 1:
            raise ClusterError(f"--cluster {address}: a local cluster needs at least one worker (local:N, N >= 1)")
        return workers
    if not address or address.lower().startswith("local"):
        raise ClusterError(f"--cluster {address}: give local:N (N worker processes here) or a Dask scheduler's "
                           f"address, e.g. tcp://host:8786")
    return address


def files_per_task(files, workers) -> int:
    """The default number of files in a task: ``max(1, min(256, ceil(files / (4 * workers))))``, at least
    four tasks per worker (the workers finish together) and at most 256 files a task (a lost task
    costs little; records stream back often); 10^7 files make some 40 000 tasks, seconds of the
    scheduler's time.

    Examples
    --------
    >>> files_per_task(60, 2), files_per_task(10**7, 100), files_per_task(3, 8)
    (8, 256, 1)
    """
    return max(1, min(MAX_FILES_PER_TASK, math.ceil(files / (TASKS_PER_WORKER * max(1, workers)))))


def group_files(paths, size) -> list:
    """``paths`` cut into consecutive tasks of ``size`` files (the last may be shorter).

    Examples
    --------
    >>> group_files(["a", "b", "c"], 2)
    [['a', 'b'], ['c']]
    """
    paths = list(paths)
    return [paths[start:start + size] for start in range(0, len(paths), size)]


def measure_files(paths, options, spec, explain, reading) -> list:
    """A cluster's task: the record of each of ``paths``, as a local batch worker makes it, with the
    file's :func:`~holecli.batch.manifest.file_fingerprint` taken just before it is measured (a file
    changed while measured then differs at the next ``--resume``).

    Parameters
    ----------
    paths : list of str
    options : dict
        Keyword arguments of :func:`holecli.detect_file`.
    spec : holecli.tolerance.Spec or holecli.inspection.Inspection or None
    explain : bool
    reading : dict
        ``scan``, ``units`` and ``plots`` of :func:`holecli.batch.pool.measure_guarded`, those given.

    Returns
    -------
    list of (dict, dict)
        ``(record, fingerprint)`` of each file, in order. No time limit per file: a worker's tasks
        run outside its main thread, where no alarm can be set.
    """
    results = []
    for path in paths:
        fingerprint = file_fingerprint(path)  # first: a file changed while measured differs at the next --resume
        results.append((measure_guarded(path, options, spec, explain, reading), fingerprint))
    return results


def lost_message(path) -> str:
    """The message of a file whose task could not finish: its worker was lost on every try."""
    return (f"{path}: the cluster could not measure this file: the workers running its task died (a crash in a "
            f"library, out of memory, or a worker stopped from outside)")


def require_distributed():
    """Import Dask's ``distributed``.

    Raises
    ------
    ClusterError
        With :data:`MISSING_DASK` when it is not installed.
    """
    try:
        import distributed
    except ImportError:
        raise ClusterError(MISSING_DASK) from None
    return distributed


@contextmanager
def cluster_client(address, verbose=False):
    """A Dask client of the cluster ``address`` (:func:`parse_address`), closed on exit.

    ``local:N`` starts a ``LocalCluster`` of N worker processes with one thread each, on the loopback
    interface only, without the dashboard, its workers batch workers
    (:class:`~holecli.batch.local_worker.LocalBatchWorker`: Ctrl-C is the batch's), and shuts it down on
    exit. Dask's own log lines are kept
    out of stderr (they are shown at ``verbose``).

    Yields
    ------
    distributed.Client

    Raises
    ------
    ClusterError
        When Dask is missing or the scheduler cannot be reached.
    """
    target = parse_address(address)
    distributed = require_distributed()
    level = logging.INFO if verbose else logging.CRITICAL
    logger = logging.getLogger("distributed")
    previous = logger.level
    logger.setLevel(level)
    cluster = client = None
    try:
        try:
            if isinstance(target, int):
                cluster = distributed.LocalCluster(n_workers=target, threads_per_worker=1, processes=True,
                                                   host="127.0.0.1", dashboard_address=None, silence_logs=level)
                client = distributed.Client(cluster)
                from holecli.batch.local_worker import LocalBatchWorker  # (it imports distributed)

                client.register_plugin(LocalBatchWorker(os.getpid()))
            else:
                client = distributed.Client(target, timeout=30)
        except (OSError, TimeoutError, ValueError) as error:
            raise ClusterError(f"--cluster {address}: cannot reach the scheduler: {error}") from None
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        logger.setLevel(previous)


def worker_count(client) -> int:
    """The workers the scheduler has now (at least 1)."""
    return max(1, len(client.scheduler_info().get("workers", {})))


def measure_on_cluster(paths, options, spec=None, *, client, task_size=None, should_stop=None,
                       poll_seconds=0.2, explain=False, scan=None, units=None, plots=None, fingerprints=None):
    """Measure ``paths`` on the cluster of ``client`` and yield each record as its task finishes
    (:func:`holecli.batch.measure_all`'s records and ``should_stop``, on a cluster).

    Parameters
    ----------
    paths : sequence of str
    options, spec, explain, scan, units, plots
        As :func:`holecli.batch.measure_all`'s.
    client : distributed.Client
    task_size : int, optional
        Files in a task (default :func:`files_per_task` of the workers there now).
    should_stop : callable, optional
        Called whenever tasks have finished (after their records are yielded) and at least every
        ``poll_seconds``; when it returns true the tasks not finished are cancelled and the generator
        returns (also when it is closed).
    fingerprints : dict, optional
        Filled with ``{record's file: fingerprint}`` as records are yielded (for the manifest).

    Yields
    ------
    dict
        The record of each file. A task whose workers were all lost (or whose code raised: a bug)
        gives each of its files an error record.
    """
    distributed = require_distributed()
    should_stop = should_stop or (lambda: False)
    reading = {key: value for key, value in (("scan", scan), ("units", units), ("plots", plots)) if value is not None}
    size = task_size or files_per_task(len(paths), worker_count(client))
    futures = {}
    for chunk in group_files(paths, size):
        future = client.submit(measure_files, chunk, options, spec, explain, reading, pure=False,
                               retries=TASK_RETRIES)
        futures[future] = chunk
    pending = set(futures)
    try:
        while pending:
            try:
                done, _ = distributed.wait(list(pending), timeout=poll_seconds, return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = ()
            for future in done:
                pending.discard(future)
                chunk = futures.pop(future)
                try:
                    results = future.result()
                except distributed.KilledWorker:
                    results = [(error_record(path, lost_message(path)), None) for path in chunk]
                except Exception as error:  # noqa: BLE001 - a task raising is a bug: never lose its files
                    results = [(error_record(path, internal_error_message(path, error)), None) for path in chunk]
                future.release()
                for record, fingerprint in results:
                    if fingerprints is not None and fingerprint is not None:
                        fingerprints[record["file"]] = fingerprint
                    yield record
            if should_stop():
                return
    finally:
        if pending:
            client.cancel(list(pending), force=True)
