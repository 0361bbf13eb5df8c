"""Frame timing: wall clock per frame and per pass, with GL timer queries alongside.

A frame is a list of passes. Each timed frame starts with ``glFinish``, and each pass is
timed from its first call to a ``glFinish`` after it (``time.perf_counter``): on Mesa's
llvmpipe, where the "GPU" is the CPU's rasteriser threads, that is exactly what the pass
costs, and the frame's time is the sum. (The finish between passes costs llvmpipe
little: a framebuffer change ends its "scene" and starts the rasteriser anyway; only the
next pass's vertex work can no longer overlap the previous pass's fragments.)

Each pass is also wrapped in a ``GL_TIME_ELAPSED`` query, and its result is kept where it is
plausible. On this machine's llvmpipe (Mesa 22.3) the queries do not measure passes
reliably (docs/performance.md):

* moderngl's ``Query.elapsed`` reads the result with ``glGetQueryObjectuiv``, 32 bits, so
  it saturates at 2^32 - 1 ns = 4.295 s (the unculled lighting pass at 256 lights read
  exactly 4294.967 ms); the queries here use the raw entry points and
  ``glGetQueryObjectui64v``;
* llvmpipe time-stamps the query inside its rasteriser's bins: a query begun before a
  framebuffer change returned a time since boot, and one around the forward pass (many
  draws) returned 13 ms of a 1540 ms pass. Queries here begin after their pass's first
  framebuffer is bound, and a result outside [0.5, 1] x the pass's wall time (+1 ms) is
  discarded (``plausible``) rather than reported.
"""

from __future__ import annotations

import ctypes
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import moderngl

from app.gl.context import GLContext

GL_TIME_ELAPSED = 0x88BF
GL_QUERY_RESULT = 0x8866

TIMER_FINISH = "glFinish + perf_counter per pass"
TIMER_QUERY = "GL_TIME_ELAPSED (64-bit), kept where plausible"


class GLTimerQueries:
    """GL_TIME_ELAPSED queries through raw entry points, read as 64-bit results."""

    def __init__(self, load: Callable[[str], int], slots: int = 8) -> None:
        def fn(name: str, *signature: object) -> Callable:
            address = load(name)
            if not address:
                raise RuntimeError(f"{name} not found")
            return ctypes.CFUNCTYPE(*signature)(address)

        uint = ctypes.c_uint
        self._gen = fn("glGenQueries", None, ctypes.c_int, ctypes.POINTER(uint))
        self._delete = fn("glDeleteQueries", None, ctypes.c_int, ctypes.POINTER(uint))
        self._begin = fn("glBeginQuery", None, uint, uint)
        self._end = fn("glEndQuery", None, uint)
        self._get = fn("glGetQueryObjectui64v", None, uint, uint, ctypes.POINTER(ctypes.c_uint64))
        self._ids = (uint * slots)()
        self._gen(slots, self._ids)
        self.slots = slots

    @classmethod
    def create(cls, gl: GLContext) -> GLTimerQueries | None:
        """Queries for the current context, or None where the entry points are missing."""
        if gl.ctx.version_code < 330 and "GL_ARB_timer_query" not in gl.ctx.extensions:
            return None
        try:
            if gl.backend == "osmesa":
                load = gl._keepalive.load_opengl_function  # the OSMesa loader
            else:
                egl = ctypes.CDLL("libEGL.so.1")
                egl.eglGetProcAddress.restype = ctypes.c_void_p
                egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]

                def load(name: str) -> int:
                    return egl.eglGetProcAddress(name.encode()) or 0

            return cls(load)
        except (OSError, RuntimeError, AttributeError):
            return None

    def begin(self, slot: int) -> None:
        self._begin(GL_TIME_ELAPSED, self._ids[slot])

    def end(self) -> None:
        self._end(GL_TIME_ELAPSED)

    def elapsed_ns(self, slot: int) -> int:
        """The result of ``slot`` (waits for it)."""
        value = ctypes.c_uint64()
        self._get(self._ids[slot], GL_QUERY_RESULT, ctypes.byref(value))
        return int(value.value)

    def release(self) -> None:
        self._delete(self.slots, self._ids)


@dataclass
class Pass:
    """One pass of a frame: ``run()`` draws; ``target`` is the framebuffer it binds first."""

    name: str
    run: Callable[[], None]
    target: moderngl.Framebuffer | None = None


@dataclass
class Budget:
    """How many frames to time: a warm-up, then at least ``min_frames`` and at most
    ``max_frames``, stopping once ``seconds`` of timed frames have passed."""

    warmup: int = 1
    min_frames: int = 3
    max_frames: int = 9
    seconds: float = 20.0


@dataclass
class FrameTimes:
    """Frame and per-pass times in milliseconds: ``wall_ms`` per frame; per pass, the wall
    time to its glFinish, the plausible timer-query results, and the time its calls took
    to return (``submit``: on llvmpipe the vertex work and binning done on this thread)."""

    wall_ms: list[float]
    pass_ms: dict[str, list[float]]
    gpu_ms: dict[str, list[float]]
    submit_ms: dict[str, list[float]]
    timer: str
    notes: list[str] = field(default_factory=list)

    @property
    def median(self) -> float:
        return statistics.median(self.wall_ms)

    @staticmethod
    def _medians(values: dict[str, list[float]]) -> dict[str, float]:
        return {name: statistics.median(v) for name, v in values.items() if v}

    def pass_medians(self) -> dict[str, float]:
        return self._medians(self.pass_ms)

    def gpu_medians(self) -> dict[str, float]:
        return self._medians(self.gpu_ms)

    def submit_medians(self) -> dict[str, float]:
        return self._medians(self.submit_ms)


