"""A cheap clock of a method's stages: :class:`StageClock` (one ``time.perf_counter`` per boundary)."""

from __future__ import annotations

import time


class StageClock:
    """Times the stages of one detection, in the order they run.

    Parameters
    ----------
    progress : callable, optional
        Called with the name of each stage as it starts (the command line's status line); it must be
        cheap and must not raise.

    Attributes
    ----------
    stages : list of (str, float)
        The stages finished so far and their milliseconds.
    """

    def __init__(self, progress=None):
        self._progress = progress
        self._name = None
        self._started = 0.0
        self.stages = []

    def start(self, name):
        """End the running stage (if any) and start ``name``.

        Parameters
        ----------
        name : str
        """
        now = time.perf_counter()
        if self._name is not None:
            self.stages.append((self._name, (now - self._started) * 1000.0))
        self._name, self._started = name, now
        if self._progress is not None:
            self._progress(name)

    def stop(self):
        """End the running stage.

        Returns
        -------
        tuple of (str, float)
            Every stage and its milliseconds.
        """
        if self._name is not None:
            self.stages.append((self._name, (time.perf_counter() - self._started) * 1000.0))
            self._name = None
        return tuple(self.stages)
