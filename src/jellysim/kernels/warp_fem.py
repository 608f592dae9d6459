"""Warp kernels of the physical (FEM) path: the twins of :mod:`.fem_numba` (read the spec in
:mod:`.fem_numpy`), operation for operation, so float64 on Warp's CPU device repeats numba's
arithmetic.

One substep is ``k_tet_forces`` (a thread per tet: Stable Neo-Hookean + the damping branch,
the branch strain ``q`` advanced, ``J`` and the running smallest ``J``), [the springs' first
pass, :func:`.warp_kernels.k_force_first`], ``k_fem_gather`` (a thread per point: its corner
rows in tet order, then the springs' second list), ``k_fem_integrate`` (symplectic Euler with
the handles and the checks), [:func:`.warp_contact.k_contact`], :func:`.warp_contact.k_step_end`.
No float atomics except ``atomic_min`` of ``J`` (exact, order-free).  Arguments are bundled in
per-precision structs (:func:`.warp_common.precision_structs`):

* ``Tets``: the per-tet material arrays, the damping branch (``g``, ``decay``, ``q``) and the
  per-tet outputs (corner forces, ``J``, the smallest ``J``);
* ``Gather``: the point -> corner-slot CSR list, the springs' second list, the sum;
* ``Points``: masses, damping, gravity, the handles (gravity scale, point force, pins, drag),
  the substep and the runaway guard.
"""
from __future__ import annotations

from typing import Any

import warp as wp

from .warp_common import A2, FLOAT, I32, precision_structs, register_overloads

wp.set_module_options({"enable_backward": False})

TETS = {"tets": wp.array2d(dtype=wp.int32), "dm": ("array", 3), "vol": ("array", 1),
        "mu": ("array", 1), "lam": ("array", 1), "alpha": ("array", 1), "mu_l": ("array", 1),
        "g": FLOAT, "decay": FLOAT, "q": ("array", 2), "tet_force": ("array", 2),
        "tet_j": ("array", 1), "min_j": ("array", 1)}
GATHER = {"ptr": I32, "slot": I32, "tet_force": ("array", 2), "use_springs": wp.int32,
          "first": ("array", 2), "second_ptr": I32, "second_other": I32,
          "scal": ("array", 1), "fsum": ("array", 2)}
POINTS = {"inv_mass": ("array", 1), "damping": FLOAT, "gx": FLOAT, "gy": FLOAT, "gz": FLOAT,
          "gscale": ("array", 1), "fext": ("array", 2), "pinned": I32,
          "pin_from": ("array", 2), "pin_to": ("array", 2), "drag": ("array", 1),
          "drag_w": ("array", 1), "drag_off": ("array", 2),
          "dt": FLOAT, "cx": FLOAT, "cy": FLOAT, "cz": FLOAT, "bound2": FLOAT}

Tets = precision_structs("FemTets", TETS, __name__)
Gather = precision_structs("FemGather", GATHER, __name__)
Points = precision_structs("FemPoints", POINTS, __name__)