def _frame(
    ctx: moderngl.Context, passes: list[Pass], queries: GLTimerQueries | None
) -> tuple[list[float], list[float | None], list[float]]:
    """One frame: (wall ms per pass, query ms per pass or None, submit ms per pass)."""
    wall, submit = [], []
    ctx.finish()
    for slot, p in enumerate(passes):
        t0 = time.perf_counter()
        if queries is not None:
            if p.target is not None:
                p.target.use()  # the query must begin in the scene its pass draws into
            queries.begin(slot)
        p.run()
        if queries is not None:
            queries.end()
        t1 = time.perf_counter()
        ctx.finish()
        t2 = time.perf_counter()
        submit.append((t1 - t0) * 1e3)
        wall.append((t2 - t0) * 1e3)
    gpu: list[float | None] = [None] * len(passes)
    if queries is not None:
        gpu = [queries.elapsed_ns(slot) / 1e6 for slot in range(len(passes))]
    return wall, gpu, submit


def plausible(wall_ms: float, query_ms: float) -> bool:
    """A query result that can be the pass's time: within [0.5, 1] x its wall time, with
    1 ms of slack for the clock reads (see the module docstring for what llvmpipe does)."""
    return 0.5 * wall_ms - 1.0 <= query_ms <= wall_ms + 1.0


def time_frames(
    gl: GLContext,
    passes: list[Pass],
    budget: Budget,
    queries: GLTimerQueries | None,
    tick: Callable[[], None] | None = None,
) -> FrameTimes:
    """Warm up, then time frames of ``passes`` (see ``Budget``); ``tick`` after each frame."""
    return time_interleaved(gl, {"": passes}, budget, queries, tick)[""]


class _Record:
    """One variant's frames as they come in."""

    def __init__(self, names: list[str]) -> None:
        self.names = names
        self.frames: list[float] = []
        self.wall: dict[str, list[float]] = {n: [] for n in names}
        self.gpu: dict[str, list[float]] = {n: [] for n in names}
        self.submit: dict[str, list[float]] = {n: [] for n in names}
        self.rejected: dict[str, int] = {n: 0 for n in names}

    def add(self, wall: list[float], gpu: list[float | None], submit: list[float]) -> None:
        self.frames.append(sum(wall))
        for n, wv, gv, cv in zip(self.names, wall, gpu, submit, strict=True):
            self.wall[n].append(wv)
            self.submit[n].append(cv)
            if gv is not None and plausible(wv, gv):
                self.gpu[n].append(gv)
            elif gv is not None:
                self.rejected[n] += 1

    def times(self) -> FrameTimes:
        notes = [
            f"{n}: {k} of {len(self.frames)} timer-query results outside [0.5, 1] x the "
            "pass's wall time"
            for n, k in self.rejected.items()
            if k
        ]
        # A pass's query median is kept only if every frame's result was plausible.
        gpu = {n: v if not self.rejected[n] else [] for n, v in self.gpu.items()}
        return FrameTimes(self.frames, self.wall, gpu, self.submit, TIMER_FINISH, notes)


def time_interleaved(
    gl: GLContext,
    variants: dict[str, list[Pass]],
    budget: Budget,
    queries: GLTimerQueries | None,
    tick: Callable[[], None] | None = None,
) -> dict[str, FrameTimes]:
    """Time the frames of several variants in rounds, one frame of each per round and the
    order rotated every round, so that a change in the machine's speed while they are
    measured (another process, clock or cache effects) falls on every variant alike and
    the ratios between them stay fair. Each variant is warmed up first. Rounds stop after
    ``budget.max_frames``, or once there are ``budget.min_frames`` and ``budget.seconds``
    per variant have passed. ``tick`` after each frame."""
    ctx = gl.ctx
    for passes in variants.values():
        if queries is not None and len(passes) > queries.slots:
            raise ValueError("more passes than query slots")
        for _ in range(budget.warmup):  # shader JIT, texture allocation, first-use costs
            for p in passes:
                p.run()
            ctx.finish()
            if tick:
                tick()
    order = list(variants)
    records = {v: _Record([p.name for p in variants[v]]) for v in order}
    started = time.perf_counter()
    rounds = 0
    while rounds < budget.max_frames and (
        rounds < budget.min_frames or time.perf_counter() - started < budget.seconds * len(order)
    ):
        shift = rounds % len(order)
        for v in order[shift:] + order[:shift]:
            records[v].add(*_frame(ctx, variants[v], queries))
            if tick:
                tick()
        rounds += 1
    return {v: records[v].times() for v in order}


def summary(values: list[float]) -> tuple[float, float, float]:
    """(median, min, max)."""
    return statistics.median(values), min(values), max(values)


def round_ratios(
    a: FrameTimes, b: FrameTimes, a_passes: tuple[str, ...] = (), b_passes: tuple[str, ...] = ()
) -> dict[str, float] | None:
    """a / b per round of one ``time_interleaved`` run (frame k of each is round k, so a
    slowdown of the machine falls on both): the median and the range over rounds, of the
    whole frames or, where given, of the sums of the named passes. None without rounds."""

    def per_round(t: FrameTimes, names: tuple[str, ...]) -> list[float]:
        if not names:
            return t.wall_ms
        return [sum(v) for v in zip(*(t.pass_ms[n] for n in names), strict=True)]

    num, den = per_round(a, a_passes), per_round(b, b_passes)
    ratios = [x / y for x, y in zip(num, den, strict=False) if y > 0.0]
    if not ratios:
        return None
    return {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios),
            "rounds": len(ratios)}  # fmt: skip
