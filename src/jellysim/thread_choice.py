"""The thread count, chosen by timing the run itself (``threads = None``).

Whether a second thread pays depends on the machine and its load as much as on the body: the
work between two parallel regions must outweigh waking the other thread, and with another
process busy on the cores a second thread waits for one at every region.  Measured (real-time
factor or steps/s, 2 threads / 1; BENCHMARKS.md "Threads and body size", "Threads chosen by
timing", "A short spin, chosen by timing"): with threads that sleep at once (passive), the
physical path's second thread paid from 24,576 tets on the AVX-512 VM of session 7 and from
8,000-13,000 on the AVX2 VM of 2026-12-07, the report's step from 31,704 springs; with the
10 us spin set at import (session 32), from about 2,000 tets and 2,500 springs, while with a
busy process per core two spinning threads ran the paper scene slower than one (5.3k against
9.0k steps/s, session 31).  No fixed threshold is right for every
machine and load, so when the user gives no thread count the Simulator starts with a size rule
(:func:`auto_threads`, :data:`PHYSICAL_PARALLEL_MIN_TETS`),
times its first frames (the physical path) or pieces (springs: :meth:`Simulator.advance` steps
in pieces of at most 0.2 s, :data:`TRY_PIECE_SECONDS` during a try) on both counts
(:class:`ThreadChoice`), keeps all threads only where they ran a step faster than one by more
than :data:`MARGIN` (else one: a tie leaves the other core to other work), and tries the other
again every :data:`PROBE_EVERY` frames / :data:`SPRINGS_PROBE_SECONDS` of steps (a
machine's load changes).  Results do not depend on the thread count (every per-point sum has a
fixed order, tested), so switching changes only the speed.

Only for the numba backend, bodies of at least :data:`ADAPTIVE_MIN_TETS` tets /
:data:`ADAPTIVE_MIN_SPRINGS` springs, more than one numba thread, and not under ``mpiexec``
(ranks are given their threads).
"""
from __future__ import annotations

import statistics

__all__ = ["ThreadChoice", "for_physical", "for_springs", "auto_threads", "ADAPTIVE_MIN_TETS",
           "ADAPTIVE_MIN_SPRINGS", "PROBE_EVERY", "SPRINGS_PROBE_SECONDS", "MARGIN"]

ADAPTIVE_MIN_TETS = 2_000
"""Smaller physical bodies keep one thread (with the 10 us spin a second thread ran 2,058 tets
1.0-2.2x as fast as one: a try costs frames, and a frame of so few tets costs little)."""

ADAPTIVE_MIN_SPRINGS = 1_000
"""Smaller spring bodies keep one thread (with the 10 us spin the report's step ran 1,109
springs 0.55-0.63x as fast on two threads, 2,480 springs 1.36-1.41x)."""

SPRINGS_PROBE_SECONDS = 2.0
"""Wall time [s] of steps on the chosen count between two tries of the other on the springs
path (a try: two pieces of at most :data:`TRY_PIECE_SECONDS`).  Timed, not counted in pieces:
a piece ends with each :meth:`Simulator.advance` call, and a loop of short calls (500 steps of
the paper scene, 25 ms) tried the slower count on one call in six."""

TRY_PIECE_SECONDS = 0.02
"""Wall time [s] of a piece during a try (the springs path): a try of the first ten pieces
takes about 0.2 s, a later one 0.04 s."""

PROBE_EVERY = 120
"""Frames between two tries of the other thread count (2 s of simulated time at 60 frames/s;
a try costs at most its two frames' difference)."""

MARGIN = 0.10
"""All threads are kept when their steps were faster than one thread's by more than this
fraction, else one thread (frame times on a shared 2-core VM scatter by 10-30 %: a smaller
margin switched on noise)."""

KEEP = 5
"""Timings kept per thread count (their median decides)."""

PARALLEL_MIN_POINTS = 200
"""Below this many points one thread is used."""

