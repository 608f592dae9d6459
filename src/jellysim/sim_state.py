"""The simulator's private arrays as a checkpoint holds them (:class:`InternalState`, a mixin
of :class:`~jellysim.simulator.Simulator`): what is state, what is scratch."""
from __future__ import annotations

import numpy as np

from .errors import SceneError

__all__ = ["InternalState"]


class InternalState:
    """:meth:`internal_state` and :meth:`restore_internal_state` (checkpoints, resuming)."""

    _COUNTERS = ("cg_iterations", "cg_worst_residual", "cg_unconverged", "substeps")
    """Scalars carried between advance calls (substeps: the physical path may double them)."""
    _SCRATCH = frozenset({"_scratch", "_scalar", "_provot_scalar", "_dx", "_count", "_max_corr",
                          "_x_pre", "_frame", "_spring_vec", "_cobs", "_tet_force", "_fsum",
                          "_state32", "_cg.1", "_cg.2", "_cg.3", "_cg.4", "_cg.5", "_cg.6",
                          "_cg.7"})
    """Arrays every step writes before it reads them: not state, so not checkpointed (per
    spring and per tet they outweigh the state 10-50x; the state in ``_scratch`` is kept
    under its own names: ``_cg.0``, ``_hist``...).  tests/test_reliability.py overwrites each
    with NaN between advance calls and checks that nothing changes."""

    _SETTINGS = frozenset({"_obstacle_kind", "_obstacle_data"})
    """Arrays packed once from the simulator's settings (the ground and obstacles), never
    written by a step: not state.  Restoring them carried one simulator's ground into
    another made with a different one (API trial, session 28); older files that hold them
    are read, these ignored."""

    def internal_state(self) -> dict[str, np.ndarray]:
        """Every private array the simulator keeps between :meth:`advance` calls, copied.

        Collected generically: each ``numpy`` array attribute whose name starts with ``_``
        (``_hist``, ``_fresh``, ``_contact_state``, ``_cg``'s warm start...), each
        list/tuple of arrays as ``name.i`` (``_cg.0``), ``_last`` when set, and the CG counters.
        A new private array is therefore checkpointed without touching this method, unless
        named in :attr:`_SCRATCH`.  With :attr:`state` (x, v, a, t, step) it is everything a
        bitwise resume needs, except the handles (pins and their paths, point forces, gravity
        scales, the drag spring): a simulator restored from it keeps the handles it has, so
        give it the same ones (a scene's ``[[handle]]`` tables are re-applied on ``--resume``;
        a pin's path re-given after its start time is refused: pin with the path's remaining
        keyframes).  :meth:`reset` starts over instead."""
        out: dict[str, np.ndarray] = {}
        for name, value in vars(self).items():
            if not name.startswith("_") or name in self._SCRATCH or name in self._SETTINGS:
                continue
            if isinstance(value, np.ndarray):
                if value.flags.writeable:  # read-only arrays are the Model's, not state
                    out[name] = value.copy()
            elif isinstance(value, (list, tuple)) and value and all(
                    isinstance(v, np.ndarray) and v.flags.writeable for v in value):
                for i, v in enumerate(value):
                    if f"{name}.{i}" not in self._SCRATCH:
                        out[f"{name}.{i}"] = v.copy()
        for name in self._COUNTERS:
            out[name] = np.array(getattr(self, name))
        return out

    def restore_internal_state(self, d) -> None:
        """Inverse of :meth:`internal_state`: copy the arrays back in place.  Raises
        :class:`SceneError` when ``d`` does not fit this simulator (another body or
        integrator)."""
        own = self.internal_state()
        d = {k: val for k, val in d.items() if k not in self._SETTINGS}  # (older files)
        # tolerated when absent (files of earlier versions): arrays added since, all of them
        # rebuilt every step (_squeezed: a frame count; _slip: every point resumes stuck)
        missing = sorted(set(own) - set(d) - {"_last.0", "_last.1", "_squeezed", "_relax",
                                              "_slip"})
        extra = sorted(k for k in set(d) - set(own) - {"_last.0", "_last.1"}
                       if k not in self._SCRATCH and k.partition(".")[0] not in self._SCRATCH)
        # (scratch arrays in files of earlier versions are ignored)
        if missing or extra:
            raise SceneError(f"saved simulator state does not fit this simulator (missing "
                             f"{missing}, unexpected {extra}): same scene and integrator?")
        for key in own:
            if key in self._COUNTERS:
                continue
            if key.startswith("_last.") or key not in d:  # (_squeezed: not in older files)
                continue
            if own[key].shape != np.shape(d[key]) or own[key].dtype != np.asarray(d[key]).dtype:
                raise SceneError(f"saved simulator state '{key}' has shape "
                                 f"{np.shape(d[key])}, expected {own[key].shape}")
        for key in own:
            if key in self._COUNTERS or key.startswith("_last.") or key not in d:
                continue
            name, _, i = key.partition(".")
            target = getattr(self, name)[int(i)] if i else getattr(self, name)
            np.copyto(target, d[key])
        if "_last" in vars(self):
            self._last = ((np.array(d["_last.0"]), np.array(d["_last.1"]))
                          if "_last.0" in d else None)
        self.cg_iterations = int(d["cg_iterations"])
        self.cg_worst_residual = float(d["cg_worst_residual"])
        self.cg_unconverged = int(d["cg_unconverged"])
        if "_min_j" in vars(self):  # (an inversion restored with it happened before the
            self._restored_min_j = (float(self._min_j[0]), float(self.state.t))  # resume)
        if "substeps" in d:
            self._substep_count = int(d["substeps"])  # (the simulator's own, not the user's)
            self.dt_step = self.dt / self.substeps
