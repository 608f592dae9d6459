"""The classroom plank: where a jello block starts to slide as its slope is raised slowly.

A 3 x 1.5 x 2.5 cm block (E = 30 kPa, nu = 0.45, zeta = 0.05 at 20 Hz) is settled on the
contact ground; then gravity is turned by 1 deg every 0.1 s.  The breakaway angle is the first
at which the centre of mass moves faster than 1 mm/s along the slope at the end of a stage.  A
rigid block breaks away at atan(mu_s) whatever mu_k is.  An elastic one's edges slip first
(their pressure is lowest, their shear highest); if a slipping point held only mu_k at once
(slip_distance D_c = 0) the slip would spread across the base at a lower angle, near
atan(mu_k) (precursor slip: Iwashita, Matsukawa & Otsuki, Sci. Rep. 13, 2023,
doi:10.1038/s41598-023-29764-w; Tromborg et al., arXiv:1105.3325, 2011).  With slip-weakening
(the coefficient falls from mu_s to mu_k over D_c of slip, the default D_c = 1 mm) the
edges' creep stays below D_c and the block holds to near atan(mu_s).  docs/physics.md
section 2 quotes the output.

Run:  PYTHONPATH=src python examples/validate_tilt.py
"""
import dataclasses
import warnings

import numpy as np

import jellysim as js


def breakaway(mu_s, mu_k, *, points=300, slip_distance=1e-3, step_deg=1.0, max_deg=30.0):
    """The breakaway angle [deg] (None if it holds to ``max_deg``)."""
    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=points)
    mat = js.material("gelatin", youngs_modulus=3e4, poisson_ratio=0.45, damping_ratio=0.05,
                      damping_frequency=20.0)
    ground = js.GroundParams(model="contact", friction=mu_k, static_friction=mu_s,
                             slip_distance=slip_distance, restitution=0.0)
    model = js.physical_model(body, mat)
    sim = js.Simulator(model, dt=1 / 240, ground=ground)
    sim.settle()
    m = model.point_mass / model.point_mass.sum()
    for theta in np.arange(step_deg, max_deg + 1e-9, step_deg):
        t = np.radians(theta)
        sim.model = dataclasses.replace(sim.model, gravity=np.array(
            [9.81 * np.sin(t), -9.81 * np.cos(t), 0.0]))
        sim.advance(24)
        if float(m @ sim.state.v[:, 0]) > 1e-3:
            return float(theta)
    return None


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    pairs = [(0.5, 0.5), (0.5, 0.45), (0.5, 0.3), (0.5, 0.1)]
    slips = [0.0, 1e-5, 1e-4, 1e-3]
    print("breakaway [deg], 300 points, by slip_distance D_c [m]")
    print("mu_s  mu_k  atan(mu_s) atan(mu_k)  " + "  ".join(f"{d:g}".rjust(6) for d in slips))
    for mu_s, mu_k in pairs:
        got = [breakaway(mu_s, mu_k, slip_distance=d) for d in slips]
        print(f"{mu_s:4.2f}  {mu_k:4.2f}  {np.degrees(np.arctan(mu_s)):9.2f}  "
              f"{np.degrees(np.arctan(mu_k)):9.2f}   " + "  ".join(f"{g}".rjust(6) for g in got),
              flush=True)
    print("the default D_c (1e-3 m) at 2,400 points")
    for mu_s, mu_k in pairs:
        print(f"{mu_s:4.2f}  {mu_k:4.2f}  {breakaway(mu_s, mu_k, points=2400)}", flush=True)
