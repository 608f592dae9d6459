"""Two other layouts of the fused paper step's slots: are they faster than the shipped one?

The shipped step (``kernels/steps_fused_numba.py``) has its first sweep store each spring's
force and Provot *scalars* in the spring's slot of its second point's list; the second sweep
gathers the other end's position to rebuild the vectors.  Timed here against it, in one
process, on ``bench_step``'s paper scene (600 points, one Jacobi Provot pass, one thread):

* ``vec``: each slot holds the force and Provot *vectors* and the Provot count (8 doubles, one
  cache line), so the second sweep is a contiguous sum with no gather; bitwise the shipped
  results (``-(c (b - a)) == c (a - b)`` exactly);
* ``scatter``: one serial sweep adding each spring to both ends at once (no slots, no second
  sweep); not bitwise (the sums' order differs), so compared by speed and by its distance.

Run:  PYTHONPATH=src python -m benchmarks.bench_slot_layouts [--points 600] [--steps 2000]
"""
import argparse
import json
import time

import numpy as np
from numba import njit, prange

from jellysim.kernels.contact_numba import _status
from jellysim.kernels.provot_numba import _momentum_shift, _provot_c_inv
from jellysim.kernels.steps_fused_numba import (_accel_and_move, _consts, _copy_state,
                                                _drift_paper, _finish_point)


