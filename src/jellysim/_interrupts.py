"""Ctrl-C held off where acting on it at once would do harm.

:class:`Deferred` (``Simulator.advance``): a signal that lands while the simulator steps is
noted and acted on between whole steps, so an interrupted ``advance`` leaves ``x``, ``v``,
``t`` and ``step`` of the same step (notebook trial, session 30: a Ctrl-C that landed between
a physical frame's kernel and its bookkeeping left positions 9 mm ahead of ``t``; and a long
``advance`` of the springs path, one compiled call, could not be stopped at all).

:func:`held`: while a third-party package that swallows Ctrl-C is imported.

trimesh imports its optional parts inside ``try: ... except BaseException`` and keeps the
exception in an ``ExceptionWrapper`` in place of the module: a Ctrl-C (SIGINT) that lands
during ``import trimesh`` is swallowed, the run goes on with part of trimesh replaced, and
either does not stop or fails later deep inside it (``TypeError: unsupported operand type(s)
for |: 'ExceptionWrapper' and 'NoneType'``).  :func:`held` replaces the SIGINT and SIGTERM
handlers for the duration (a second or so) by one that only notes the signal, and hands a
noted signal to the handler that was there as soon as the block ends, so the command stops
right after, cleanly.  (Handlers, not the thread's signal mask: the signal may be delivered
to any thread, and Python runs its handlers in the main thread whichever received it.)
"""
from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager

try:  # the C functions under `signal`'s enum wrappers: 0.3-0.5 us a call instead of 4-6
    import _signal as _raw
except ImportError:  # (not CPython)
    _raw = signal

__all__ = ["Deferred", "held", "import_trimesh"]

_SIGNALS = tuple(s for s in (getattr(signal, "SIGINT", None), getattr(signal, "SIGTERM", None))
                 if s is not None)


@contextmanager
def held(act: bool = True):
    """Note SIGINT and SIGTERM instead of acting on them until the block ends, then act on
    the first one noted (``act=False``: drop them, for a block whose caller stops next
    anyway, such as saving an interrupted run's frames) (main thread only; elsewhere a
    no-op)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    old = {}
    try:
        for s in _SIGNALS:
            old[s] = signal.signal(s, lambda signum, frame: noted.append(signum))
    except (ValueError, OSError):  # (an embedding that forbids handlers)
        for s, h in old.items():
            signal.signal(s, h)
        yield
        return
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if noted and act:
            s = noted[0]
            h = old[s]
            if callable(h):
                h(s, None)   # Python's default_int_handler raises KeyboardInterrupt
            elif h == signal.SIG_DFL:
                os.kill(os.getpid(), s)
            # SIG_IGN: ignored, as it would have been


class Deferred:
    """Within the block, SIGINT and SIGTERM (those whose handler is Python code: Ctrl-C's
    ``KeyboardInterrupt``, a run's stop handler) are only noted; :meth:`deliver` (called by
    the block at its safe points) and the block's end hand each noted signal to the handler
    that was there, which may raise.  Main thread only (elsewhere a no-op).  Cheap: about
    2 us per block (15 us through ``signal``'s enum wrappers, a tenth of ``advance(1)``'s
    Python on the paper scene)."""

    __slots__ = ("noted", "old")

    def __init__(self):
        self.noted: list[int] = []
        self.old: dict = {}

    def _note(self, signum, frame) -> None:
        self.noted.append(signum)

    def __enter__(self) -> "Deferred":
        if threading.current_thread() is threading.main_thread():
            for s in _SIGNALS:
                h = _raw.getsignal(s)
                if not callable(h):  # (SIG_DFL, SIG_IGN: no Python code runs for it)
                    continue
                try:
                    _raw.signal(s, self._note)
                except (ValueError, OSError):  # (an embedding that forbids handlers)
                    continue
                self.old[s] = h
        return self

    def deliver(self) -> None:
        """Act on the signals noted so far (each by its own handler, in order)."""
        while self.noted:
            s = self.noted.pop(0)
            self.old[s](s, None)

    def __exit__(self, *exc) -> None:
        old, self.old = self.old, {}
        for s, h in old.items():
            _raw.signal(s, h)
        noted, self.noted = self.noted, []
        for s in noted:
            old[s](s, None)


def import_trimesh():
    """``import trimesh`` with Ctrl-C held (see the module); raises ImportError if absent."""
    with held():
        import trimesh  # (its load, sample and remesh need nothing imported later)
    return trimesh
