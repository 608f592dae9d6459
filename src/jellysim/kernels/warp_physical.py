"""Host side of the physical (FEM) path on Warp: :func:`physical_steps`, the twin of
:func:`jellysim.kernels.fem_numba.physical_steps` (same arguments: numpy arrays and the tuples
documented there; same in-place results on ``x``, ``v``, ``a``, the damping strains ``q`` and
the smallest ``J`` ``min_j``).

Per call: the state, ``q``, ``min_j`` and the handle arrays are copied to the device; the
substeps run as recorded launches (a CUDA graph of :data:`GRAPH_SUBSTEPS` substeps replayed,
then single-substep graphs for the rest, on a GPU; the recorded launches replayed on Warp's CPU
device), with no host round trip; after a failing substep every kernel returns at once (the
device status word), so the state is left as after that substep, as with numba; the state is
copied back once.  The per-tet scratch (corner forces, ``J``) and the per-point force sum stay
on the device (the host's scratch arrays are not written).  Device copies of the Model's and
the FemArrays' arrays are uploaded once and cached per model (keyed on the arrays, freed with
them).
"""
from __future__ import annotations

import weakref

import numpy as np
import warp as wp

from . import STATUS_OK
from .records import OBSTACLE_COLUMNS
from .warp_contact import k_contact, k_step_end
from .warp_fem import Gather, Points, Tets, k_fem_gather, k_fem_integrate, k_tet_forces
from .warp_kernels import k_force_first

__all__ = ["physical_steps", "GRAPH_SUBSTEPS"]

GRAPH_SUBSTEPS = 32
"""Substeps captured in one CUDA graph (a frame of the demo is ~230 substeps)."""


class _DeviceFem:
    """A physical model's arrays on one device in one precision, the per-call buffers, and
    the recorded substep programs."""

    def __init__(self, wb, fem, inv_mass, springs):
        dev, F = wb.device, wb.np_dtype
        tets, dm, vol, mu, lam, alpha, mu_l = fem[:7]
        ptr, slot = fem[11], fem[12]
        spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other = springs[:7]
        t = tets.shape[0]
        n = inv_mass.shape[0]
        k = spring_ij.shape[0]
        if 4 * t >= 2**31 - 1 or k >= 2**31 - 1:
            raise ValueError(f"the warp backend indexes corners and springs with int32; {t} "
                             f"tets / {k} springs is too many")

        def up(a, dtype):
            return wp.array(np.ascontiguousarray(a, dtype=dtype), device=dev)

        def zeros(shape, dtype=F):
            return wp.array(np.zeros(shape, dtype=dtype), device=dev)

        self.n, self.t = n, t
        self.tets = up(tets, np.int32)
        self.dm, self.vol, self.mu = up(dm, F), up(vol, F), up(mu, F)
        self.lam, self.alpha, self.mu_l = up(lam, F), up(alpha, F), up(mu_l, F)
        self.ptr, self.slot = up(ptr, np.int32), up(slot, np.int32)
        self.inv_mass = up(inv_mass, F)
        ij = np.asarray(spring_ij).reshape(k, 2)
        some = (lambda a: a) if k else (lambda a: np.zeros(1))  # noqa: E731 (no empty arrays)
        self.spring_j = up(some(ij[:, 1]), np.int32)
        self.rest, self.stiff = up(some(rest), F), up(some(stiff), F)
        self.first_ptr, self.second_ptr = up(first_ptr, np.int32), up(second_ptr, np.int32)
        self.second_slot = up(some(second_slot), np.int32)
        self.second_other = up(some(second_other), np.int32)
        self.scal = zeros(max(k, 1))
        self.first = zeros((n, 3))
        self.tet_force = zeros((4 * t, 3))
        self.tet_j = zeros(t)
        self.fsum = zeros((n, 3))
        # per-call state and handles
        self.x, self.v, self.a = zeros((n, 3)), zeros((n, 3)), zeros((n, 3))
        self.q, self.min_j, self.slip = zeros((t, 6)), zeros(1), zeros(n)
        self.gscale, self.fext = zeros(n), zeros((n, 3))
        self.pinned = zeros(n, np.int32)
        self.pin_from, self.pin_to = zeros((n, 3)), zeros((n, 3))
        self.drag = zeros(6)
        self.drag_w, self.drag_off = zeros(n), zeros((n, 3))
        self.ctl = zeros(4, np.int32)
        self.counts = zeros(2, np.int32)
        self.programs: dict = {}
        self.last = None  # (WarpBackend.replay_resident: the explicit path's benchmarks only)
        self.views = None
        if not wp.get_device(dev).is_cuda:  # CPU device: numpy views of the device memory
            self.views = {name: getattr(self, name).numpy() for name in _IO}


