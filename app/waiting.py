"""Work a thread does ahead, in the time it would otherwise spend waiting.

A still render of a model file reads its scene on the main thread while other threads
decode the maps and make their levels (app/textures/early.py, maps.py); the scene's reader
then waits for them (the exposure meter reads the base colour's levels). What the render
does next, importing the renderer and starting the GL, needs none of that, so ``pbs
render`` declares it ``ahead`` and the texture layer's waits (``before_waiting``) do it
first: the main thread works while the maps are made instead of after them
(docs/performance.md, "A real asset against f3d"). Work is done only at a wait of the
thread that declared it, the one that takes it (a GL context is current on the thread
that made it).

Only the standard library is imported here: the texture layer's early decodes import this
module before numpy.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Generic, TypeVar

if TYPE_CHECKING:
    from concurrent.futures import Future

R = TypeVar("R")

T = TypeVar("T")

# The work declared ahead and not yet done, oldest first, each done at a wait of the
# thread that declared it (the one that takes its value: a GL context is current there).
_PENDING: list[Ahead] = []
_LOCK = threading.Lock()  # the list, between threads that declare and wait


class Ahead(Generic[T]):
    """A value made once on the thread that declares it (``ahead``): at the first of its
    waits that has time for it (``before_waiting``), else when ``get`` asks for it. An
    exception the making raises is kept and raised by ``get``: the caller meets it where
    it would have made the value itself, after everything it checks first."""

    def __init__(self, make: Callable[[], T], release: Callable[[T], Any] | None = None) -> None:
        self._make = make
        self._release = release
        self._made = False
        self._taken = False
        self._value: T | None = None
        self._error: BaseException | None = None
        self.thread: threading.Thread | None = None  # the declaring thread (``ahead``)

    def run(self) -> None:
        """Make the value now, where it is not made yet."""
        if self._made:
            return
        self._made = True
        _forget(self)
        try:
            self._value = self._make()
        except BaseException as exc:  # raised by get, to the caller that needs the value
            self._error = exc
            if not isinstance(exc, Exception):  # an interrupt stops the wait too
                raise

    def get(self) -> T:
        """The value (made now where no wait made it), or the making's exception."""
        self.run()
        self._taken = True
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]

    def drop(self) -> None:
        """No longer wanted: not made by a later wait; a value made and never taken is
        released (a GL context started for a render that was refused)."""
        _forget(self)
        if self._made and not self._taken and self._error is None and self._release:
            self._release(self._value)  # type: ignore[arg-type]


@contextmanager
def ahead(*works: Ahead) -> Iterator[None]:
    """Declare ``works`` to be made at this thread's waits within the block, in order;
    those not taken by its end are dropped (``Ahead.drop``)."""
    for work in works:
        work.thread = threading.current_thread()
    with _LOCK:
        _PENDING.extend(works)
    try:
        yield
    finally:
        for work in works:
            work.drop()


def before_waiting(future: Future | None) -> None:
    """Called where a thread is about to wait for ``future``: the work that thread
    declared ahead is done first, one piece at a time while ``future`` is still not done.
    Nothing where ``future`` is done (or None), nor on a thread that declared none (a
    texture layer's helper thread waiting for another's work)."""
    if future is None or future.done():
        return
    me = threading.current_thread()
    while not future.done():
        with _LOCK:
            work = next((w for w in _PENDING if w.thread is me), None)
        if work is None:
            return
        work.run()


def waited(future: Future[R]) -> R:
    """``future.result()``, this thread's work declared ahead done first while it is not
    done (``before_waiting``)."""
    before_waiting(future)
    return future.result()


def _forget(work: Ahead) -> None:
    with _LOCK:
        if work in _PENDING:
            _PENDING.remove(work)
