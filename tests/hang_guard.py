"""A test that would block (a FIFO opened as a model or robot file) fails instead of hanging the suite."""

from __future__ import annotations

import signal
from contextlib import contextmanager
from typing import Iterator


class Hung(Exception):
    """Raised in the test's own thread when its time is up."""


@contextmanager
def fails_after(seconds: int) -> Iterator[None]:
    """Raise :class:`Hung` in this thread after ``seconds`` (SIGALRM), the previous handler put back."""
    def hung(*_):
        raise Hung(f"blocked for {seconds} s")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