_IO = ("x", "v", "a", "q", "min_j", "slip", "gscale", "fext", "pinned", "pin_from", "pin_to", "drag",
       "drag_w", "drag_off", "ctl", "counts")


def _device_model(wb, fem, inv_mass, springs) -> _DeviceFem:
    arrays = (*fem[:8], fem[11], fem[12], inv_mass, *springs[:7])
    key = ("fem",) + tuple(id(a) for a in arrays)
    dm = wb._models.get(key)
    if dm is None:
        dm = _DeviceFem(wb, fem, inv_mass, springs)
        wb._models[key] = dm
        owner = weakref.ref(wb)

        def drop(key=key, owner=owner):
            w = owner()
            if w is not None:
                w._models.pop(key, None)

        for a in arrays:  # an array freed -> its model is gone: free the device copies
            weakref.finalize(a, drop)
    return dm


def _program(wb, dm: _DeviceFem, key, p):
    """The recorded launches of one substep (and its CUDA graphs)."""
    prog = dm.programs.get(key)
    if prog is not None:
        return prog
    dev, T = wb.device, wb.wp_dtype
    n, t = dm.n, dm.t
    tt = Tets[T]()
    tt.tets, tt.dm, tt.vol, tt.mu, tt.lam = dm.tets, dm.dm, dm.vol, dm.mu, dm.lam
    tt.alpha, tt.mu_l, tt.q = dm.alpha, dm.mu_l, dm.q
    tt.g, tt.decay = p["g"], p["decay"]
    tt.tet_force, tt.tet_j, tt.min_j = dm.tet_force, dm.tet_j, dm.min_j
    ga = Gather[T]()
    ga.ptr, ga.slot, ga.tet_force, ga.use_springs = dm.ptr, dm.slot, dm.tet_force, int(
        p["use_springs"])
    ga.first, ga.second_ptr, ga.second_other = dm.first, dm.second_ptr, dm.second_other
    ga.scal, ga.fsum = dm.scal, dm.fsum
    pt = Points[T]()
    pt.inv_mass, pt.damping = dm.inv_mass, p["damping"]
    pt.gx, pt.gy, pt.gz = p["gravity"]
    pt.gscale, pt.fext, pt.pinned = dm.gscale, dm.fext, dm.pinned
    pt.pin_from, pt.pin_to, pt.drag = dm.pin_from, dm.pin_to, dm.drag
    pt.drag_w, pt.drag_off = dm.drag_w, dm.drag_off
    pt.dt = p["dt"]
    pt.cx, pt.cy, pt.cz = p["center"]
    pt.bound2 = p["bound2"]
    kind = wp.array(p["obstacle_kind"].astype(np.int32), device=dev)
    odata = wp.array(p["obstacle_data"].astype(wb.np_dtype).reshape(-1, OBSTACLE_COLUMNS),
                     dtype=T, device=dev)
    cmds = []

    def L(kernel, dim, inputs):
        cmds.append(wp.launch(kernel, dim=dim, inputs=inputs, device=dev, record_cmd=True))

    L(k_tet_forces, t, [dm.x, tt, dm.ctl])
    if p["use_springs"]:
        L(k_force_first, n, [dm.x, dm.spring_j, dm.rest, dm.stiff, dm.first_ptr,
                             dm.second_slot, dm.scal, dm.first, dm.ctl])
    L(k_fem_gather, n, [dm.x, ga, dm.ctl])
    L(k_fem_integrate, n, [dm.x, dm.v, dm.a, dm.fsum, pt, dm.counts, dm.ctl])
    if p["obstacle_kind"].shape[0] > 0:
        L(k_contact, n, [dm.x, dm.v, kind, odata, T(p["rest_speed"]), T(p["dt"]), dm.slip,
                         dm.ctl])
    L(k_step_end, 1, [dm.counts, dm.ctl])
    graphs = None
    if wb.is_cuda:
        graphs = []
        for count in (GRAPH_SUBSTEPS, 1):
            with wp.ScopedCapture(device=dev) as cap:
                for _ in range(count):
                    for c in cmds:
                        c.launch()
            graphs.append(cap.graph)
    prog = {"cmds": cmds, "graphs": graphs, "keep": (kind, odata, tt, ga, pt)}
    if len(dm.programs) >= 8:
        dm.programs.pop(next(iter(dm.programs)))
    dm.programs[key] = prog
    return prog


