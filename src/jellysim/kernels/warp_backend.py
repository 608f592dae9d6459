"""Warp backend: the explicit step and the physical path on an NVIDIA GPU (CUDA) or on Warp's
CPU device.

Same physics, same arithmetic order and the same ``run_steps`` signature as
:mod:`.numba_backend` (and ``physical_steps`` as :mod:`.fem_numba`), so ``get_backend("warp")``
drops into the Simulator; Warp is imported
only when this module is (``pip install 'jellysim[gpu]'``).  What it runs:

* the integrators ``paper`` (the report's order: ``x += v dt; v += a dt; a = F(x, v) / m``, eq. 1
  spring forces, ``-delta v`` damping, gravity) and ``symplectic``;
* Provot strain limiting: Jacobi (averaged) over the springs or over all pairs, Gauss-Seidel
  (one serial thread, as the numba backend's), with the pass-count tolerance;
* the report's ground (``mu``/``nu``) and the physical contact of planes, spheres and boxes
  (restitution, static/kinetic Coulomb friction: the numba backend's ``contact``);
* the non-finite / runaway check, which stops the batch at the failing step.

**Determinism.**  No float atomics: each spring's scalar is computed once, by the thread of its
first point, and written into its slot of the second point's list (``spring_second_slot``: one
writer per slot); a second pass gathers each point's slots in CSR order.  The only atomics are
integer counters and ``atomic_max`` of non-negative norms (exact, order-free), so a run is
bitwise repeatable on every device, and in float64 on the CPU device bitwise equal to the numba
backend (the tests allow 1e-12 m).

**No host round trip per step.**  Per call the state is uploaded once; one step is a fixed list
of launches recorded once (captured as a CUDA graph on a GPU, replayed ``n`` times; on the CPU
device the recorded launches are replayed); a device status word makes every kernel of the
steps after a failure return at once, so the state is left as after the failing step, as with
numba.  The state (and ``max_corr``) is copied back when the call returns.  Device copies of a
Model's arrays are cached per Model (uploaded once).

The physical (FEM) path (Stable Neo-Hookean tets, the damping branch, handles, contact) is
:meth:`WarpBackend.physical_steps` (:mod:`.warp_physical`, kernels in :mod:`.warp_fem`).

The kernels are four Warp modules (:mod:`.warp_kernels`: integrator and spring forces;
:mod:`.warp_provot`; :mod:`.warp_contact`: contact, ground, checks; :mod:`.warp_fem`), each
with float32 and float64 overloads (:mod:`.warp_common`): compiled once (seconds of CPU cold,
then Warp's kernel cache: ``~/.cache/warp`` or ``WARP_CACHE_PATH``).
"""
from __future__ import annotations

import weakref

import numpy as np
import warp as wp

from ..errors import SceneError
from . import STATUS_OK
from .records import OBSTACLE_COLUMNS
from . import warp_fem  # noqa: F401 (its module is loaded with the others, compiled once)
from .warp_contact import Guard, k_add_velocity, k_contact, k_finish, k_step_end
from .warp_kernels import (Accel, k_drift, k_force_first, k_force_second, k_fused_first,
                           k_fused_second, k_triad)
from .warp_provot import (ProvotBuf, k_apply_dx, k_mass_moves, k_provot_all, k_provot_check,
                          k_provot_first, k_provot_gs, k_provot_second, k_remove_shift,
                          k_shift_total)

__all__ = ["WarpBackend", "run_steps", "PRECISIONS", "resolve_device", "device_info",
           "bytes_per_spring_update", "k_triad"]

PRECISIONS = ("float64", "float32")
MOMENTUM_BLOCKS = {"cuda": 256, "cpu": 1}
"""Fixed blocks of the Jacobi Provot momentum sum per device kind (deterministic partial
sums; one on the CPU device is numba's serial order, bitwise)."""
_KERNEL_MODULES = ("jellysim.kernels.warp_kernels", "jellysim.kernels.warp_provot",
                   "jellysim.kernels.warp_contact", "jellysim.kernels.warp_fem")


