"""Time-step throughput: steps/s and spring-updates/s, beside this machine's memory bandwidth.

Scenes: the report's paper cube (600 edge-favouring points, r = 0.3, k = 2 N/m, delta = 0.8 kg/s,
dt = 0.01 s, tau = 0.1 %, ONE Provot pass over the springs, the report's ground) and the same
recipe at N = 10k, 100k, 1M points with r = 0.3 (600 / N)^(1/3) (so about 33 springs per point).
Every body starts resting on the ground (y in [0, 1]) so that the ground rule and Provot
corrections are active in every timed window; each window must end finite, else it is reported
as failed.  The report's dt = 0.01 s is kept for the paper scene; the larger edge-favouring
fields crowd many points into the cube's corners (up to hundreds of springs per point), which
pushes the forward-Euler limit dt < delta / lambda_max(K) far below 0.01 s, so those scenes use
dt = min(0.01 s, half the stability guard's estimate) with the report's k, delta and density.  A spring-update is one spring's force plus one Provot check: springs x steps/s.

The bandwidth bound (roofline): a STREAM triad ``a = b + s c`` (numba parallel, and numpy)
measures the streaming bandwidth B [bytes/s].  A spring-update must at least read what defines
the spring and cannot be recomputed: its other end's index (4 bytes as int32; the first end is
implicit in a per-point list), its rest length (8, f64) and its stiffness (8, f64) = 20 bytes;
and each step must read and write the point state, x and v read and written, a written:
5 x 24 = 120 bytes per point, shared by the point's springs.  So the minimum traffic is
``MIN_BYTES = 20 + 120 n / k`` bytes per spring-update (n points, k springs; about 24 bytes at
33 springs per point), independent of any layout, and no implementation on this machine
exceeds B / MIN_BYTES spring-updates/s; the script prints the achieved fraction of that bound.
For comparison, the numba step (``kernels/spring_sums_numba.py``: each point visits all its
springs, each spring seen from both ends) reads per spring, from each end, the other end's
index (4), the rest length (8) and the stiffness (8; both ends' from their points' visit lists,
``SpringArrays.visit_*``) = ``LAYOUT_BYTES`` = 40, and writes nothing per
spring (plus the point arrays).  (The scheme before 2026-12-07 computed each spring once and
moved 76 bytes: the two indices, rest, stiffness, the slot index, and the force and Provot
scalars written into the second point's slot, 16 + 16 read for ownership, and read back, 16.)

The numba backend is timed in float64 and float32 (``precision = "float32"``: the state stored
in float32, the arithmetic in float64), on 1 and 2 threads (``numba_1t``, ``numba_2t``,
``numba_f32_1t``, ``numba_f32_2t``); each run's fraction of the bound is printed.

Run:  python -m benchmarks.bench_step [--sizes 600,10000,100000,1000000] [--repeats 5]

The Warp backend (``--backend warp [--device auto|cpu|cuda:N] [--dtype float32|float64]``):
on a GPU the whole step is one captured CUDA graph replayed per step.  It reports, per scene,
``end_to_end`` (``Simulator.advance``: state uploaded, n steps, state copied back) and
``resident`` (the steps alone, state left on the device), the device's name, memory, peak
memory bandwidth (CUDA driver: 2 x memory clock x bus width), a measured STREAM triad on the
device, and the fraction of both used at the least traffic of one paper step with one Provot
pass (``warp_backend.bytes_per_spring_update``).  ``--compare-numba`` also times the numba
backend (1 thread and all threads) on the same scenes (where the GPU starts to win).  Scenes of 1M points
and more are cubic lattices by default (``--scene auto``; 26 neighbours within 1.8 h, built
directly in CSR order in seconds), since the edge-favouring field of 1M points takes minutes to
build (and holds 73M springs); ``--scene field`` forces the random field.

    python -m benchmarks.bench_step --backend warp --dtype float32 \
        --sizes 600,10000,100000,1000000,10000000 --compare-numba
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

LAYOUT_BYTES = 40
"""Bytes per spring the numba step moves (see the docstring)."""
SPRING_MIN_BYTES = 20
POINT_MIN_BYTES = 120


def min_bytes_per_spring_update(n: int, k: int) -> float:
    """The least bytes a spring-update must move (the docstring's roofline)."""
    return SPRING_MIN_BYTES + POINT_MIN_BYTES * n / max(k, 1)


def stream_triad(n: int = 1 << 25, repeats: int = 5) -> dict:
    import numba
    from numba import njit, prange

    @njit(parallel=True, cache=False)
    def triad(a, b, c, s):
        for i in prange(a.shape[0]):
            a[i] = b[i] + s * c[i]

    a = np.zeros(n)
    b = np.ones(n)
    c = np.full(n, 2.0)
    out = {}
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        triad(a, b, c, 3.0)
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            triad(a, b, c, 3.0)
            times.append(time.perf_counter() - t)
        out[f"threads_{threads}_GBps"] = 24 * n / float(np.median(times)) / 1e9
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        np.multiply(c, 3.0, out=a)
        np.add(a, b, out=a)
        times.append(time.perf_counter() - t)
    out["numpy_GBps"] = 40 * n / float(np.median(times)) / 1e9  # two passes: 16 + 24 bytes
    out["best_GBps"] = max(out.values())
    return out


def paper_scene(n: int, seed: int = 2010):
    from jellysim.body import Body
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.sampling import box_field
    from jellysim.model import finalize

    r = 0.3 * (600 / n) ** (1 / 3)
    t = time.perf_counter()
    pts = box_field(n, [0, 0, 0], [1, 1, 1], distribution="edge", seed=seed)
    springs = radius_springs(pts, r)
    build = time.perf_counter() - t
    model = finalize(Body(points=pts, springs=springs, volume=1.0), stiffness=2.0,
                     density=1141.0, damping=0.8)
    return model, r, build


def lattice_scene(n: int):
    """The paper recipe on a cubic grid of about ``n`` points in the unit cube (k = 2 N/m,
    density 1141 kg/m^3, delta = 0.8 kg/s), springs to the 26 neighbours, the Model built
    directly (springs generated already sorted, both CSR lists without a sort)."""
    from jellysim.body import Body
    from jellysim.model import Model

    t = time.perf_counter()
    m = max(2, int(round(n ** (1 / 3))))
    h = 1.0 / (m - 1)
    ax = np.linspace(0.0, 1.0, m)
    pts = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    n = pts.shape[0]
    offs = [(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)
            if (a * m + b) * m + c > 0]
    offs.sort(key=lambda o: (o[0] * m + o[1]) * m + o[2])
    delta = np.array([(a * m + b) * m + c for a, b, c in offs], dtype=np.int64)
    g = np.arange(n, dtype=np.int64)
    ix, iy, iz = g // (m * m), (g // m) % m, g % m
    valid = np.ones((n, len(offs)), dtype=bool)
    for o, (a, b, c) in enumerate(offs):
        for coord, d in ((ix, a), (iy, b), (iz, c)):
            if d > 0:
                valid[:, o] &= coord < m - 1
            elif d < 0:
                valid[:, o] &= coord > 0
    del ix, iy, iz
    rank = np.cumsum(valid, axis=1) - 1
    first_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(valid.sum(axis=1), out=first_ptr[1:])
    si, so = np.nonzero(valid)
    sj = si + delta[so]
    k = si.shape[0]
    rest = np.linalg.norm(np.array(offs, dtype=np.float64) * h, axis=1)[so]
    # second list of q: springs (q - delta_o, q) in spring order = descending delta
    valid2 = np.zeros_like(valid)
    for col in range(len(offs)):
        o = len(offs) - 1 - col
        d = delta[o]
        valid2[d:, col] = valid[:-d, o]
    second_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(valid2.sum(axis=1), out=second_ptr[1:])
    qj, qc = np.nonzero(valid2)
    qo = len(offs) - 1 - qc
    qi = qj - delta[qo]
    second_spring = (first_ptr[qi] + rank[qi, qo]).astype(np.int32)
    del valid2, qj, qc, qo
    second_slot = np.empty(k, dtype=np.int32)
    second_slot[second_spring] = np.arange(k, dtype=np.int32)
    mass = np.full(n, 1141.0 / n)
    body = Body(points=pts, springs=np.zeros((0, 2), dtype=np.int64), volume=1.0)
    ro = lambda a, dt: np.ascontiguousarray(a, dtype=dt)  # noqa: E731
    model = Model(point_x0=pts, point_mass=mass, point_inv_mass=1.0 / mass,
                  spring_ij=ro(np.stack([si, sj], axis=1), np.int32),
                  spring_rest_length=rest, spring_stiffness=np.full(k, 2.0),
                  point_first_ptr=first_ptr, point_second_ptr=second_ptr,
                  point_second_spring=second_spring, spring_second_slot=second_slot,
                  point_second_other=ro(si[second_spring], np.int32), damping=0.8,
                  gravity=np.array([0.0, -9.8, 0.0]), body=body)
    return model, 1.8 * h, time.perf_counter() - t


def scene_dt(model) -> float:
    from jellysim.stability import estimate_stability

    if model.point_count == 600:
        return 0.01
    return min(0.01, 0.5 * estimate_stability(model, "paper", 0.01).dt_max)


def time_steps(model, backend: str, threads: int, steps: int, repeats: int, dt: float,
               precision: str = "float64") -> dict:
    from jellysim.errors import SimulationError
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    sim = Simulator(model, dt=dt, integrator="paper", backend=backend, threads=threads,
                    provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                    ground=GroundParams(mu=0.1, nu=0.2), check_stability=False,
                    precision=precision)
    sim.advance(1)  # compile / load cache, first touch
    rates = []
    corrected = []
    try:
        for _ in range(repeats):
            before = sim.state.x.copy()
            t = time.perf_counter()
            sim.advance(steps)
            rates.append(steps / (time.perf_counter() - t))
            if backend == "numba":  # (it records each point's last Provot move; numpy not)
                corrected.append(float(np.abs(sim._scratch.max_corr).max()))
            assert np.all(np.isfinite(sim.state.x)) and not np.array_equal(before, sim.state.x)
    except SimulationError as exc:
        return {"failed": str(exc)}
    med = float(np.median(rates))
    return {"steps_per_s": med, "spring_updates_per_s": med * model.spring_count,
            "rates": rates, "provot_last_pass_max_correction_m":
            max(corrected) if corrected else None,
            "on_ground": int(np.sum(sim.state.x[:, 1] == 0.0))}


def time_warp(model, device, dtype, dt, repeats, target_s=0.5) -> dict:
    """Warp: the first call (compile or cache load, upload, graph capture), then end-to-end
    and device-resident windows of about ``target_s`` seconds."""
    from jellysim.errors import SimulationError
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    sim = Simulator(model, dt=dt, integrator="paper", backend="warp", device=device,
                    precision=dtype, provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                    ground=GroundParams(mu=0.1, nu=0.2), check_stability=False)
    try:
        t = time.perf_counter()
        sim.advance(1)
        first = time.perf_counter() - t
        t = time.perf_counter()
        sim.advance(5)
        probe = (time.perf_counter() - t) / 5
        steps = int(min(100_000, max(10, target_s / max(probe, 1e-7))))
        e2e, resident = [], []
        for _ in range(repeats):
            before = sim.state.x.copy()
            t = time.perf_counter()
            sim.advance(steps)
            e2e.append(steps / (time.perf_counter() - t))
            assert np.all(np.isfinite(sim.state.x)) and not np.array_equal(before, sim.state.x)
        for _ in range(repeats):
            t = time.perf_counter()
            status = sim._k.replay_resident(model.point_x0, steps)
            resident.append(steps / (time.perf_counter() - t))
            if status != 0:
                return {"failed": f"status {status} in the resident window"}
    except SimulationError as exc:
        return {"failed": str(exc)}
    med = float(np.median(resident))
    return {"device": sim._k.device, "dtype": dtype, "first_call_s": first,
            "steps_per_window": steps,
            "end_to_end": {"steps_per_s": float(np.median(e2e)),
                           "spring_updates_per_s": float(np.median(e2e)) * model.spring_count,
                           "rates": e2e},
            "resident": {"steps_per_s": med, "spring_updates_per_s": med * model.spring_count,
                         "rates": resident},
            "on_ground": int(np.sum(sim.state.x[:, 1] == 0.0))}


def warp_machine(device: str | None, dtype: str) -> dict:
    """Device name, memory, peak bandwidth, nvidia-smi's line, a measured device triad."""
    import subprocess

    import warp as wp

    from jellysim.kernels import warp_backend as wb

    dev = wb.resolve_device(device)
    info = wb.device_info(dev)
    info["warp"] = wp.__version__
    try:
        out = subprocess.run(["nvidia-smi", "--query-gpu=name,memory.total,clocks.max.memory,"
                              "driver_version", "--format=csv,noheader"], capture_output=True,
                             text=True, timeout=20)
        if out.returncode == 0:
            info["nvidia_smi"] = out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    wb.WarpBackend.get(dev, dtype)  # compiles / loads the module
    T = wp.float32 if dtype == "float32" else wp.float64
    size = 4 if dtype == "float32" else 8
    n = (1 << 27) if info["is_cuda"] else (1 << 24)
    a = wp.zeros(n, dtype=T, device=dev)
    b = wp.ones(n, dtype=T, device=dev)
    c = wp.ones(n, dtype=T, device=dev)
    times = []
    for i in range(6):
        wp.synchronize_device(dev)
        t = time.perf_counter()
        wp.launch(wb.k_triad, dim=n, inputs=[a, b, c, T(3.0)], device=dev)
        wp.synchronize_device(dev)
        if i:
            times.append(time.perf_counter() - t)
    info["triad_Bps"] = 3 * size * n / float(np.median(times))
    del a, b, c
    return info


def main_warp(args) -> None:
    from jellysim.kernels.warp_backend import bytes_per_spring_update

    machine = warp_machine(args.device, args.dtype)
    result = {"machine": machine, "backend": "warp", "dtype": args.dtype, "scenes": []}
    print(json.dumps({"machine": machine}), flush=True, file=__import__("sys").stderr)
    for n in [int(s) for s in args.sizes.split(",")]:
        lattice = args.scene == "lattice" or (args.scene == "auto" and n >= 1_000_000)
        model, r, build = lattice_scene(n) if lattice else paper_scene(n)
        dt = scene_dt(model)
        bps = bytes_per_spring_update(model.spring_count, model.point_count, args.dtype)
        entry = {"points": model.point_count, "scene": "lattice" if lattice else "field",
                 "radius_m": r, "springs": model.spring_count, "dt_s": dt, "build_s": build,
                 "bytes_per_spring_update": bps, "runs": {}}
        run = time_warp(model, args.device, args.dtype, dt, args.repeats)
        entry["runs"]["warp"] = run
        if "resident" in run:
            rate = run["resident"]["spring_updates_per_s"]
            bytes_s = rate * bps["per_spring_update"]
            entry["bytes_per_s"] = bytes_s
            entry["fraction_of_triad"] = bytes_s / machine["triad_Bps"]
            if machine.get("peak_bandwidth_Bps"):
                entry["fraction_of_peak"] = bytes_s / machine["peak_bandwidth_Bps"]
        if args.compare_numba and model.point_count <= args.numba_max:
            import numba

            steps = max(2, min(2000, int(2e7 / max(model.spring_count, 1))))
            for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
                entry["runs"][f"numba_{threads}t"] = time_steps(model, "numba", threads, steps,
                                                                args.repeats, dt)
        result["scenes"].append(entry)
        print(json.dumps(entry), flush=True, file=__import__("sys").stderr)
        del model
    print(json.dumps(result, indent=2))


def main(argv=None) -> None:
    import numba

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="600,10000,100000,1000000")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--numpy-max", type=int, default=100_000,
                    help="largest N timed with the numpy reference backend")
    ap.add_argument("--backend", choices=("numba", "warp"), default="numba",
                    help="numba (and the numpy reference) or warp")
    ap.add_argument("--device", default="auto", help="warp: auto, cpu, cuda, cuda:N")
    ap.add_argument("--dtype", choices=("float32", "float64"), default="float32",
                    help="warp precision")
    ap.add_argument("--scene", choices=("auto", "field", "lattice"), default="auto",
                    help="warp: the edge-favouring field, or a cubic lattice (auto: lattice "
                         "from 1M points)")
    ap.add_argument("--compare-numba", action="store_true",
                    help="warp: also time numba (1 thread and all threads) on the same scenes")
    ap.add_argument("--numba-max", type=int, default=1_000_000,
                    help="warp --compare-numba: largest N timed with numba")
    args = ap.parse_args(argv)
    if args.backend == "warp":
        return main_warp(args)
    import jellysim  # noqa: F401  (first: it chooses numba's target before anything compiles)

    bw = stream_triad()
    features = set((numba.config.CPU_FEATURES or "").split(","))
    result = {"machine": {"cpu_count": os.cpu_count(),
                          "numba_threads": numba.config.NUMBA_NUM_THREADS,
                          "jellysim_cpu": os.environ.get("JELLYSIM_CPU", "auto"),
                          "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY", "(OpenMP's)"),
                          "codegen": ("no AVX-512" if "-avx512f" in features else
                                      "prefer-no-gather" if "+prefer-no-gather" in features
                                      else "native"),
                          "python": platform.python_version(), "numba": numba.__version__,
                          "numpy": np.__version__, "load_average": os.getloadavg()},
              "stream_triad": bw, "layout_bytes_per_spring": LAYOUT_BYTES,
              "scenes": []}
    for n in [int(s) for s in args.sizes.split(",")]:
        model, r, build = paper_scene(n)
        steps = max(2, min(2000, int(2e7 / max(model.spring_count, 1))))
        dt = scene_dt(model)
        entry = {"points": n, "radius_m": r, "springs": model.spring_count, "dt_s": dt,
                 "build_s": build, "steps_per_window": steps, "runs": {}}
        for backend, threads, precision in [("numba", 1, "float64"), ("numba", 2, "float64"),
                                            ("numba", 1, "float32"), ("numba", 2, "float32"),
                                            ("numpy", 1, "float64")]:
            if backend == "numpy" and n > args.numpy_max:
                continue
            s = steps if backend == "numba" else max(1, steps // 50)
            name = f"{backend}_{'f32_' if precision == 'float32' else ''}{threads}t"
            entry["runs"][name] = time_steps(model, backend, threads, s, args.repeats, dt,
                                             precision)
        best = max((v.get("spring_updates_per_s", 0) for v in entry["runs"].values()),
                   default=0)
        mb = min_bytes_per_spring_update(model.point_count, model.spring_count)
        bound = bw["best_GBps"] * 1e9 / mb
        entry["min_bytes_per_spring_update"] = mb
        entry["bandwidth_bound_spring_updates_per_s"] = bound
        entry["fraction_of_bandwidth_bound"] = best / bound
        for run in entry["runs"].values():
            if "spring_updates_per_s" in run:
                run["fraction_of_bandwidth_bound"] = run["spring_updates_per_s"] / bound
        result["scenes"].append(entry)
        print(json.dumps(entry), flush=True, file=__import__("sys").stderr)
    result["machine"]["load_average_after"] = os.getloadavg()
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
