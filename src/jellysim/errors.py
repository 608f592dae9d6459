"""Exceptions raised by jellysim.

Every error the package raises on purpose derives from :class:`JellysimError`, so callers can
catch "anything jellysim refused" in one clause.  The concrete classes also derive from
:class:`ValueError` because they all report bad input, not bugs.
"""
from __future__ import annotations

__all__ = ["JellysimError", "BuildError", "JelloFileError"]


class JellysimError(Exception):
    """Base class of every exception jellysim raises on purpose."""


class BuildError(JellysimError, ValueError):
    """A builder could not turn the given geometry into a body (e.g. an open or
    self-intersecting surface handed to the constrained tetrahedralizer)."""


class JelloFileError(JellysimError, ValueError):
    """A ``.jello`` / ``.npz`` body file is malformed; the message names the file, and for text
    files the line and column, and says what was expected."""
