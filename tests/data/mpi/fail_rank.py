"""Test helper, run under ``mpiexec -n 2``: rank 1 fails at its third frame, by an exception
(``raise``) or by being killed (``kill``), or rank 0 is sent SIGINT there (``interrupt``: a
Ctrl-C; ``interrupt-twice``: two; ``interrupt-build``: one while rank 0 builds the body;
``interrupt-saving``: one there and a second while rank 0 saves the frames; ``finish-saving``:
one while rank 0 saves a finished run's frames); the job must end with a clear message, not
hang, and never lose the frames."""
import os
import signal
import sys

from jellysim.distributed import simulator as dsim
from jellysim.distributed.runner import cli_run

mode, scene, out = sys.argv[1:4]
original = dsim.DistributedSimulator.advance
calls = {"n": 0}


def advance(self, steps=1):
    calls["n"] += 1
    if mode == "interrupt" and self.rank == 0 and calls["n"] == 3:
        os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C reaching rank 0 as it steps
    if mode == "interrupt-saving" and self.rank == 0 and calls["n"] == 3:
        os.kill(os.getpid(), signal.SIGINT)
    if mode == "interrupt-twice" and self.rank == 0 and calls["n"] == 3:
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGINT)  # (a second one: stop now)
    if mode in ("raise", "kill") and self.rank == 1 and calls["n"] == 3:
        if mode == "kill":
            os.kill(os.getpid(), signal.SIGKILL)
        raise MemoryError("injected failure")
    return original(self, steps)


dsim.DistributedSimulator.advance = advance
if mode in ("interrupt-saving", "finish-saving"):  # a Ctrl-C while the frames are written
    import time

    from jellysim.io.trajectory import Recorder

    save = Recorder.save

    def save_hit(self, *args, **kw):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.1)  # (Python runs the handler here, inside the save)
        return save(self, *args, **kw)

    Recorder.save = save_hit
if mode == "interrupt-build":  # a Ctrl-C on rank 0 while it builds the body for all ranks
    from jellysim.scene import Scene

    build = Scene.build_model

    def build_model(self, *args, **kw):
        os.kill(os.getpid(), signal.SIGINT)
        return build(self, *args, **kw)

    Scene.build_model = build_model
cli_run(scene, out, quiet=True)
