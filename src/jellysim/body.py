"""Body: the geometry of a jello before it becomes a simulation :class:`~jellysim.model.Model`.

A :class:`Body` is what every builder produces (random box fields, points sampled inside a
surface mesh, the ``.jello`` file reader) and what :func:`jellysim.model.finalize` consumes.
It is plain data: arrays plus a few optional extras.  Nothing here knows about time stepping.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Body"]


@dataclass
class Body:
    """Points and springs of one jello body (SI units throughout).

    Attributes
    ----------
    points:
        Rest positions [m], shape (n, 3), float64.
    springs:
        Spring end-point indices, shape (k, 2), int64, each row ``i < j``, rows unique and
        sorted lexicographically.
    rest_length:
        Spring rest lengths [m], shape (k,), float64, or ``None`` for "the distance between the
        end points in ``points``".
    stiffness:
        Per-spring stiffness [N/m], shape (k,), float64, or ``None`` for "the scene's ``k``".
    masses:
        Point masses [kg], shape (n,), float64, or ``None`` for "density x volume, split evenly".
    tets:
        Tetrahedra (indices into ``points``), shape (t, 4), int64, or ``None``.
    triangles:
        Surface triangles (indices into ``points``), shape (f, 3), int64, or ``None``.
    volume:
        Enclosed volume [m^3], or ``None`` when unknown.
    meta:
        Free-form provenance (builder name, parameters), JSON-serialisable values only.
    """

    points: np.ndarray
    springs: np.ndarray
    rest_length: np.ndarray | None = None
    stiffness: np.ndarray | None = None
    masses: np.ndarray | None = None
    tets: np.ndarray | None = None
    triangles: np.ndarray | None = None
    volume: float | None = None
    meta: dict = field(default_factory=dict)

    @property
    def point_count(self) -> int:
        return int(self.points.shape[0])

    @property
    def spring_count(self) -> int:
        return int(self.springs.shape[0])
