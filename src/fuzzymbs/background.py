"""A value computed in a background thread, for work that overlaps the study's own.

The brake's reference runs (:mod:`fuzzymbs.mbs.shared_steps`) and the models a study
builds ahead of need (:mod:`fuzzymbs.study.integration_check`) are single-sample
kernel runs on one core; the compiled kernels release the GIL, so a thread beside
the study's own work fills the core it would leave idle.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Generic, TypeVar

__all__ = ["Background"]

T = TypeVar("T")


class Background(Generic[T]):
    """A value computed in a background thread (the kernels release the GIL).

    :meth:`result` waits for it and re-raises its exception. The thread is a daemon:
    an interrupted study exits without waiting for a reference run. It pickles as
    its value (waiting for it), so that a model holding one goes to worker processes
    whole.
    """

    def __init__(self, function: Callable[..., T], *args: Any) -> None:
        self._done = threading.Event()
        self._value: T | None = None
        self._error: BaseException | None = None

        def run() -> None:
            try:
                self._value = function(*args)
            except BaseException as error:  # re-raised by result()
                self._error = error
            finally:
                self._done.set()

        threading.Thread(target=run, name="fuzzymbs-background", daemon=True).start()

    def result(self) -> T:
        self._done.wait()
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]

    def __reduce__(self):
        return (_ready, (self.result(),))


class _Ready(Background[T]):
    """A :class:`Background` whose value is known (after unpickling)."""

    def __init__(self, value: T) -> None:
        self._value = value

    def result(self) -> T:
        return self._value


def _ready(value: T) -> Background[T]:
    return _Ready(value)