@wp.kernel
def k_tet_forces(x: A2, tt: Any, ctl: I32):
    t = wp.tid()
    if ctl[0] != 0:
        return
    i0 = tt.tets[t, 0]
    i1 = tt.tets[t, 1]
    i2 = tt.tets[t, 2]
    i3 = tt.tets[t, 3]
    d00 = x[i1, 0] - x[i0, 0]
    d10 = x[i1, 1] - x[i0, 1]
    d20 = x[i1, 2] - x[i0, 2]
    d01 = x[i2, 0] - x[i0, 0]
    d11 = x[i2, 1] - x[i0, 1]
    d21 = x[i2, 2] - x[i0, 2]
    d02 = x[i3, 0] - x[i0, 0]
    d12 = x[i3, 1] - x[i0, 1]
    d22 = x[i3, 2] - x[i0, 2]
    m = tt.dm
    f00 = d00 * m[t, 0, 0] + d01 * m[t, 1, 0] + d02 * m[t, 2, 0]
    f01 = d00 * m[t, 0, 1] + d01 * m[t, 1, 1] + d02 * m[t, 2, 1]
    f02 = d00 * m[t, 0, 2] + d01 * m[t, 1, 2] + d02 * m[t, 2, 2]
    f10 = d10 * m[t, 0, 0] + d11 * m[t, 1, 0] + d12 * m[t, 2, 0]
    f11 = d10 * m[t, 0, 1] + d11 * m[t, 1, 1] + d12 * m[t, 2, 1]
    f12 = d10 * m[t, 0, 2] + d11 * m[t, 1, 2] + d12 * m[t, 2, 2]
    f20 = d20 * m[t, 0, 0] + d21 * m[t, 1, 0] + d22 * m[t, 2, 0]
    f21 = d20 * m[t, 0, 1] + d21 * m[t, 1, 1] + d22 * m[t, 2, 1]
    f22 = d20 * m[t, 0, 2] + d21 * m[t, 1, 2] + d22 * m[t, 2, 2]
    zero = type(d00)(0.0)
    one = type(d00)(1.0)
    half = type(d00)(0.5)
    ic = (f00 * f00 + f01 * f01 + f02 * f02 + f10 * f10 + f11 * f11 + f12 * f12
          + f20 * f20 + f21 * f21 + f22 * f22)
    # cofactor columns: c0 = F1 x F2, c1 = F2 x F0, c2 = F0 x F1 (Fk = column k)
    c00 = f11 * f22 - f21 * f12
    c10 = f21 * f02 - f01 * f22
    c20 = f01 * f12 - f11 * f02
    c01 = f12 * f20 - f22 * f10
    c11 = f22 * f00 - f02 * f20
    c21 = f02 * f10 - f12 * f00
    c02 = f10 * f21 - f20 * f11
    c12 = f20 * f01 - f00 * f21
    c22 = f00 * f11 - f10 * f01
    J = f00 * c00 + f10 * c10 + f20 * c20
    a = tt.mu[t] * (one - one / (ic + one))
    b = tt.lam[t] * (J - tt.alpha[t])
    p00 = a * f00 + b * c00
    p01 = a * f01 + b * c01
    p02 = a * f02 + b * c02
    p10 = a * f10 + b * c10
    p11 = a * f11 + b * c11
    p12 = a * f12 + b * c12
    p20 = a * f20 + b * c20
    p21 = a * f21 + b * c21
    p22 = a * f22 + b * c22
    g = tt.g
    if g > zero:
        exx = half * (f00 * f00 + f10 * f10 + f20 * f20 - one)
        eyy = half * (f01 * f01 + f11 * f11 + f21 * f21 - one)
        ezz = half * (f02 * f02 + f12 * f12 + f22 * f22 - one)
        exy = half * (f00 * f01 + f10 * f11 + f20 * f21)
        eyz = half * (f01 * f02 + f11 * f12 + f21 * f22)
        exz = half * (f00 * f02 + f10 * f12 + f20 * f22)
        q = tt.q
        decay = tt.decay
        q0 = exx + (q[t, 0] - exx) * decay
        q1 = eyy + (q[t, 1] - eyy) * decay
        q2 = ezz + (q[t, 2] - ezz) * decay
        q3 = exy + (q[t, 3] - exy) * decay
        q4 = eyz + (q[t, 4] - eyz) * decay
        q5 = exz + (q[t, 5] - exz) * decay
        q[t, 0] = q0
        q[t, 1] = q1
        q[t, 2] = q2
        q[t, 3] = q3
        q[t, 4] = q4
        q[t, 5] = q5
        dxx = exx - q0
        dyy = eyy - q1
        dzz = ezz - q2
        tr = type(d00)(-2.0) * tt.mu_l[t] * (dxx + dyy + dzz) / type(d00)(3.0)  # deviatoric
        two = type(d00)(2.0) * tt.mu_l[t]
        sxx = g * (two * dxx + tr)
        syy = g * (two * dyy + tr)
        szz = g * (two * dzz + tr)
        sxy = g * two * (exy - q3)
        syz = g * two * (eyz - q4)
        sxz = g * two * (exz - q5)
        p00 = p00 + (f00 * sxx + f01 * sxy + f02 * sxz)
        p01 = p01 + (f00 * sxy + f01 * syy + f02 * syz)
        p02 = p02 + (f00 * sxz + f01 * syz + f02 * szz)
        p10 = p10 + (f10 * sxx + f11 * sxy + f12 * sxz)
        p11 = p11 + (f10 * sxy + f11 * syy + f12 * syz)
        p12 = p12 + (f10 * sxz + f11 * syz + f12 * szz)
        p20 = p20 + (f20 * sxx + f21 * sxy + f22 * sxz)
        p21 = p21 + (f20 * sxy + f21 * syy + f22 * syz)
        p22 = p22 + (f20 * sxz + f21 * syz + f22 * szz)
    # H = -V P Dm^-T: H[:, k] = -V sum_l P[:, l] m[k, l]
    w = -tt.vol[t]
    r = 4 * t
    out = tt.tet_force
    s0x = zero
    s0y = zero
    s0z = zero
    for k in range(3):
        hx = w * (p00 * m[t, k, 0] + p01 * m[t, k, 1] + p02 * m[t, k, 2])
        hy = w * (p10 * m[t, k, 0] + p11 * m[t, k, 1] + p12 * m[t, k, 2])
        hz = w * (p20 * m[t, k, 0] + p21 * m[t, k, 1] + p22 * m[t, k, 2])
        out[r + 1 + k, 0] = hx
        out[r + 1 + k, 1] = hy
        out[r + 1 + k, 2] = hz
        s0x = s0x + hx
        s0y = s0y + hy
        s0z = s0z + hz
    out[r, 0] = -s0x
    out[r, 1] = -s0y
    out[r, 2] = -s0z
    tt.tet_j[t] = J
    if J < tt.min_j[0]:  # (a NaN never lowers the minimum, as numba's serial loop)
        wp.atomic_min(tt.min_j, 0, J)


