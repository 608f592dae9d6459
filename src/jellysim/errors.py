"""Exceptions raised by jellysim."""
from __future__ import annotations

__all__ = ["JellysimError", "MeshError"]


class JellysimError(Exception):
    """Base class of every error jellysim raises on purpose."""


class MeshError(JellysimError, ValueError):
    """A surface mesh could not be loaded or is unusable.

    The message names the file and the problem.
    """
