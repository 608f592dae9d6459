"""Statics of radius-builder bodies: a resting gelatin cube sags rho g L^2 / (2E) at any
resolution (the calibration's claim), checked on the linear static equilibrium of the
calibrated springs (the dynamic settle on a contact ground adds the sinking of a rough
bottom around its lowest points: BENCHMARKS.md "Radius-builder sag")."""
from pathlib import Path

import numpy as np
import pytest

from jellysim.build import build_body
from jellysim.geometry import load_mesh
from jellysim.geometry.mesh import Mesh
from jellysim.params import Material
from jellysim.physics.material import static_displacements
from jellysim.physics.policy import physical_model

DATA = Path(__file__).parent / "data"
E, RHO, L, G = 1.0e4, 1141.0, 0.1, 9.8


def _top_sag_ratio(points: int) -> float:
    cube = load_mesh(DATA / "cube.obj")  # [-1, 1]^3
    mesh = Mesh.from_arrays((cube.vertices + 1.0) * (L / 2), cube.faces, name="cube")
    body = build_body(mesh, points=points, connect="radius", seed=0)
    model = physical_model(body, Material(youngs_modulus=E, density=RHO, model="springs"),
                           gravity=(0.0, -G, 0.0))
    x = model.point_x0
    y0 = x[:, 1] - x[:, 1].min()
    forces = np.zeros_like(x)
    forces[:, 1] = -model.point_mass * G
    held = np.zeros(x.shape, bool)
    held[y0 < 0.5 * L / len(x) ** (1 / 3), 1] = True  # resting on a frictionless plate
    u = static_displacements(x, model.spring_ij, model.spring_stiffness, forces, held)
    top = y0 > 0.9 * y0.max()
    column = RHO * G * (L * y0 - 0.5 * y0**2) / E  # linear elastic column, top: rho g L^2/2E
    return float(-u[top, 1].sum() / column[top].sum())


def test_radius_cube_sag_is_rho_g_l2_over_2e_at_two_resolutions():
    coarse, fine = _top_sag_ratio(2000), _top_sag_ratio(16000)
    print(f"sag / (rho g L^2 / 2E): 2,000 points {coarse:.3f}, 16,000 points {fine:.3f}")
    assert coarse == pytest.approx(1.0, abs=0.10)
    assert fine == pytest.approx(1.0, abs=0.10)
    assert coarse / fine == pytest.approx(1.0, abs=0.10)
