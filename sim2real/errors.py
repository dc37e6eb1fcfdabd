"""The project's small set of exceptions.

Each failure kind has one class, so callers can catch what they can handle:
bad data from a file (``ConfigError``), a bus that did not answer
(``CommunicationError``), and a servo that reported a fault (``ServoError``).
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