PARALLEL_MIN_SPRINGS = 2_000
"""Below this many springs the springs path STARTS on one thread (then, from
:data:`jellysim.thread_choice.ADAPTIVE_MIN_SPRINGS`, keeps the faster of 1 and all by timing
its pieces).  Each parallel region wakes the other thread: with the 10 us spin set at import,
the report's step on 2 threads against 1 ran 0.55-0.63x at 1,109 springs, 1.36-1.41x at
2,480, 1.59-1.68x at 10,127 (the paper scene); with passive threads 0.69x at 10,127 and
1.17x at 31,704 (BENCHMARKS.md "A short spin, chosen by timing", "Threads and body size")."""


PHYSICAL_PARALLEL_MIN_TETS = 8_000
"""Below this many tets the physical path STARTS on one thread, then keeps the faster of 1
and all threads by timing frames (:mod:`jellysim.thread_choice`: with the 10 us spin two
threads ran 7,986 tets 1.5-2.9x as fast as one; with passive threads a second thread paid from
24,000 tets on the AVX-512 VM of session 7, from about 8,000-13,000 on the AVX2 VM)."""


def auto_threads(point_count: int, spring_count: int | None = None) -> int:
    """The thread count a Simulator given none starts on (it then times both counts:
    :mod:`jellysim.thread_choice`): 1 for small bodies (fewer than :data:`PARALLEL_MIN_POINTS`
    points or :data:`PARALLEL_MIN_SPRINGS` springs); 1 on a heavily oversubscribed machine
    (1-minute load average above twice the CPU count: with a load average of 19 on 2 cores a
    second thread waits for a core at every parallel region, and the paper scene ran 39
    steps/s on 2 threads, 3,244 on one; BENCHMARKS.md, "Contention"); otherwise all of
    numba's threads."""
    import os

    import numba

    if point_count < PARALLEL_MIN_POINTS or (spring_count is not None
                                             and spring_count < PARALLEL_MIN_SPRINGS):
        return 1
    most = numba.config.NUMBA_NUM_THREADS
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average on this platform
        return most
    return 1 if load > 2.0 * (os.cpu_count() or 1) else most