@wp.kernel
def k_fem_gather(x: A2, ga: Any, ctl: I32):
    """Per point: its corner rows in tet order; with springs, + the first-list sum (written
    by ``k_force_first``) + the second-list sum (numba's ``_spring_forces`` order)."""
    p = wp.tid()
    if ctl[0] != 0:
        return
    tf = ga.tet_force
    fx = type(tf[0, 0])(0.0)
    fy = type(tf[0, 0])(0.0)
    fz = type(tf[0, 0])(0.0)
    for e in range(ga.ptr[p], ga.ptr[p + 1]):
        r = ga.slot[e]
        fx = fx + tf[r, 0]
        fy = fy + tf[r, 1]
        fz = fz + tf[r, 2]
    if ga.use_springs != 0:
        fx = fx + ga.first[p, 0]
        fy = fy + ga.first[p, 1]
        fz = fz + ga.first[p, 2]
        sx = type(fx)(0.0)
        sy = type(fx)(0.0)
        sz = type(fx)(0.0)
        qx = x[p, 0]
        qy = x[p, 1]
        qz = x[p, 2]
        for t in range(ga.second_ptr[p], ga.second_ptr[p + 1]):
            c = ga.scal[t]
            i = ga.second_other[t]
            sx = sx + c * (x[i, 0] - qx)
            sy = sy + c * (x[i, 1] - qy)
            sz = sz + c * (x[i, 2] - qz)
        fx = fx + sx
        fy = fy + sy
        fz = fz + sz
    ga.fsum[p, 0] = fx
    ga.fsum[p, 1] = fy
    ga.fsum[p, 2] = fz


@wp.kernel
def k_fem_integrate(x: A2, v: A2, a: A2, fsum: A2, pt: Any, counts: I32, ctl: I32):
    """Symplectic Euler per point (v += dt a; x += dt v), pins along their line over the
    call's substeps (``ctl[1]`` done of ``ctl[3]``), drag, then the checks."""
    p = wp.tid()
    if ctl[0] != 0:
        return
    fx = fsum[p, 0] + pt.fext[p, 0]
    fy = fsum[p, 1] + pt.fext[p, 1]
    fz = fsum[p, 2] + pt.fext[p, 2]
    drag = pt.drag
    if drag[0] >= 0.0 and pt.drag_w[p] > 0.0:  # the grabbed patch (handles.Handles.drag)
        kd = drag[4] * pt.drag_w[p]
        fx = fx + kd * (drag[1] + pt.drag_off[p, 0] - x[p, 0])
        fy = fy + kd * (drag[2] + pt.drag_off[p, 1] - x[p, 1])
        fz = fz + kd * (drag[3] + pt.drag_off[p, 2] - x[p, 2])
    w = pt.inv_mass[p]
    gs = pt.gscale[p]
    dt = pt.dt
    damping = pt.damping
    a[p, 0] = (fx - damping * v[p, 0]) * w + gs * pt.gx
    a[p, 1] = (fy - damping * v[p, 1]) * w + gs * pt.gy
    a[p, 2] = (fz - damping * v[p, 2]) * w + gs * pt.gz
    if drag[0] >= 0.0 and pt.drag_w[p] > 0.0 and drag[5] > 0.0:  # its damper, implicit
        r = type(dt)(1.0) + dt * drag[5] * pt.drag_w[p] * w
        for c in range(3):
            a[p, c] = ((v[p, c] + dt * a[p, c]) / r - v[p, c]) / dt
    if pt.pinned[p] != 0:
        frac = type(dt)(ctl[1] + 1) / type(dt)(ctl[3])
        for c in range(3):
            target = pt.pin_from[p, c] + frac * (pt.pin_to[p, c] - pt.pin_from[p, c])
            v[p, c] = (target - x[p, c]) / dt
            x[p, c] = target
            a[p, c] = type(dt)(0.0)
    else:
        for c in range(3):
            v[p, c] = v[p, c] + dt * a[p, c]
            x[p, c] = x[p, c] + dt * v[p, c]
    s = x[p, 0] + x[p, 1] + x[p, 2] + v[p, 0] + v[p, 1] + v[p, 2]
    if not wp.isfinite(s):
        wp.atomic_add(counts, 0, 1)
    rx = x[p, 0] - pt.cx
    ry = x[p, 1] - pt.cy
    rz = x[p, 2] - pt.cz
    if rx * rx + ry * ry + rz * rz > pt.bound2:
        wp.atomic_add(counts, 1, 1)


register_overloads([k_tet_forces, k_fem_gather, k_fem_integrate],
                   {"tt": Tets, "ga": Gather, "pt": Points})