# -- host side -----------------------------------------------------------------------------------
def resolve_device(device: str | None = None) -> str:
    """``"cuda"`` (the default GPU) when one is present, else ``"cpu"``; a named device
    (``"cpu"``, ``"cuda"``, ``"cuda:1"``) is checked to exist."""

    wp.init()
    if device in (None, "", "auto"):
        return "cuda:0" if wp.is_cuda_available() else "cpu"
    try:
        return str(wp.get_device(device))
    except (RuntimeError, ValueError) as exc:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise SceneError(f"warp device '{device}' is not available ({exc}); devices here: "
                         f"{names}") from None


def device_info(device: str) -> dict:
    """Name, memory and (CUDA) peak memory bandwidth [bytes/s] of a Warp device."""
    d = wp.get_device(device)
    info = {"device": str(d), "name": d.name, "is_cuda": bool(d.is_cuda)}
    if d.is_cuda:
        info["memory_bytes"] = int(d.total_memory)
        info["sm_count"] = int(getattr(d, "sm_count", 0))
        info["arch"] = int(getattr(d, "arch", 0))
        peak = _cuda_peak_bandwidth(d.ordinal)
        if peak:
            info["peak_bandwidth_Bps"] = peak
    return info


def _cuda_peak_bandwidth(ordinal: int) -> float | None:
    """2 x memory clock x bus width [bytes/s]: the CUDA driver's device attributes (memory
    clock rate 36, bus width 37); the clock from ``nvidia-smi`` where the driver no longer
    reports it."""
    import ctypes
    import subprocess

    try:
        cu = ctypes.CDLL("libcuda.so.1")
        dev = ctypes.c_int()
        if cu.cuInit(0) or cu.cuDeviceGet(ctypes.byref(dev), ordinal):
            return None
        clock = ctypes.c_int()  # kHz
        width = ctypes.c_int()  # bits
        if cu.cuDeviceGetAttribute(ctypes.byref(width), 37, dev) or width.value <= 0:
            return None
        khz = clock.value if not cu.cuDeviceGetAttribute(ctypes.byref(clock), 36, dev) else 0
        if khz <= 0:
            out = subprocess.run(["nvidia-smi", f"--id={ordinal}",
                                  "--query-gpu=clocks.max.memory",
                                  "--format=csv,noheader,nounits"], capture_output=True,
                                 text=True, timeout=20)
            khz = 1000.0 * float(out.stdout.strip().splitlines()[0])
        return 2.0 * khz * 1e3 * width.value / 8.0
    except (OSError, ValueError, IndexError, subprocess.SubprocessError):
        return None


def bytes_per_spring_update(springs: int, points: int, precision: str = "float32") -> dict:
    """The least memory traffic of one paper step with one Provot pass over the springs (the
    fused force + Provot sweep), per spring: streamed spring arrays plus the per-point arrays
    shared out over the springs (every array read or written once per kernel; neighbour
    positions assumed cached)."""
    t = 4 if precision == "float32" else 8
    # pass 1: spring_j 4, rest t, stiff t, second_slot 4, writes scal t, pscal t
    # pass 2: second_other 4, reads scal t, pscal t
    per_spring = 12 + 6 * t
    # drift: r x v a, w x v x_pre (18t); fused 1: r x, ptr, w f dx cnt (9t + 12);
    # fused 2: r x a dx v inv_mass ptr cnt, w a dx max_corr (22t + 12);
    # finish: r x dx v x_pre a, w x v a (24t)
    per_point = 73 * t + 24
    return {"per_spring": per_spring, "per_point": per_point,
            "per_spring_update": per_spring + per_point * points / max(springs, 1)}


_MODEL_ARRAYS = ("x0", "inv_mass", "spring_ij", "rest", "stiff", "first_ptr", "second_ptr",
                 "second_slot", "second_other")


