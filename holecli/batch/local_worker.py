"""The worker plugin of a local cluster (``holecli batch --cluster local:N``): each worker process
becomes a batch worker (:func:`holecli.batch.pool.become_worker`): Ctrl-C is the batch's, which
cancels the tasks and shuts the cluster down; the worker dies with the batch's process.

Imported only with Dask (the extra ``cluster``), by :func:`holecli.batch.cluster.cluster_client`.
"""

from __future__ import annotations

import threading

from distributed.diagnostics.plugin import WorkerPlugin

from holecli.batch.pool import become_worker


class LocalBatchWorker(WorkerPlugin):
    """Makes each worker of a local cluster a batch worker of the process ``parent`` (the batch's),
    also a worker the cluster starts again after one was lost.

    Parameters
    ----------
    parent : int
        The batch's process id.
    """

    name = "holecli-local-batch-worker"
    idempotent = True

    def __init__(self, parent):
        self.parent = parent

    def setup(self, worker):
        """Ignore Ctrl-C, take SIGTERM's default, die with the batch (in the worker's main thread)."""
        if threading.current_thread() is threading.main_thread():
            become_worker(self.parent)
