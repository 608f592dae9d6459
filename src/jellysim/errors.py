"""Exceptions with messages meant for users: each names the file, key or step at fault."""
from __future__ import annotations

__all__ = ["JellysimError", "SceneError", "SimulationError", "MeshError", "BuildError",
           "JelloFileError", "RunInterrupted", "CheckpointError", "NothingToResume",
           "OutputError", "ResourceError", "ParameterError", "StabilityWarning", "SolverWarning",
           "did_you_mean"]


def did_you_mean(word, choices, fmt: str = "'{}'") -> str:
    """`` (did you mean 'x'?)`` for the choice closest to ``word`` (``fmt`` shapes it:
    ``"[{}]"`` for a section, ``"{!r}"``), or ``""`` when none is close."""
    import difflib

    near = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {fmt.format(near[0])}?)" if near else ""


class JellysimError(Exception):
    """Base class of every error jellysim raises on purpose."""


class ParameterError(JellysimError, ValueError):
    """A Python API argument is invalid (a shape, a unit's range, a choice): the message names
    the parameter and what would fix it.  ``except ParameterError`` catches every bad argument,
    :class:`SceneError` included."""


class SceneError(ParameterError):
    """A scene file or scene parameter is invalid; also what :class:`~jellysim.Simulator`, its
    ``advance`` and its handles (``pin``, ``apply_force``, ``select_points``...) raise for a bad
    argument (the scene reader adds the scene file's name to the same messages).  A
    :class:`ParameterError` (notebook trial, session 30: the Simulator's bad arguments raised
    one class, ``material``'s and ``finalize``'s the other)."""


class SimulationError(JellysimError, RuntimeError):
    """A run went unstable (non-finite values or a runaway point)."""

    def __init__(self, message: str, *, step: int, status: int):
        super().__init__(message)
        self.step = step
        self.status = status


class MeshError(JellysimError, ValueError):
    """A surface mesh file cannot be used."""


class BuildError(JellysimError, ValueError):
    """A body cannot be built from the given geometry and options."""


class JelloFileError(JellysimError, ValueError):
    """A ``.jello`` / body file is malformed."""


class RunInterrupted(JellysimError):
    """A run stopped early on request (SIGINT, SIGTERM, ``stop_after``) after saving its frames
    and a checkpoint; ``jellysim run --resume`` continues it."""

    def __init__(self, message: str, *, step: int, signal: int | None, out_dir):
        super().__init__(message)
        self.step = step
        self.signal = signal
        self.out_dir = out_dir


class CheckpointError(JellysimError, ValueError):
    """A checkpoint is missing, damaged or belongs to another scene or version."""


class NothingToResume(CheckpointError):
    """``resume`` on a run that has finished, and no more steps were asked to extend it."""


class OutputError(JellysimError, OSError):
    """An output file or folder cannot be written (missing, read-only, or a file in the way);
    nothing was written."""


class ResourceError(JellysimError, ValueError):
    """A request would need more memory (or work) than allowed; nothing was built."""


class StabilityWarning(UserWarning):
    """The time step exceeds the estimated stable limit."""


class SolverWarning(UserWarning):
    """A linear solve stopped above its tolerance (see
    :data:`jellysim.simulator.CG_ERROR_RESIDUAL`)."""