class _DeviceModel:
    """A Model's arrays and the scratch on one device, in one precision; recorded steps."""

    def __init__(self, wb: WarpBackend, x0, inv_mass, mass, spring_ij, rest, stiff, first_ptr,
                 second_ptr, second_slot, second_other):
        dev, T, F = wb.device, wb.wp_dtype, wb.np_dtype
        n = x0.shape[0]
        k = spring_ij.shape[0]
        if k >= 2**31 - 1:
            raise ValueError(f"the warp backend indexes springs with int32; {k} springs is "
                             "too many")

        def up(a, dtype):
            return wp.array(np.ascontiguousarray(a, dtype=dtype), device=dev)

        self.n, self.k = n, k
        self.x0 = up(x0, F)
        self.inv_mass = up(inv_mass, F)
        self.mass = up(mass, F)
        # the Jacobi momentum sum's fixed blocks (never float atomics)
        blocks = MOMENTUM_BLOCKS["cuda" if wp.get_device(dev).is_cuda else "cpu"]
        self.mom_part = wp.zeros((blocks, 4), dtype=wp.float64, device=dev)
        self.shift = wp.zeros(3, dtype=wp.float64, device=dev)
        ij = np.asarray(spring_ij).reshape(k, 2)
        self.spring_i = up(ij[:, 0], np.int32)
        self.spring_j = up(ij[:, 1], np.int32)
        self.rest = up(rest, F)
        self.stiff = up(stiff, F)
        self.first_ptr = up(first_ptr, np.int32)
        self.second_ptr = up(second_ptr, np.int32)
        self.second_slot = up(second_slot, np.int32)
        self.second_other = up(second_other, np.int32)
        z2 = lambda: wp.zeros((n, 3), dtype=T, device=dev)  # noqa: E731
        self.x, self.v, self.a, self.dx, self.x_pre = z2(), z2(), z2(), z2(), z2()
        self.scal = wp.zeros(max(k, 1), dtype=T, device=dev)
        self.pscal = wp.zeros(max(k, 1), dtype=T, device=dev)
        self.cnt = wp.zeros(n, dtype=wp.int32, device=dev)
        self.max_corr = wp.zeros(n, dtype=T, device=dev)
        self.slip = wp.zeros(n, dtype=T, device=dev)
        self.largest = wp.zeros(1, dtype=T, device=dev)
        self.ctl = wp.zeros(4, dtype=wp.int32, device=dev)
        self.counts = wp.zeros(2, dtype=wp.int32, device=dev)
        self.programs: dict = {}
        self.last = None
        # CPU device: numpy views of the device arrays (copies in and out without Warp calls)
        self.views = None
        if not wp.get_device(dev).is_cuda:
            self.views = {name: getattr(self, name).numpy() for name in
                          ("x", "v", "a", "max_corr", "slip", "ctl", "counts", "largest")}