@njit(parallel=True, cache=False, nogil=True, error_model="numpy")
def region_vec(xr, vr, xw, vw, a, springs, points, tau, g, ctl, scratch, svec):
    n = xr.shape[0]
    rest, stiff = springs.rest, springs.stiff
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot = springs.second_slot
    first_other = springs.first_other
    dx = scratch.dx
    count, force, max_corr = scratch.count, scratch.force, scratch.max_corr
    inv_mass, gravity, center = points.inv_mass, points.gravity, g.center
    mass = points.mass
    consts = _consts(points, g, ctl)
    for p in prange(n):
        fx = 0.0; fy = 0.0; fz = 0.0; sx = 0.0; sy = 0.0; sz = 0.0
        cnt = 0
        px, py, pz = np.float64(xr[p, 0]), np.float64(xr[p, 1]), np.float64(xr[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            ex = np.float64(xr[q, 0]) - px
            ey = np.float64(xr[q, 1]) - py
            ez = np.float64(xr[q, 2]) - pz
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            inv = 1.0 / length if length > 0.0 else 0.0
            r0 = rest[s]
            c = stiff[s] * (length - r0) * inv
            slot = second_slot[s]
            gx = c * ex; gy = c * ey; gz = c * ez
            fx += gx; fy += gy; fz += gz
            cp = _provot_c_inv(length, inv, r0, tau)
            hx = cp * ex; hy = cp * ey; hz = cp * ez
            sx += hx; sy += hy; sz += hz
            nz = cp != 0.0
            cnt += nz
            svec[slot, 0] = gx; svec[slot, 1] = gy; svec[slot, 2] = gz
            svec[slot, 3] = hx; svec[slot, 4] = hy; svec[slot, 5] = hz
            svec[slot, 6] = 1.0 if nz else 0.0
        force[p, 0] = fx; force[p, 1] = fy; force[p, 2] = fz
        dx[p, 0] = sx; dx[p, 1] = sy; dx[p, 2] = sz
        count[p] = cnt
    nonfinite = 0
    runaway = 0
    for q in prange(n):
        fx = force[q, 0]; fy = force[q, 1]; fz = force[q, 2]
        sx = dx[q, 0]; sy = dx[q, 1]; sz = dx[q, 2]
        cnt = count[q]
        cf = 0.0
        for t in range(second_ptr[q], second_ptr[q + 1]):
            fx -= svec[t, 0]; fy -= svec[t, 1]; fz -= svec[t, 2]
            sx -= svec[t, 3]; sy -= svec[t, 4]; sz -= svec[t, 5]
            cf += svec[t, 6]
        cnt += int(cf)
        _accel_and_move(q, vr, a, (fx, fy, fz, sx, sy, sz, cnt), inv_mass, gravity,
                        consts[0], dx, max_corr)
    shift = _momentum_shift(mass, dx)
    for p in prange(n):
        bad, far = _finish_point(p, xr, vr, xw, vw, a, dx, shift, center, consts)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


@njit(cache=False, nogil=True, error_model="numpy")
def region_scatter(xr, vr, xw, vw, a, springs, points, tau, g, ctl, scratch, svec):
    n = xr.shape[0]
    rest, stiff = springs.rest, springs.stiff
    first_ptr = springs.first_ptr
    first_other = springs.first_other
    dx = scratch.dx
    count, force, max_corr = scratch.count, scratch.force, scratch.max_corr
    inv_mass, gravity, center = points.inv_mass, points.gravity, g.center
    mass = points.mass
    consts = _consts(points, g, ctl)
    for p in range(n):
        for c in range(3):
            force[p, c] = 0.0
            dx[p, c] = 0.0
        count[p] = 0
    for p in range(n):
        fx = force[p, 0]; fy = force[p, 1]; fz = force[p, 2]
        sx = dx[p, 0]; sy = dx[p, 1]; sz = dx[p, 2]
        cnt = count[p]
        px, py, pz = np.float64(xr[p, 0]), np.float64(xr[p, 1]), np.float64(xr[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            ex = np.float64(xr[q, 0]) - px
            ey = np.float64(xr[q, 1]) - py
            ez = np.float64(xr[q, 2]) - pz
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            inv = 1.0 / length if length > 0.0 else 0.0
            r0 = rest[s]
            c = stiff[s] * (length - r0) * inv
            gx = c * ex; gy = c * ey; gz = c * ez
            fx += gx; fy += gy; fz += gz
            force[q, 0] -= gx; force[q, 1] -= gy; force[q, 2] -= gz
            cp = _provot_c_inv(length, inv, r0, tau)
            if cp != 0.0:
                hx = cp * ex; hy = cp * ey; hz = cp * ez
                sx += hx; sy += hy; sz += hz
                dx[q, 0] -= hx; dx[q, 1] -= hy; dx[q, 2] -= hz
                cnt += 1
                count[q] += 1
        _accel_and_move(p, vr, a, (fx, fy, fz, sx, sy, sz, cnt), inv_mass, gravity,
                        consts[0], dx, max_corr)
    shift = _momentum_shift(mass, dx)
    nonfinite = 0
    runaway = 0
    for p in range(n):
        bad, far = _finish_point(p, xr, vr, xw, vw, a, dx, shift, center, consts)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


@njit(cache=False)
def run_region(region, nsteps, dt, x, v, a, springs, points, tau, velocity_update, ground,
               scratch, svec):
    """``nsteps`` report steps by ``region`` (one of the two above), double-buffered as the
    shipped ``paper_springs_steps`` (no failure retake: the bench scene does not fail)."""
    _drift_paper(x, v, a, dt)
    xr, vr, xw, vw = x, v, scratch.x_pre, scratch.v_alt
    for step in range(nsteps):
        region(xr, vr, xw, vw, a, springs, points, tau, ground,
               (dt, step != nsteps - 1, velocity_update), scratch, svec)
        xr, xw = xw, xr
        vr, vw = vw, vr
    if nsteps % 2 == 1:
        _copy_state(x, v, xr, vr)


def main(argv=None):
    import os

    import numba
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    from .bench_step import paper_scene, scene_dt

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=600)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    model, _, _ = paper_scene(args.points)
    steps = args.steps
    dt = scene_dt(model)
    tau, mu, nu = 0.001, 0.1, 0.2
    numba.set_num_threads(1)
    sim = Simulator(model, dt=dt, integrator="paper", backend="numba", threads=1,
                    provot=ProvotParams(tau=tau, loops=1, pairs="springs"),
                    ground=GroundParams(mu=mu, nu=nu), check_stability=False)
    sim.advance(1)
    x0, v0, a0 = sim.state.x.copy(), sim.state.v.copy(), sim.state.a.copy()
    svec = np.zeros((model.spring_count, 8))
    vu = bool(sim._provot_opts.velocity_update)
    rs = {"shipped": [], "vec": [], "scatter": []}
    load = os.getloadavg()
    for rep in range(args.repeats):   # alternating: a drift of the machine hits all alike
        sim.state.x[:], sim.state.v[:], sim.state.a[:] = x0, v0, a0
        t = time.perf_counter(); sim.advance(steps); rs["shipped"].append(steps / (time.perf_counter() - t))
        xs = sim.state.x.copy()
        x, v, a = x0.copy(), v0.copy(), a0.copy()
        t = time.perf_counter()
        run_region(region_vec, steps, dt, x, v, a, sim._springs, sim._points, tau, vu, sim._ground, sim._scratch, svec)
        rs["vec"].append(steps / (time.perf_counter() - t))
        x2, v2, a2 = x0.copy(), v0.copy(), a0.copy()
        t = time.perf_counter()
        run_region(region_scatter, steps, dt, x2, v2, a2, sim._springs, sim._points, tau, vu, sim._ground, sim._scratch, svec)
        rs["scatter"].append(steps / (time.perf_counter() - t))
    med = {k: float(np.median(r[1:])) for k, r in rs.items()}
    print(json.dumps({"points": model.point_count, "springs": model.spring_count,
                      "steps": steps, "load": load, "load_after": os.getloadavg(),
                      "steps_per_s": med,
                      "ratio": {k: med[k] / med["shipped"] for k in ("vec", "scatter")},
                      "vec_bitwise_shipped": bool(np.array_equal(x, xs)),
                      "scatter_max_distance_m": float(np.abs(x2 - xs).max())}, indent=2))


if __name__ == "__main__":
    main()
