"""The project's small set of exceptions.

Each failure kind has one class, so callers can catch what they can handle:
bad data from a file (``ConfigError``), a bad command-line value (``UsageError``),
a bus that did not answer (``CommunicationError``), and a servo that reported a fault
(``ServoError``).
"""

from __future__ import annotations


class BipedError(Exception):
    """Base of every error this project raises on purpose."""


class ConfigError(BipedError, ValueError):
    """A configuration, profile or controller file is malformed or inconsistent.

    The message names the file, the key (as a dotted path) and the problem.
    """

    def __init__(self, source: str, key: str, problem: str):
        self.source = str(source)
        self.key = key
        self.problem = problem
        where = f"{self.source}: {key}" if key else self.source
        super().__init__(f"{where}: {problem}")


class UsageError(BipedError, ValueError):
    """A value given on the command line (or to a function standing in for it) is wrong.

    The message names the flag and the problem, e.g. ``--disable-module: unknown module
    'nope' (this controller has: main)``.
    """