class WarpBackend:
    """The Warp kernels on one device in one precision.  ``run_steps`` has the numba backend's
    signature (numpy arrays in and out); device copies are cached per Model.

    device: ``None``/``"auto"`` (a GPU when present, else Warp's CPU device), ``"cpu"``,
        ``"cuda"``, ``"cuda:N"``.
    precision: ``"float64"`` (default; bitwise the numba arithmetic on the CPU device) or
        ``"float32"`` (the state is rounded to float32 on upload and widened on the way back).
    """

    name = "warp"
    _instances: dict = {}

    def __init__(self, device: str | None = None, precision: str = "float64"):

        if precision not in PRECISIONS:
            raise SceneError(f"warp precision must be one of {', '.join(PRECISIONS)}, got "
                             f"'{precision}'")
        self.device = resolve_device(device)
        self.precision = precision
        self.wp_dtype = wp.float64 if precision == "float64" else wp.float32
        self.np_dtype = np.float64 if precision == "float64" else np.float32
        self._models: dict = {}
        for module in _KERNEL_MODULES:
            wp.load_module(module=module, device=self.device)

    @classmethod
    def get(cls, device: str | None = None, precision: str = "float64") -> WarpBackend:
        """A shared instance per (device, precision)."""
        key = (resolve_device(device), precision)
        inst = cls._instances.get(key)
        if inst is None:
            inst = cls._instances[key] = cls(key[0], precision)
        return inst

    @property
    def is_cuda(self) -> bool:
        return wp.get_device(self.device).is_cuda

    # -- model cache ---------------------------------------------------------------------------
    def _model(self, arrays) -> _DeviceModel:
        key = tuple(id(a) for a in arrays)
        dm = self._models.get(key)
        if dm is None:
            dm = _DeviceModel(self, *arrays)
            self._models[key] = dm
            owner = weakref.ref(self)

            def drop(key=key, owner=owner):
                wb = owner()
                if wb is not None:
                    wb._models.pop(key, None)

            for a in arrays:  # an array freed -> its Model is gone: free the device copies
                weakref.finalize(a, drop)
        return dm

    # -- one step as recorded launches ---------------------------------------------------------
    def _program(self, dm: _DeviceModel, key, p):
        prog = dm.programs.get(key)
        if prog is not None:
            return prog
        dev, T = self.device, self.wp_dtype
        n = dm.n
        cmds = []

        def L(kernel, dim, inputs):
            cmds.append(wp.launch(kernel, dim=dim, inputs=inputs, device=dev, record_cmd=True))

        dt = T(p["dt"])
        loops = p["loops"]
        all_pairs, gs = p["all_pairs"], p["gauss_seidel"]
        obstacles = p["obstacle_kind"].shape[0] > 0
        save = int(loops > 0 and p["velocity_update"])
        paper = p["integrator"] == 0
        fuse = paper and loops > 0 and not all_pairs and not gs
        tau, tol = T(p["tau"]), T(p["tolerance"])
        g = p["gravity"]
        acc = Accel[T]()
        acc.inv_mass, acc.damping = dm.inv_mass, p["damping"]
        acc.gx, acc.gy, acc.gz = g
        pb = ProvotBuf[T]()
        pb.dx, pb.cnt, pb.max_corr, pb.largest = dm.dx, dm.cnt, dm.max_corr, dm.largest
        kind = wp.array(p["obstacle_kind"].astype(np.int32), device=dev)
        odata = wp.array(p["obstacle_data"].astype(self.np_dtype).reshape(
            -1, OBSTACLE_COLUMNS), dtype=T, device=dev)
        ctl = dm.ctl

        def forces():
            L(k_force_first, n, [dm.x, dm.spring_j, dm.rest, dm.stiff, dm.first_ptr,
                                 dm.second_slot, dm.scal, dm.a, ctl])
            L(k_force_second, n, [dm.x, dm.v, acc, dm.second_ptr, dm.second_other, dm.scal,
                                  dm.a, ctl])

        def momentum(gate):  # dx -= sum m dx / sum m (provot_numpy.momentum_shift)
            L(k_mass_moves, dm.mom_part.shape[0], [dm.mass, dm.dx, dm.mom_part, gate, ctl])
            L(k_shift_total, 1, [dm.mom_part, dm.shift, gate, ctl])
            L(k_remove_shift, n, [dm.dx, dm.shift, gate, ctl])

        def provot_pass(reduce):
            if all_pairs:
                L(k_provot_all, n, [dm.x, dm.x0, tau, dm.dx, dm.max_corr, reduce, dm.largest,
                                    ctl])
            else:
                L(k_provot_first, n, [dm.x, dm.spring_j, dm.rest, dm.first_ptr,
                                      dm.second_slot, tau, dm.pscal, dm.dx, dm.cnt, ctl])
                L(k_provot_second, n, [dm.x, dm.second_ptr, dm.second_other, dm.pscal, dm.dx,
                                       dm.cnt, dm.max_corr, reduce, dm.largest, ctl])
            momentum(1)
            L(k_apply_dx, n, [dm.x, dm.dx, 1, ctl])
            if reduce:
                L(k_provot_check, 1, [dm.largest, tol, ctl])

        pending = 0
        if paper:
            L(k_drift, n, [dm.x, dm.v, dm.a, dt, 1, save, dm.x_pre, ctl])
            if fuse:
                last = loops == 1 and not obstacles
                reduce = int(loops > 1)
                L(k_fused_first, n, [dm.x, dm.spring_j, dm.rest, dm.stiff, dm.first_ptr,
                                     dm.second_slot, tau, dm.scal, dm.pscal, dm.a, pb, ctl])
                L(k_fused_second, n, [dm.x, dm.v, acc, dm.second_ptr, dm.second_other,
                                      dm.scal, dm.pscal, dm.a, pb, reduce, ctl])
                momentum(0)
                if not last:
                    L(k_apply_dx, n, [dm.x, dm.dx, 0, ctl])
                pending = int(last)
                if reduce:
                    L(k_provot_check, 1, [dm.largest, tol, ctl])
                    for i in range(loops - 1):
                        provot_pass(int(i < loops - 2))
            else:
                forces()
        else:
            forces()
            L(k_drift, n, [dm.x, dm.v, dm.a, dt, 0, save, dm.x_pre, ctl])
        if loops > 0 and not fuse:
            if gs:
                L(k_provot_gs, 1, [dm.x, dm.x0, dm.spring_i, dm.spring_j, dm.rest, tau, loops,
                                   tol, int(all_pairs), ctl])
            else:
                for i in range(loops):
                    provot_pass(int(i < loops - 1))
        gd = Guard[T]()
        gd.ground, gd.height, gd.mu, gd.nu = int(p["ground"]), p["height"], p["mu"], p["nu"]
        gd.cx, gd.cy, gd.cz = p["center"]
        gd.bound2 = p["bound2"]
        finish = [dt, gd, dm.counts, ctl]
        if obstacles:
            if save:
                L(k_add_velocity, n, [dm.v, dm.x, dm.x_pre, dt, ctl])
            L(k_contact, n, [dm.x, dm.v, kind, odata, T(p["rest_speed"]), dt, dm.slip, ctl])
            L(k_finish, n, [dm.x, dm.v, dm.a, dm.dx, 0, dm.x_pre, 0, *finish])
        else:
            L(k_finish, n, [dm.x, dm.v, dm.a, dm.dx, pending, dm.x_pre, save, *finish])
        L(k_step_end, 1, [dm.counts, ctl])

        graph = None
        if self.is_cuda:
            with wp.ScopedCapture(device=dev) as cap:
                for c in cmds:
                    c.launch()
            graph = cap.graph
        prog = {"cmds": cmds, "graph": graph, "keep": (kind, odata, acc, pb, gd)}
        if len(dm.programs) >= 8:
            dm.programs.pop(next(iter(dm.programs)))
        dm.programs[key] = prog
        return prog

    def _replay(self, prog, nsteps: int) -> None:
        if prog["graph"] is not None:
            for _ in range(nsteps):
                wp.capture_launch(prog["graph"])
        else:
            cmds = prog["cmds"]
            for _ in range(nsteps):
                for c in cmds:
                    c.launch()

    def run_steps(self, nsteps, dt, integrator, x, v, a, springs, points, provot, ground,
                  obstacles, scratch):
        """The backend interface's explicit driver (:mod:`jellysim.kernels.records`) on the
        device: the arguments and in-place results on x, v, a (and ``scratch.max_corr``,
        ``obstacles.slip``: the contact's slip-weakening state, in and out) of
        :func:`jellysim.kernels.numba_backend.run_steps`; the other scratch arrays stay on
        the device.  Returns ``(steps_done, status)``."""
        sp, pt, pv, g, ob = springs, points, provot, ground, obstacles
        max_corr, slip = scratch.max_corr, ob.slip
        dm = self._model((pt.x0, pt.inv_mass, pt.mass, sp.ij, sp.rest, sp.stiff, sp.first_ptr,
                          sp.second_ptr, sp.second_slot, sp.second_other))
        ok = np.asarray(ob.kind)
        od = np.asarray(ob.data, dtype=np.float64)
        p = dict(dt=float(dt), integrator=int(integrator), damping=float(pt.damping),
                 gravity=tuple(float(c) for c in pt.gravity), loops=int(pv.loops),
                 tau=float(pv.tau), tolerance=float(pv.tolerance),
                 all_pairs=bool(pv.all_pairs), gauss_seidel=bool(pv.gauss_seidel),
                 velocity_update=bool(pv.velocity_update), ground=bool(g.paper),
                 height=float(g.height), mu=float(g.mu), nu=float(g.nu),
                 rest_speed=float(ob.rest_speed), center=tuple(float(c) for c in g.center),
                 bound2=float(g.bound2))
        key = (tuple(p.items()), ok.tobytes(), od.tobytes())
        p["obstacle_kind"], p["obstacle_data"] = ok, od
        prog = self._program(dm, key, p)
        F = self.np_dtype
        hv = dm.views
        if hv is not None:  # CPU device: plain numpy copies into the device memory
            hv["x"][...] = x
            hv["v"][...] = v
            hv["a"][...] = a
            if slip is not None:
                hv["slip"][...] = slip
            for name in ("ctl", "counts", "largest"):
                hv[name][...] = 0
        else:
            dm.x.assign(np.ascontiguousarray(x, dtype=F))
            dm.v.assign(np.ascontiguousarray(v, dtype=F))
            dm.a.assign(np.ascontiguousarray(a, dtype=F))
            if slip is not None:
                dm.slip.assign(np.ascontiguousarray(slip, dtype=F))
            dm.ctl.zero_()
            dm.counts.zero_()
            dm.largest.zero_()
        dm.last = prog
        self._replay(prog, int(nsteps))
        if hv is not None:
            ctl = hv["ctl"].copy()
            x[...] = hv["x"]
            v[...] = hv["v"]
            a[...] = hv["a"]
            max_corr[...] = hv["max_corr"]
            if slip is not None:
                slip[...] = hv["slip"]
        else:
            ctl = dm.ctl.numpy()
            x[...] = dm.x.numpy()
            v[...] = dm.v.numpy()
            a[...] = dm.a.numpy()
            max_corr[...] = dm.max_corr.numpy()
            if slip is not None:
                slip[...] = dm.slip.numpy()
        status = int(ctl[0])
        done = int(ctl[1]) if status != STATUS_OK else int(nsteps)
        return done, status

    def physical_steps(self, nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays,
                       scratch):
        """The physical (FEM) path's driver on the device: the signature and results of
        :func:`jellysim.kernels.fem_numba.physical_steps` (:mod:`.warp_physical`)."""
        from .warp_physical import physical_steps

        return physical_steps(self, nsteps, dt, x, v, a, model_arrays, fem, handles,
                              contact_arrays, scratch)

    def replay_resident(self, x0, nsteps: int) -> int:
        """Benchmarks: run ``nsteps`` more steps of the last ``run_steps`` call of the model
        whose rest positions are ``x0`` on the device-resident state (no copies); returns the
        status.  The host state is not updated."""
        for dm in self._models.values():
            if dm.last is not None and dm.n == x0.shape[0]:
                self._replay(dm.last, int(nsteps))
                wp.synchronize_device(self.device)
                return int(dm.ctl.numpy()[0])  # noqa: the status word, not the state
        raise RuntimeError("no run_steps call to replay")


def run_steps(*args):
    """:meth:`WarpBackend.run_steps` on the default device (a GPU if present, else the CPU
    device) in float64: a drop-in for the numba backend's ``run_steps``."""
    return WarpBackend.get().run_steps(*args)
