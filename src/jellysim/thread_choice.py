"""The physical path's thread count, chosen by timing its frames (``threads = None``).

Whether a second thread pays on the physical path depends on the machine as much as on the
body: a substep's tet pass must outweigh the cost of waking the other thread at each of its
parallel regions.  Measured (real-time factor 2 threads / 1; BENCHMARKS.md "Threads and body
size" and "Threads chosen by timing"): on the AVX-512 VM of 2026-11-30 (session 7) 0.86-1.01 at
20,250 tets and 1.18 from 24,576; on the AVX2 VM of 2026-12-07, whose tet pass costs twice as
much, 0.69 at 4,374 tets, 1.0-1.42 at 7,986, 1.08-1.26 at 13,182 and 1.26-1.50 at 29,478 (its
frame times scatter by 10-30 %).  No fixed size threshold is right on both, so when the
user gives no thread count the Simulator starts with the size rule
(:data:`jellysim.simulator.PHYSICAL_PARALLEL_MIN_TETS`), times its first frames on both counts
(:class:`ThreadChoice`), keeps whichever ran a substep faster by more than :data:`MARGIN`, and
tries the other again every :data:`PROBE_EVERY` frames (a machine's load changes).  Results do not
depend on the thread count (every per-point sum has a fixed order, tested), so switching
changes only the speed.

Only for the numba backend, bodies of at least :data:`ADAPTIVE_MIN_TETS` tets, more than one
numba thread, and not under ``mpiexec`` (ranks are given their threads).
"""
from __future__ import annotations

import statistics

__all__ = ["ThreadChoice", "for_physical", "ADAPTIVE_MIN_TETS", "PROBE_EVERY", "MARGIN"]

ADAPTIVE_MIN_TETS = 6_000
"""Smaller bodies keep one thread: below this a second thread did not pay on either VM
(0.86x at 4,374 tets on the AVX2 one), and a try on it costs frames."""

PROBE_EVERY = 120
"""Frames between two tries of the other thread count (2 s of simulated time at 60 frames/s;
a try costs at most its two frames' difference)."""

MARGIN = 0.10
"""The other count is taken when its substeps were faster by more than this fraction (frame
times on a shared 2-core VM scatter by 10-30 %: a smaller margin switched on noise)."""

KEEP = 5
"""Timings kept per thread count (their median decides)."""


class ThreadChoice:
    """Which thread count each frame runs on, from the timings of earlier frames.

    Call :meth:`next_frame` before a frame: ``(threads, timed)``; after a timed frame,
    :meth:`record` its wall time [s] and the substeps it ran.  The first frame on each count
    is not timed (it may load or compile that count's kernels).  The first try interleaves
    the two counts (four timed frames each, so that a change of the machine's load hits
    both alike); later tries run two frames on the other count between frames on the
    current one.  A try ends with the decision: the median of each count's last
    :data:`KEEP` timings."""

    def __init__(self, start: int, most: int):
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

    @property
    def other(self) -> int:
        return self.counts[1] if self.current == self.counts[0] else self.counts[0]

    def next_frame(self) -> tuple[int, bool]:
        """(thread count, whether to time the frame) of the next frame."""
        if not self._plan:
            if self._trying:
                self._decide()
                self._trying, self._since_try, self.chosen = False, 0, True
            if self._since_try >= PROBE_EVERY:
                self._plan, self._trying = [(self.other, True), (self.other, True)], True
            else:
                self._plan = [(self.current, True)]
                self._since_try += 1
        return self._plan.pop(0)

    def record(self, count: int, seconds: float, substeps: int) -> None:
        """A timed frame on ``count`` threads took ``seconds`` for ``substeps`` substeps."""
        if substeps > 0 and seconds > 0.0 and count in self.cost:
            kept = self.cost[count]
            kept.append(seconds / substeps)
            del kept[:-KEEP]

    def _decide(self) -> None:
        mine, theirs = self.cost[self.current], self.cost[self.other]
        if mine and theirs and (statistics.median(theirs)
                                < (1.0 - MARGIN) * statistics.median(mine)):
            self.current = self.other


def for_physical(start: int, model) -> ThreadChoice | None:
    """The chooser for the physical (numba) ``model`` starting on ``start`` threads, or
    ``None`` where there is no choice to make (see the module docstring)."""
    import numba

    from .distributed.simulator import launched_under_mpi

    most = int(numba.config.NUMBA_NUM_THREADS)
    if most < 2 or model.fem.tet_count < ADAPTIVE_MIN_TETS or launched_under_mpi():
        return None
    return ThreadChoice(start, most)