class ThreadChoice:
    """Which thread count each frame runs on, from the timings of earlier frames.

    Call :meth:`next_frame` before a frame: ``(threads, timed)``; after a timed frame,
    :meth:`record` its wall time [s] and the substeps it ran.  The first frame on each count
    is not timed (it may load or compile that count's kernels).  The first try interleaves
    the two counts (four timed frames each, so that a change of the machine's load hits
    both alike); later tries run three frames on the other count (the first untimed) between
    frames on the current one.  A try ends with the decision: the median of each count's last
    :data:`KEEP` timings (for the count a later try ran, its two timings of that try)."""

    def __init__(self, start: int, most: int, probe_every: int = PROBE_EVERY,
                 probe_seconds: float | None = None, min_seconds: float = 0.0):
        self.probe_every = float(probe_seconds) if probe_seconds is not None else probe_every
        self._timed_probe = probe_seconds is not None
        """Whether :attr:`probe_every` counts seconds of recorded frames, not frames."""
        self.min_seconds = float(min_seconds)
        """A timing is at least this long [s]: shorter frames of one count are summed (and a
        try runs that count again) until they are (the springs path: a piece ends with each
        advance call, and 1 ms pieces of advance(10) chose one thread in one run of four)."""
        self._sum = {c: [0.0, 0] for c in (1, int(most))}
        self.counts = (1, int(most))
        self.current = int(start) if int(start) in self.counts else 1
        self.cost: dict[int, list[float]] = {c: [] for c in self.counts}
        """Recent seconds per substep, per thread count."""
        other = self.other
        self._plan: list[tuple[int, bool]] = ([(self.current, False), (other, False)]
                                              + [(self.current, True), (other, True)] * 4)
        self._trying = True
        """Whether the frames planned are a try (decided on when they have run)."""
        self._since_try = 0
        self.chosen = False
        """Whether the first try has been decided (a run's pace is judged after it: during
        it, frames alternate the counts; the scale trial's 10,948-point body was told "about
        4 min more" at that pace and took 2.2)."""

    def __setstate__(self, state: dict) -> None:
        """A chooser pickled before session 32 (a Simulator in an older checkpoint) gets the
        fields it lacked, as the physical path's chooser had them."""
        self.__dict__.update({"probe_every": PROBE_EVERY, "_timed_probe": False,
                              "min_seconds": 0.0}, **state)
        self.__dict__.setdefault("_sum", {c: [0.0, 0] for c in self.counts})

    @property
    def trying(self) -> bool:
        """Whether the frame :meth:`next_frame` last gave is part of a try."""
        return self._trying

    @property
    def other(self) -> int:
        return self.counts[1] if self.current == self.counts[0] else self.counts[0]

    def next_frame(self) -> tuple[int, bool]:
        """(thread count, whether to time the frame) of the next frame."""
        if not self._plan:
            if self._trying:
                self._decide()
                self._trying, self._since_try, self.chosen = False, 0, True
            if self._since_try >= self.probe_every:
                # the first frame on the other count untimed (after a stretch on one count
                # it cost 1.5-1.8x: the shared-machine trial), its old timings dropped
                self._plan = [(self.other, False), (self.other, True), (self.other, True)]
                self._trying = True
                self.cost[self.other].clear()
                self._sum[self.other] = [0.0, 0]
            else:
                self._plan = [(self.current, True)]
                self._since_try += 0 if self._timed_probe else 1
        return self._plan.pop(0)

    def record(self, count: int, seconds: float, substeps: int) -> None:
        """A timed frame on ``count`` threads took ``seconds`` for ``substeps`` substeps."""
        if substeps > 0 and seconds > 0.0 and count in self.cost:
            if self._timed_probe and not self._trying:
                self._since_try += seconds
            total = self._sum[count]
            total[0] += seconds
            total[1] += substeps
            if total[0] < self.min_seconds:
                if self._trying:
                    self._plan.insert(0, (count, True))
                return
            kept = self.cost[count]
            kept.append(total[0] / total[1])
            del kept[:-KEEP]
            self._sum[count] = [0.0, 0]

    def _decide(self) -> None:
        """All threads when their steps were faster than one thread's by more than
        :data:`MARGIN`, else one (a tie leaves the other core to whatever else runs: under
        load a second thread gained nothing, BENCHMARKS.md "A short spin, chosen by timing")."""
        one, many = (statistics.median(self.cost[c]) if self.cost[c] else None
                     for c in self.counts)
        if one is not None and many is not None:
            self.current = self.counts[1] if many < (1.0 - MARGIN) * one else self.counts[0]


def for_physical(start: int, model) -> ThreadChoice | None:
    """The chooser for the physical (numba) ``model`` starting on ``start`` threads, or
    ``None`` where there is no choice to make (see the module docstring)."""
    import numba

    from .distributed.simulator import launched_under_mpi

    most = int(numba.config.NUMBA_NUM_THREADS)
    if most < 2 or model.fem.tet_count < ADAPTIVE_MIN_TETS or launched_under_mpi():
        return None
    return ThreadChoice(start, most)


def for_springs(start: int, model) -> ThreadChoice | None:
    """The chooser for the springs path of ``model`` (numba) starting on ``start`` threads,
    or ``None`` where there is no choice to make (see the module docstring)."""
    import numba

    from .distributed.simulator import launched_under_mpi

    most = int(numba.config.NUMBA_NUM_THREADS)
    if most < 2 or model.spring_count < ADAPTIVE_MIN_SPRINGS or launched_under_mpi():
        return None
    return ThreadChoice(start, most, probe_seconds=SPRINGS_PROBE_SECONDS,
                        min_seconds=0.5 * TRY_PIECE_SECONDS)