def _replay(prog, nsteps: int) -> None:
    if prog["graphs"] is not None:
        many, one = prog["graphs"]
        for _ in range(nsteps // GRAPH_SUBSTEPS):
            wp.capture_launch(many)
        for _ in range(nsteps % GRAPH_SUBSTEPS):
            wp.capture_launch(one)
    else:
        cmds = prog["cmds"]
        for _ in range(nsteps):
            for c in cmds:
                c.launch()


def physical_steps(wb, nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays,
                   scratch):
    """``nsteps`` symplectic Euler substeps of ``dt`` [s] on ``wb``'s device
    (:class:`~jellysim.kernels.warp_backend.WarpBackend`); returns ``(steps done, status)``."""
    inv_mass, damping, gravity, springs = model_arrays
    g, decay, q = fem[8], fem[9], fem[10]
    gscale, fext, pinned, pin_from, pin_to, drag, drag_w, drag_off = handles
    kinds, data, rest_speed, center, bound2, slip = contact_arrays
    min_j = scratch[4]
    dm = _device_model(wb, fem, inv_mass, springs)
    ok = np.asarray(kinds)
    od = np.asarray(data, dtype=np.float64)
    p = dict(dt=float(dt), g=float(g), decay=float(decay), damping=float(damping),
             gravity=tuple(float(c) for c in gravity), use_springs=bool(springs[7]),
             rest_speed=float(rest_speed), center=tuple(float(c) for c in center),
             bound2=float(bound2))
    key = (tuple(p.items()), ok.tobytes(), od.tobytes())
    p["obstacle_kind"], p["obstacle_data"] = ok, od
    prog = _program(wb, dm, key, p)
    host = {"x": x, "v": v, "a": a, "q": q, "min_j": min_j, "slip": slip, "gscale": gscale, "fext": fext,
            "pinned": pinned, "pin_from": pin_from, "pin_to": pin_to, "drag": drag,
            "drag_w": drag_w, "drag_off": drag_off}
    ctl0 = np.array([0, 0, 0, int(nsteps)], dtype=np.int32)
    views = dm.views
    if views is not None:  # CPU device: plain numpy copies into the device memory
        for name, arr in host.items():
            views[name][...] = arr
        views["ctl"][...] = ctl0
        views["counts"][...] = 0
    else:
        F = wb.np_dtype
        for name, arr in host.items():
            dst = getattr(dm, name)
            dst.assign(np.ascontiguousarray(arr, dtype=np.int32 if name == "pinned" else F))
        dm.ctl.assign(ctl0)
        dm.counts.zero_()
    _replay(prog, int(nsteps))
    for name in ("x", "v", "a", "q", "min_j", "slip"):
        host[name][...] = views[name] if views is not None else getattr(dm, name).numpy()
    ctl = views["ctl"].copy() if views is not None else dm.ctl.numpy()
    status = int(ctl[0])
    done = int(ctl[1]) if status != STATUS_OK else int(nsteps)
    return done, status
