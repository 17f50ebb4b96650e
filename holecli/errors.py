"""The exceptions holecli raises.

Every error the package raises on purpose derives from :class:`HoleCliError`, so a caller can catch
the one base class. The command-line interface turns each into a one-line ``Error: ...`` message on
stderr and a documented exit code.
"""


class HoleCliError(Exception):
    """Base class of every error raised by holecli."""


class LoadError(HoleCliError):
    """A point-cloud file could not be read, or holds no usable points.

    Parameters
    ----------
    path : str
        The file that was being read.
    problem : str
        What is wrong with it, as one short sentence without a trailing period.
    """

    def __init__(self, path, problem):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class PointsError(HoleCliError, ValueError):
    """The points handed to the detection pipeline are unusable (wrong shape, too few, degenerate).

    Parameters
    ----------
    message : str
        What is wrong, as one line.
    """


class SpecError(HoleCliError, ValueError):
    """A tolerance specification (command-line values or a spec file) is invalid.

    Parameters
    ----------
    message : str
        What is wrong and where (the key, the hole), as one line.
    """
