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

# The topics of work a layer offers to whoever declared they would do it ahead (``offer``,
# ``AheadEach``): a map's normal/roughness chain that the GL can draw, once its images are
# decoded (app/textures/maps.py ``PreparedLevels`` with a ``gl_source``).
GL_CHAIN = "gl chain"

# The work declared ahead and not yet done, oldest first, each done at a wait of the
# thread that declared it (the one that takes its value: a GL context is current there).
_PENDING: list[Ahead | AheadEach] = []
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

    def ready(self) -> bool:
        """Whether a wait may make it now: not made yet."""
        return not self._made

    @property
    def made(self) -> bool:
        """Whether it was made (or its making failed), at a wait or when asked for."""
        return self._made

    def get(self) -> T:
        """The value (made now where no wait made it), or the making's exception."""
        self.run()
        self._taken = True
        return self.lend()

    def lend(self) -> T:
        """The value for other work done ahead (made now where it is not made yet), not
        taken: ``drop`` still releases it where nothing takes it later. The making's
        exception where it failed."""
        self.run()
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]

    def drop(self) -> None:
        """No longer wanted: not made by a later wait; a value made and never taken is
        released (a GL context started for a render that was refused)."""
        _forget(self)
        if self._made and not self._taken and self._error is None and self._release:
            self._release(self._value)  # type: ignore[arg-type]


class AheadEach(Generic[T]):
    """Items of ``topic`` offered by any thread (``offer``) while its ``ahead`` block lasts,
    each done by ``handle`` at a wait of the thread that declares it, in the order they
    came: work that becomes possible while the thread reads (a map's chain once its
    images are decoded), where a value of ``Ahead`` is made once. An item whose handling
    raises is left as it is: the caller that needs it does the work itself and meets the
    error there. Items left at the block's end are dropped, done by their callers
    likewise."""

    def __init__(self, topic: str, handle: Callable[[T], Any]) -> None:
        self.topic = topic
        self._handle = handle
        self._items: list[T] = []
        self._lock = threading.Lock()
        self.thread: threading.Thread | None = None  # the declaring thread (``ahead``)

    def put(self, item: T) -> None:
        with self._lock:
            self._items.append(item)

    def ready(self) -> bool:
        """Whether an item waits to be handled."""
        with self._lock:
            return bool(self._items)

    def run(self) -> None:
        """Handle the items handed over so far, oldest first."""
        while True:
            with self._lock:
                if not self._items:
                    return
                item = self._items.pop(0)
            try:
                self._handle(item)
            except Exception:  # its caller does the work itself, and meets the error there
                continue

    def drop(self) -> None:
        """No longer wanted: items not handled yet are left to their callers."""
        _forget(self)
        with self._lock:
            self._items.clear()


@contextmanager
def ahead(*works: Ahead | AheadEach) -> Iterator[None]:
    """Declare ``works`` to be done at this thread's waits within the block, in order;
    those not taken by its end are dropped (``Ahead.drop``, ``AheadEach.drop``)."""
    for work in works:
        work.thread = threading.current_thread()
    with _LOCK:
        _PENDING.extend(works)
    try:
        yield
    finally:
        for work in works:
            work.drop()


def offer(topic: str, item: object) -> None:
    """Hand ``item`` to the work of ``topic`` declared ahead (``AheadEach``), where a thread
    declared any: it is done at one of that thread's waits, else by whoever needs it."""
    with _LOCK:
        takers = [w for w in _PENDING if isinstance(w, AheadEach) and w.topic == topic]
    for work in takers:
        work.put(item)


def before_waiting(future: Future | None) -> None:
    """Called where a thread is about to wait for ``future``: the work that thread
    declared ahead and that is ready (``ready``) is done first, one piece at a time while
    ``future`` is still not done. Nothing where ``future`` is done (or None), nor on a
    thread that declared none (a texture layer's helper thread waiting for another's
    work)."""
    if future is None or future.done():
        return
    me = threading.current_thread()
    while not future.done():
        with _LOCK:
            work = next((w for w in _PENDING if w.thread is me and w.ready()), None)
        if work is None:
            return
        work.run()


def waited(future: Future[R]) -> R:
    """``future.result()``, this thread's work declared ahead done first while it is not
    done (``before_waiting``)."""
    before_waiting(future)
    return future.result()


def _forget(work: Ahead | AheadEach) -> None:
    with _LOCK:
        if work in _PENDING:
            _PENDING.remove(work)
