"""Radius bodies carry tets (Delaunay of their points, carved, slivers dropped) for the
tetrahedral elasticity; their springs, masses and spring calibration stay the radius body's."""
import warnings
from dataclasses import replace

import numpy as np
import pytest

from conftest import mesh_path
from jellysim.build import _radius_tets, build_body
from jellysim.geometry import load_mesh
from jellysim.geometry.connect import radius_springs
from jellysim.geometry.mesh import Mesh
from jellysim.geometry.tetra import boundary_faces, cloud_tets, tet_quality, tet_signed_volumes
from jellysim.physics.material import calibrate_springs, point_masses
from jellysim.scene import Scene


def _faces_shared_by_at_most_two(tets):
    t = np.asarray(tets)
    faces = np.sort(t[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    return counts.max() <= 2


@pytest.mark.parametrize("name", ["sphere.obj", "torus.obj", "hollow_sphere.obj"])
def test_radius_body_tets_fill_the_mesh_inside_without_inversion(name):
    igl = pytest.importorskip("igl")
    mesh = load_mesh(mesh_path(name))
    body = build_body(mesh, points=3000, connect="radius", seed=1)
    assert body.point_count == 3000  # no orphan dropped on these shapes
    tets = np.asarray(body.tets)
    vol = tet_signed_volumes(body.points, tets)
    assert np.all(vol > 0)  # positively oriented: none inverted
    covered = np.zeros(body.point_count, dtype=bool)
    covered[tets.ravel()] = True
    assert covered.all()  # every point gets elastic force and mass from some tet
    assert tet_quality(body.points, tets).min() >= 0.01  # slivers dropped
    assert _faces_shared_by_at_most_two(tets)  # a conforming tet mesh (a Delaunay subset)
    # carving: every tet's centroid inside the surface (independent inside test: libigl)
    cent = body.points[tets].mean(axis=1)
    assert np.all(igl.winding_number(mesh.vertices, mesh.faces, cent) > 0.5)
    # the tets fill the surface up to a skin one spacing thick: the hull of random points
    # (and, for the torus and the cavity, the carved concave parts) stays a little inside
    assert body.meta["tet_volume"] == pytest.approx(float(np.sum(vol)))
    assert 0.85 * body.volume < np.sum(vol) < body.volume
    # the springs stay the radius springs, the masses the even split
    assert np.array_equal(body.springs, radius_springs(body.points, body.meta["radius"]))
    assert body.masses is None


def test_cube_tet_volume_converges_to_the_mesh_volume():
    cube = load_mesh(mesh_path("cube.obj"))  # [-1, 1]^3, volume 8
    fractions = []
    for n in (2000, 16000):
        body = build_body(cube, points=n, connect="radius", seed=0)
        assert body.volume == pytest.approx(8.0)
        fractions.append(body.meta["tet_volume"] / body.volume)
    # the missing skin (hull slivers and the gap between the hull and the faces) thins
    # like the point spacing: 93 % at 2,000 points, 97 % at 16,000
    assert 0.91 < fractions[0] < fractions[1] < 1.0
    assert fractions[1] > 0.96


def test_calibration_and_masses_ignore_the_radius_tets():
    cube = load_mesh(mesh_path("cube.obj"))
    body = build_body(cube, points=1500, connect="radius", seed=2)
    bare = replace(body, tets=None)
    k = calibrate_springs(body, 1e4)
    assert np.array_equal(k, calibrate_springs(bare, 1e4))
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2):  # same result for any thread count
        assert np.array_equal(k, calibrate_springs(body, 1e4))
    assert np.array_equal(point_masses(body, 1141.0), point_masses(bare, 1141.0))
    m = point_masses(body, 1141.0)
    assert np.allclose(m, 1141.0 * 8.0 / body.point_count)  # density x volume, split evenly


def test_same_seed_same_tets():
    a = build_body(mesh_path("spot.obj"), points=800, connect="radius", seed=4)
    b = build_body(mesh_path("spot.obj"), points=800, connect="radius", seed=4)
    assert np.array_equal(a.tets, b.tets)


@pytest.mark.parametrize("distribution,fill", [("edge", 0.97), ("uniform", 0.9),
                                               ("grid", 0.999)])
def test_scene_box_field_radius_body_has_tets(distribution, fill):
    scene = Scene.from_text(f"""
[body]
type = "box"
points = 1000
distribution = "{distribution}"
lower = [0.0, 0.0, 0.0]
upper = [0.1, 0.2, 0.1]
seed = 3
[springs]
connect = "radius"
radius = 0.03
[material]
youngs_modulus = 1e4
density = 1141.0
[integrator]
name = "implicit"
dt = 0.01
steps = 1
""")
    body = scene.build_body()
    vol = tet_signed_volumes(body.points, body.tets)
    assert np.all(vol > 0)
    assert np.unique(np.asarray(body.tets)).size == body.point_count  # no orphan
    assert distribution == "grid" or body.point_count == 1000
    # a box is convex: nothing carved; a grid's tets fill it exactly (its points include
    # the corners), random fields up to a thin skin
    if distribution == "grid":  # the lattice's own Kuhn tets (scene.build_body)
        assert "cloud_tets" not in body.meta and len(body.tets) == 6 * (len(
            np.unique(body.points[:, 0])) - 1) * (len(np.unique(body.points[:, 1])) - 1) * (
            len(np.unique(body.points[:, 2])) - 1)
    else:
        assert body.meta["cloud_tets"]["outside_removed"] == 0
    assert fill * 0.002 <= vol.sum() <= 0.002 * (1 + 1e-9)
    assert np.array_equal(body.springs, radius_springs(body.points, 0.03))
    # the radius springs are calibrated as a point cloud (a grid: its cells' point volumes)
    model = scene.build_model(body)
    assert model.point_count == body.point_count


def test_cloud_tets_orphans_are_readmitted_or_reported():
    rng = np.random.default_rng(5)
    pts = np.concatenate([rng.random((300, 3)), [[5.0, 0.5, 0.5]]])
    inside = (lambda q: q[:, 0] < 1.0)  # the far point's tets all have centroid x > 5/4
    tets, orphans, info = cloud_tets(pts, inside)
    covered = np.zeros(len(pts), dtype=bool)
    covered[tets.ravel()] = True
    assert np.array_equal(orphans, ~covered)
    assert np.flatnonzero(orphans).tolist() == [300] and info["orphans"] == 1
    assert np.all(inside(pts[tets].mean(axis=1)))
    # slivers: with a (far too) strict threshold most tets are dropped, and the points they
    # leave alone each get their best remaining tet back
    tets9, orphans9, info9 = cloud_tets(pts[:300], min_quality=0.9)
    assert info9["slivers_removed"] > 0.9 * info9["delaunay_tets"]
    assert info9["orphans_readmitted"] > 0 and not orphans9.any()
    assert tet_quality(pts, tets9).min() >= 0.01
    assert np.all(tet_signed_volumes(pts, tets9) > 0)
    # the builder keeps the orphan (the body has the points asked for) and counts it
    kept, t, info_b = _radius_tets(pts, inside)
    assert len(kept) == 301 and np.array_equal(kept, pts) and info_b["orphans"] == 1
    assert 300 not in t and np.all(tet_signed_volumes(kept, t) > 0)


def test_radius_tets_of_a_thin_surface_raise_a_clear_error():
    flat = np.random.default_rng(0).random((50, 3))
    flat[:, 2] = 0.0
    from jellysim.errors import BuildError

    with pytest.raises(BuildError, match="tets of the radius body: no well-shaped tet"):
        _radius_tets(flat, None, name="flat")
