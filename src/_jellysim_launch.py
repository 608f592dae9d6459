"""The ``jellysim`` command's entry point: Ctrl-C while the program is still loading.

The command's own code says what an interrupted command kept (``cli._Group``), but it runs
only once ``jellysim.cli`` and what it imports have loaded (about 0.3-0.5 s).  A Ctrl-C in
that window used to print a KeyboardInterrupt traceback from inside an import.  This module,
outside the package so that loading it loads nothing else, answers such a Ctrl-C with one
line and exit status 130 (nothing had been read or written yet), then hands Ctrl-C back to
Python before the command starts.
"""
import signal
import sys


def _early_interrupt(signum, frame):
    sys.stderr.write("interrupted while jellysim was starting: nothing was read or written\n")
    sys.stderr.flush()
    raise SystemExit(130)


def main():
    try:
        previous = signal.signal(signal.SIGINT, _early_interrupt)
    except (ValueError, OSError):   # not the main thread, or an embedding forbids handlers
        previous = None
    try:
        from jellysim.cli import main as command
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return command()


if __name__ == "__main__":
    main()
