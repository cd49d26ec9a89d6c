"""Every exception gbpipe raises on purpose, declared once, statically.

A leaf module: it imports nothing of gbpipe, so any layer may raise these. Each class
derives from the built-in exception a caller would catch without knowing gbpipe
(``ValueError`` for bad values, ``RuntimeError`` for a stage that failed), and from
:class:`GbpipeError`, so ``except gbpipe.errors.GbpipeError`` catches them all.

The messages follow one rule: name *where* (config key path, file, channel, sample
index), *what* was found, and *what would be valid*.
"""

from __future__ import annotations

__all__ = [
    "GbpipeError",
    "ConfigError",
    "UnstableGain",
    "DataError",
    "PulseError",
    "ExcitationError",
    "StageError",
]


class GbpipeError(Exception):
    """Base class of every error gbpipe raises deliberately."""


class ConfigError(GbpipeError, ValueError):
    """A configuration value is missing, of the wrong type, out of its physical range, or
    inconsistent with another value.

    Parameters
    ----------
    field : str
        Key path of the offending value, e.g. ``"gearbox.stages[1].ring"``; ``""`` for
        the whole configuration (e.g. a file that is not a mapping).
    problem : str
        What is wrong and what would be valid.

    Attributes
    ----------
    field : str
        The key path, for programs that react to it.
    """

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        where = f"config field '{field}'" if field else "config"
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):  # picklable across processes (two positional arguments)
        return (type(self), (self.field, self.problem))


class UnstableGain(ConfigError):
    """The configured controller gains make the closed-loop bench unstable; ``field``
    names the gain to lower."""


class DataError(GbpipeError, ValueError):
    """A signal or record cannot be used as it is: NaN or inf, a gap or clock jump, too
    short, of the wrong shape or unit.

    Parameters
    ----------
    source : str
        What holds the bad data: a variable, a file, ``file:channel``.
    problem : str
        What is wrong and how to fix it.
    sample : int, optional
        Index of the first offending sample, when there is one.
    """

    def __init__(self, source: str, problem: str, sample: int | None = None) -> None:
        self.source = source
        self.problem = problem
        self.sample = sample
        at = f" at sample {sample}" if sample is not None else ""
        super().__init__(f"{source}{at}: {problem}")

    def __reduce__(self):
        return (type(self), (self.source, self.problem, self.sample))


class PulseError(DataError):
    """A tachometer pulse train is unusable: missing or extra pulses, non-increasing
    times, pulses outside the record."""


class ExcitationError(GbpipeError, ValueError):
    """An identification input is not persistently exciting of the order needed: the
    message gives the rank of the input block-Hankel matrix against that order."""


class StageError(GbpipeError, RuntimeError):
    """Every result of a workflow stage failed: the job must fail, not write garbage."""
