import numpy as np
import pytest

from jellysim.body import Body
from jellysim.geometry.connect import radius_springs
from jellysim.geometry.sampling import box_field
from jellysim.model import finalize


def make_box_model(n=300, r=None, *, seed=3, stiffness=50.0, damping=0.0, point_mass=0.01,
                   gravity=(0.0, -9.8, 0.0), lower=(0, 0, 0), upper=(1, 1, 1),
                   distribution="uniform"):
    pts = box_field(n, lower, upper, distribution=distribution, seed=seed)
    if r is None:
        r = 0.3 * (600 / n) ** (1 / 3)
    body = Body(points=pts, springs=radius_springs(pts, r), volume=1.0)
    return finalize(body, stiffness=stiffness, point_mass=point_mass, damping=damping,
                    gravity=gravity)


@pytest.fixture
def box_model():
    return make_box_model


def spring_energy(model, x):
    d = x[model.spring_ij[:, 1]] - x[model.spring_ij[:, 0]]
    L = np.linalg.norm(d, axis=1)
    return 0.5 * np.sum(model.spring_stiffness * (L - model.spring_rest_length) ** 2)


def kinetic_energy(model, v):
    return 0.5 * np.sum(model.point_mass[:, None] * v * v)


from pathlib import Path  # noqa: E402

DATA = Path(__file__).resolve().parent / "data"
SHARED_MESHES = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"
STANFORD = {"bunny.obj", "stanford_bunny_scan_holes.obj"}


def mesh_path(name: str) -> Path:
    """A test mesh: from tests/data, or (Stanford models only) from ../shared/meshes."""
    if name in STANFORD:
        p = SHARED_MESHES / name
        if not p.exists():
            pytest.skip(f"{name} is a Stanford model, not redistributed with the repository; "
                        f"it is read from {SHARED_MESHES}, which does not exist here")
        return p
    return DATA / name
