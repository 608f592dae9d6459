"""One body across MPI ranks (jellysim.distributed, docs/mpi.md).

In-process tests check the partition, the ghost layers and the local models (no MPI needed:
the ranks are emulated in one process, exchanging ghosts by copying); the subprocess tests run
``mpiexec -n 2`` and ``-n 3`` (the MPICH wheel of the ``[mpi]`` extra) and compare the
trajectories with serial runs bit for bit.
"""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import shortest_path

import jellysim
from jellysim.distributed import (LocalPart, halo_depth, halo_layers, partition_points,
                                  point_graph, replicated_reason)
from jellysim.errors import SceneError, SimulationError
from jellysim.io.trajectory import load_trajectory
from jellysim.params import GroundParams, ProvotParams
from jellysim.physics.contact import Sphere
from jellysim.runner import run_scene
from jellysim.scene import Scene
from jellysim.simulator import Simulator
from jellysim.state import State

from conftest import make_box_model

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data" / "mpi"
MPIEXEC = Path(sys.executable).parent / "mpiexec"
HAVE_MPI = importlib.util.find_spec("mpi4py") is not None and MPIEXEC.exists()
needs_mpi = pytest.mark.skipif(not HAVE_MPI, reason="the [mpi] extra (mpi4py, mpich) is not "
                               "installed; .ci/run installs it")


# -- partition and ghost layers ----------------------------------------------------------------
@pytest.mark.parametrize("method", ["morton", "metis"])
def test_partition_gives_each_point_one_balanced_owner(method):
    m = make_box_model(1000)
    for parts in (2, 3, 5):
        owner = partition_points(m.point_x0, m.spring_ij, parts, method=method)
        counts = np.bincount(owner, minlength=parts)
        assert owner.shape == (1000,) and counts.sum() == 1000 and counts.min() > 0
        if method == "morton":  # contiguous Z-order ranges of equal size
            assert counts.max() - counts.min() <= 1
        else:  # METIS' default imbalance tolerance is 3 %
            assert counts.max() <= 1.03 * 1000 / parts + 1


def test_halo_layers_are_the_hop_distance_shells_of_the_spring_graph():
    m = make_box_model(400)
    n = m.point_count
    owner = partition_points(m.point_x0, m.spring_ij, 3)
    xadj, adjncy = point_graph(n, m.spring_ij)
    ij = m.spring_ij
    graph = coo_matrix((np.ones(len(ij)), (ij[:, 0], ij[:, 1])), shape=(n, n))
    for rank in range(3):
        hops = shortest_path(graph, directed=False, unweighted=True,
                             indices=np.flatnonzero(owner == rank)).min(axis=0)
        for d, layer in enumerate(halo_layers(owner, rank, xadj, adjncy, 3), start=1):
            assert np.array_equal(layer, np.flatnonzero(hops == d))


def test_local_model_keeps_the_global_order_of_every_owned_points_springs():
    m = make_box_model(500)
    owner = partition_points(m.point_x0, m.spring_ij, 3)
    part = LocalPart(m, owner, 1, 2)
    lm, g = part.model, part.glob
    assert np.all(np.diff(g) > 0)  # local numbering is monotone in the global one
    for p_local in part.owned_local[::7]:
        p = g[p_local]
        glob_first = m.spring_ij[m.point_first_ptr[p]:m.point_first_ptr[p + 1], 1]
        loc_first = lm.spring_ij[lm.point_first_ptr[p_local]:lm.point_first_ptr[p_local + 1], 1]
        assert np.array_equal(g[loc_first], glob_first)
        glob_second = m.point_second_other[m.point_second_ptr[p]:m.point_second_ptr[p + 1]]
        loc_second = lm.point_second_other[
            lm.point_second_ptr[p_local]:lm.point_second_ptr[p_local + 1]]
        assert np.array_equal(g[loc_second], glob_second)


def test_configurations_that_cannot_be_split_are_named():
    assert replicated_reason("implicit", ProvotParams(enabled=False)) is None  # split: CG
    assert "all" in replicated_reason("paper", ProvotParams(pairs="all"))
    assert "gauss" in replicated_reason("paper", ProvotParams(order="gauss-seidel"))
    assert replicated_reason("paper", ProvotParams(tolerance=1e-6)) is not None
    # Jacobi's momentum shift sums over the whole body each pass
    assert "jacobi" in replicated_reason("symplectic", ProvotParams(loops=4))
    assert replicated_reason("symplectic", ProvotParams(enabled=False)) is None
    assert halo_depth("paper", ProvotParams(loops=3)) == 3
    assert halo_depth("paper", ProvotParams(enabled=False)) == 1
    assert halo_depth("symplectic", ProvotParams(loops=3)) == 4


def _emulated(model, parts, depth, steps, method="morton", **kw):
    """P ranks in one process: local Simulators stepped one step at a time, ghosts copied
    from their owners after each step (what DistributedSimulator does with Isend/Irecv)."""
    owner = partition_points(model.point_x0, model.spring_ij, parts, method=method)
    start = model.state()
    ranks = [LocalPart(model, owner, r, depth) for r in range(parts)]
    for r, part in enumerate(ranks):
        for q, wanted in part.needs().items():
            ranks[q].set_send(r, wanted)
    sims = []
    for part in ranks:
        g = part.glob
        s = Simulator(part.model, state=State(start.x[g].copy(), start.v[g].copy(),
                                              start.a[g].copy()),
                      check_stability=False, runaway_distance=1e3, **kw)
        s.center[:] = model.point_x0.mean(axis=0)
        sims.append(s)
    for _ in range(steps):
        for s in sims:
            s.advance(1)
        for r, part in enumerate(ranks):
            for q, idx in part.recv.items():
                buf = np.empty((len(idx), 9))
                LocalPart.pack(sims[q].state, ranks[q].send[r], buf)
                part.unpack(sims[r].state, idx, buf)
    x = np.full((model.point_count, 3), np.nan)
    for part, s in zip(ranks, sims):
        x[part.glob[part.owned]] = s.state.x[part.owned]
    return x


@pytest.mark.parametrize("integrator,loops,parts,method", [
    ("paper", 0, 2, "morton"), ("paper", 0, 4, "metis"), ("symplectic", 0, 3, "morton"),
    ("symplectic", 0, 5, "metis")])
def test_emulated_ranks_equal_serial_bitwise(integrator, loops, parts, method):
    m = make_box_model(500, stiffness=300.0, damping=0.8, point_mass=0.2,
                       lower=(0, 0.2, 0), upper=(1, 1.2, 1), distribution="edge")
    kw = dict(dt=0.002, integrator=integrator, ground=GroundParams(),
              provot=ProvotParams(enabled=loops > 0, loops=max(loops, 1), tau=0.01),
              obstacles=(Sphere(center=(0.5, -0.01, 0.5), radius=0.2),))  # top: 0.19 m
    serial = Simulator(m, check_stability=False, runaway_distance=1e3, **kw)
    serial.advance(90)
    assert serial.state.x[:, 1].min() < 0.15  # it fell onto the sphere and the ground
    depth = halo_depth(integrator, kw["provot"])
    x = _emulated(m, parts, depth, 90, method=method, **kw)
    assert np.array_equal(x, serial.state.x)
    # (with Provot the runs are replicated: Jacobi's momentum shift sums over the whole body)


def test_distributed_package_imports_without_mpi4py():
    code = ("import sys, jellysim.distributed, jellysim.cli; "
            "assert 'mpi4py' not in sys.modules and 'pymetis' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, env=_env())


# -- real MPI ranks ------------------------------------------------------------------------------
def _env():
    env = dict(os.environ)
    src = str(Path(jellysim.__file__).resolve().parents[1])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    env["NUMBA_NUM_THREADS"] = "1"
    return env


def _mpirun(n, *args, timeout=120, env=None):
    t0 = time.perf_counter()
    proc = subprocess.run([str(MPIEXEC), "-n", str(n), sys.executable, *args],
                          capture_output=True, text=True, env={**_env(), **(env or {})},
                          timeout=timeout,
                          cwd=ROOT)
    return proc, time.perf_counter() - t0


def _serial(scene_path, out, steps=None):
    run_scene(Scene.load(scene_path), out, progress=False, vtu=False, steps=steps)
    return load_trajectory(out / "trajectory.npz")


@needs_mpi
@pytest.mark.parametrize("scene,ranks", [("paper_springs", 2), ("symplectic_contact", 3),
                                         ("paper_cube", 2), ("paper_springs_split", 2),
                                         ("symplectic_contact_split", 3)])
def test_mpiexec_run_is_bitwise_equal_to_serial(tmp_path, scene, ranks):
    path = (ROOT / "examples" / "paper_cube.toml" if scene == "paper_cube"
            else DATA / f"{scene.removesuffix('_split')}.toml")
    if scene.endswith("_split"):  # Provot off: split among the ranks (with it, replicated)
        text = path.read_text().replace("[provot]", "[provot]\nenabled = false")
        path = tmp_path / path.name
        path.write_text(text)
    steps = ["--steps", "30"] if scene == "paper_cube" else []  # O(n^2) Provot on each rank
    ref = _serial(path, tmp_path / "serial", 30 if steps else None)
    proc, _ = _mpirun(ranks, "-m", "jellysim.cli", "run", str(path), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--no-vtu", *steps)
    assert proc.returncode == 0, proc.stderr
    assert f"on {ranks} ranks" in proc.stdout and proc.stdout.count("wrote") == 1  # rank 0
    assert ("whole body" in proc.stderr) != scene.endswith("_split")
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert got.positions.shape == ref.positions.shape
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)
    assert np.array_equal(got.times, ref.times) and np.array_equal(got.steps, ref.steps)


@needs_mpi
def test_mpiexec_run_takes_the_command_lines_overrides(tmp_path):
    """Session 11's trial: under mpiexec `run` dropped `--set` (and --threads, --backend): it
    ran the scene as written.  The overrides now apply: bitwise the serial run of the
    overridden scene, which differs from the scene as written; --resume, not done under
    mpiexec, is refused once, by rank 0, instead of starting a new run."""
    path = DATA / "paper_springs.toml"
    sets = ("provot.loops=1", "physics.damping=0.2", "integrator.steps=40")
    ref_dir, plain_dir = tmp_path / "serial", tmp_path / "plain"
    run_scene(Scene.load(path, overrides=sets), ref_dir, progress=False, vtu=False)
    run_scene(Scene.load(path, overrides=("integrator.steps=40",)), plain_dir, progress=False,
              vtu=False)
    ref, plain = (load_trajectory(d / "trajectory.npz") for d in (ref_dir, plain_dir))
    assert not np.array_equal(ref.positions, plain.positions)
    args = [a for s in sets for a in ("--set", s)]
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(path), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--threads", "1", *args)
    assert proc.returncode == 0, proc.stderr
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)
    assert not list((tmp_path / "mpi").glob("*.vtu"))  # the scene's vtu = false kept
    assert "more busy threads than cores" not in proc.stderr
    # HPC trial (session 27): 2 ranks x 2 threads on a 2-core node ran 4 busy threads on 2
    # cores and said nothing; now said (the same trajectory: threads never change it)
    cores = os.cpu_count()
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(path), "--out", str(tmp_path / "o"),
                      "--quiet", "--threads", str(cores), *args,
                      env={"NUMBA_NUM_THREADS": str(cores)})
    assert proc.returncode == 0, proc.stderr
    assert cores < 2 or (f"2 ranks x {cores} threads on a node of {cores} cores: more busy "
                         "threads than cores") in proc.stderr
    assert proc.stderr.count("more busy threads") == (cores >= 2)
    assert np.array_equal(load_trajectory(tmp_path / "o" / "trajectory.npz").positions,
                          ref.positions)
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(path), "--resume",
                      str(tmp_path / "mpi"), "--steps", "60", "--quiet")
    assert proc.returncode == 2 and proc.stderr.count("error:") == 1
    assert "--resume" in proc.stderr and "not done under mpiexec" in proc.stderr
    assert np.array_equal(load_trajectory(tmp_path / "mpi" / "trajectory.npz").positions,
                          got.positions)


@needs_mpi
def test_mpiexec_refuses_a_body_starting_inside_an_obstacle_or_the_ground(tmp_path):
    """The session 11 review: the serial checks of a starting body (inside an obstacle, below
    the ground) were skipped under mpiexec, which ran what a serial run refuses.  Both are
    refused once, by rank 0, as serially, and nothing is written."""
    text = (DATA / "paper_springs.toml").read_text()
    inside = text.replace("center = [0.5, 0.05, 0.5]", "center = [0.5, 0.8, 0.5]")
    below = text.replace("lower = [0.0, 0.3, 0.0]", "lower = [0.0, -0.05, 0.0]").replace(
        "upper = [1.0, 1.3, 1.0]", "upper = [1.0, 0.95, 1.0]").replace(
        "center = [0.5, 0.05, 0.5]", "center = [3.0, 0.05, 0.5]")
    for name, body, match in (("inside", inside, "start inside this obstacle"),
                              ("below", below, "below the ground")):
        scene = tmp_path / f"{name}.toml"
        scene.write_text(body)
        with pytest.raises(SceneError, match=match):
            Scene.load(scene).simulator()
        proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(scene), "--out",
                          str(tmp_path / name), "--quiet")
        assert proc.returncode == 2 and proc.stderr.count("error:") == 1, proc.stderr
        assert match in proc.stderr and f"{scene}:" in proc.stderr  # naming the scene
        assert not (tmp_path / name).exists()  # (no empty folder left either)


@needs_mpi
def test_mpiexec_counts_the_springs_auto_substeps_like_serial(tmp_path):
    """substeps = 'auto' on the springs' symplectic path: every rank takes the substep count
    the serial run takes (from the global model's stability estimate), bitwise the same run."""
    text = (DATA / "symplectic_contact.toml").read_text().replace("substeps = 2\n", "")
    scene = tmp_path / "auto.toml"
    scene.write_text(text.replace("dt = 0.004", "dt = 0.016").replace("steps = 80", "steps = 24"))
    assert Scene.load(scene).simulator().substeps == 5  # 0.016 s is beyond the stable step
    ref = _serial(scene, tmp_path / "serial")
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(scene), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--no-vtu")
    assert proc.returncode == 0, proc.stderr
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)


@needs_mpi
def test_mpiexec_blow_up_is_agreed_by_all_ranks_at_the_serial_step(tmp_path):
    text = (DATA / "symplectic_contact.toml").read_text()
    text = text.replace("dt = 0.004", "dt = 0.05").replace("substeps = 2", "substeps = 1")
    text = text.replace("loops = 2", "loops = 1").replace("[provot]", "[provot]\nenabled = false")
    scene = tmp_path / "blowup.toml"
    scene.write_text(text)
    with pytest.raises(SimulationError) as serial:
        run_scene(Scene.load(scene), tmp_path / "serial", progress=False, vtu=False)
    proc, _ = _mpirun(3, "-m", "jellysim.cli", "run", str(scene), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--no-vtu")
    assert proc.returncode == 2
    assert proc.stderr.count("error:") == 1  # printed once, by rank 0
    assert f"went unstable at step {serial.value.step} " in proc.stderr
    # more ranks than cores is said (the re-trial: -n 3 on 2 cores, unsaid)
    assert (os.cpu_count() >= 3) == ("3 ranks on a node of" not in proc.stderr)
    ref = load_trajectory(tmp_path / "serial" / "trajectory.npz")
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert got.status.startswith("failed") and np.array_equal(got.positions, ref.positions)


@needs_mpi
@pytest.mark.parametrize("mode", ["raise", "kill"])
def test_a_failing_rank_ends_the_job_with_a_clear_error_not_a_hang(tmp_path, mode):
    import xml.etree.ElementTree as ET

    scene = tmp_path / "scene.toml"
    # Provot off: a split run (with Provot every rank runs the whole body, without the
    # per-frame exchanges that keep rank 1 from racing ahead of rank 0's writes)
    scene.write_text((DATA / "paper_springs.toml").read_text().replace(
        "vtu = false", "vtu = true").replace("[provot]", "[provot]\nenabled = false"))
    out = tmp_path / "out"
    proc, seconds = _mpirun(2, str(DATA / "fail_rank.py"), mode, str(scene), str(out),
                            timeout=60)
    assert proc.returncode != 0
    assert seconds < 30
    if mode == "raise":
        assert "rank 1 of 2: MemoryError: injected failure" in proc.stderr
    else:
        assert "BAD TERMINATION" in proc.stdout + proc.stderr
    # the frames rank 0 finished before the failure (at least two: rank 1 fails at its third
    # frame, possibly while rank 0 still writes the second) stay readable
    frames = ET.parse(out / "body.pvd").getroot().findall(".//DataSet")
    assert len(frames) >= 2
    for f in frames:
        assert ET.parse(out / f.get("file")).getroot().tag == "VTKFile"


@needs_mpi
def test_an_interrupted_mpi_run_ends_every_rank_and_keeps_its_frames(tmp_path):
    """Session 15's trial: Ctrl-C under mpiexec left one rank spinning in Allreduce for ever
    and no trajectory.  Now rank 0 saves the frames so far (status 'interrupted') and the job
    ends, every rank, with a line that says what is left."""
    scene = tmp_path / "scene.toml"
    scene.write_text((DATA / "paper_springs.toml").read_text().replace(
        "[provot]", "[provot]\nenabled = false"))
    out = tmp_path / "out"
    proc, seconds = _mpirun(2, str(DATA / "fail_rank.py"), "interrupt", str(scene), str(out),
                            timeout=60)
    # session 20's trial: the job ended by MPI_Abort (its own lines after ours), the line said
    # "run it again to finish" where a re-run is refused without --overwrite, and a later
    # `--resume` said "the run has finished (it failed, or an older jellysim wrote it)".  The
    # ranks now agree at the next frame to stop: exit 130, no abort, the frames up to it kept
    assert proc.returncode == 130 and seconds < 30
    assert "interrupted at step 30 of" in proc.stderr and "on 2 ranks" in proc.stderr
    assert "run it again with --overwrite to start afresh" in proc.stderr
    assert "MPI_Abort" not in proc.stdout + proc.stderr
    got = load_trajectory(out / "trajectory.npz")
    assert got.status.startswith("interrupted at step 30 of")
    assert len(got.times) == 4  # the start and the three frames up to the interrupt's
    np.testing.assert_array_equal(got.steps, [0, 10, 20, 30])
    resume = subprocess.run([sys.executable, "-m", "jellysim.cli", "run", str(scene),
                             "--resume", str(out)], capture_output=True, text=True, timeout=60)
    assert resume.returncode != 0
    assert "interrupted under mpiexec at step 30" in resume.stderr
    assert "--overwrite" in resume.stderr and "older jellysim" not in resume.stderr
    again = subprocess.run([sys.executable, "-m", "jellysim.cli", "run", str(scene), "--out",
                            str(out)], capture_output=True, text=True, timeout=60)
    assert again.returncode != 0 and "pass --overwrite" in again.stderr
    assert "a run interrupted under mpiexec at step 30 (no checkpoint: it cannot be " \
        "resumed)" in again.stderr
    # a second Ctrl-C does not wait for the frame: the job is aborted, the frames still kept
    out2 = tmp_path / "out2"
    proc, seconds = _mpirun(2, str(DATA / "fail_rank.py"), "interrupt-twice", str(scene),
                            str(out2), timeout=60)
    assert proc.returncode != 0 and seconds < 30
    assert "interrupted: the run stopped; its frames so far are in" in proc.stderr
    got = load_trajectory(out2 / "trajectory.npz")
    assert got.status.startswith("interrupted at step") and len(got.times) == 3
    # HPC trial (session 27): a Ctrl-C while rank 0 writes the frames, which only its memory
    # holds (1.5 s at 700 frames), ended the job with no trajectory.npz: the save now finishes
    for mode, code, status, frames in (("interrupt-saving", 130, "interrupted at step 30", 4),
                                       ("finish-saving", 0, "complete", None)):
        where = tmp_path / mode
        proc, seconds = _mpirun(2, str(DATA / "fail_rank.py"), mode, str(scene), str(where),
                                timeout=60)
        assert proc.returncode == code and seconds < 30, (mode, proc.stderr)
        got = load_trajectory(where / "trajectory.npz")
        assert got.status.startswith(status), (mode, got.status)
        assert frames is None or len(got.times) == frames
        assert "MPI_Abort" not in proc.stdout + proc.stderr
    # one while rank 0 builds the body (the others wait for it): every rank told, exit 130,
    # no MPI_Abort, no folder left (session 21's trial: "run it again with --overwrite")
    out3 = tmp_path / "out3"
    proc, seconds = _mpirun(2, str(DATA / "fail_rank.py"), "interrupt-build", str(scene),
                            str(out3), timeout=60)
    assert proc.returncode == 130 and seconds < 30, proc.stderr
    assert "stopped before its first frame; nothing was written" in proc.stderr
    assert "MPI_Abort" not in proc.stdout + proc.stderr and not out3.exists()


@needs_mpi
def test_a_bad_scene_under_mpiexec_is_one_clear_error(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text((DATA / "paper_springs.toml").read_text().replace("loops = 3",
                                                                        "loopz = 3"))
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(scene), "--out", str(tmp_path / "o"))
    assert proc.returncode == 2
    assert proc.stderr.count("error:") == 1 and "[provot] unknown key 'loopz'" in proc.stderr


# -- the physical (FEM) path ---------------------------------------------------------------------
def _gelatin_model():
    return Scene.load(DATA / "gelatin_drop.toml").build_model()


@pytest.mark.parametrize("parts,method", [(2, "morton"), (3, "metis")])
def test_fem_local_parts_hold_every_tet_of_their_points_in_the_serial_gather_order(parts, method):
    from jellysim.distributed.fem import coupling_pairs, local_fem

    m = _gelatin_model()
    fem, n = m.fem, m.point_count
    owner = partition_points(m.point_x0, coupling_pairs(m), parts, method=method)
    covered = np.zeros(fem.tet_count, dtype=int)
    for rank in range(parts):
        part = LocalPart(m, owner, rank, 1, graph=point_graph(n, coupling_pairs(m)))
        lf, sel = local_fem(fem, part.glob, owner == rank)
        covered[sel] += 1
        assert np.array_equal(part.glob[lf.tets], fem.tets[sel])  # same tets, same corners
        assert np.array_equal(lf.rest_inverse, fem.rest_inverse[sel])
        for p_local in part.owned_local:  # an owned point's corner slots: the serial list
            p = part.glob[p_local]
            mine = lf.point_tet_slot[lf.point_tet_ptr[p_local]:lf.point_tet_ptr[p_local + 1]]
            ref = fem.point_tet_slot[fem.point_tet_ptr[p]:fem.point_tet_ptr[p + 1]]
            assert np.array_equal(4 * sel[mine // 4] + mine % 4, ref)
        # a ghost is a corner of a local tet; every local point is owned or such a corner
        assert np.array_equal(np.unique(lf.tets), np.arange(part.glob.size))
    # every tet is held by the ranks owning its corners, and only by them
    assert np.array_equal(covered, [len(set(owner[t])) for t in fem.tets])
    assert covered.max() > 1  # tets on a partition boundary are computed redundantly


@needs_mpi
@pytest.mark.parametrize("scene,ranks,partition", [("gelatin_drop", 2, "morton"),
                                                   ("gelatin_drop", 3, "metis"),
                                                   ("gelatin_handles", 3, "morton")])
def test_mpiexec_physical_path_is_bitwise_equal_to_serial(tmp_path, scene, ranks, partition):
    path = DATA / f"{scene}.toml"
    ref = _serial(path, tmp_path / "serial")
    proc, _ = _mpirun(ranks, "-m", "jellysim.cli", "run", str(path), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--no-vtu", "--partition", partition)
    assert proc.returncode == 0, proc.stderr
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert got.positions.shape == ref.positions.shape
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)
    assert np.array_equal(got.times, ref.times)
    x = ref.positions
    if scene == "gelatin_drop":  # it fell onto the ground and hit the sphere it slid
        assert x[0, :, 1].min() > 0.009 and x[-1, :, 1].min() < 1e-9  # towards, which pushed
        mean_x = x[:, :, 0].mean(axis=1)  # it back (-x) although it started moving +x
        assert mean_x[-1] < mean_x.max() - 0.01
        d = np.linalg.norm(x - np.array([0.09, -0.02, 0.03]), axis=2)
        assert d.min() > 0.04 - 1e-9 and d.min(axis=1)[0] > 0.041  # started apart, never inside
        assert np.any(d.min(axis=1) < 0.04 + 1e-6)  # touched (within a micron)
    else:  # the pinned top face followed its path: 2 cm right by t = 0.1 s
        top = x[0, :, 1] > 0.105
        t = ref.times
        want = np.interp(t, [0.0, 0.1, 0.2], [0.0, 0.02, 0.02])
        assert np.allclose(x[:, top, 0] - x[0, top, 0], want[:, None], atol=1e-12)


@needs_mpi
def test_mpiexec_pin_and_drag_gauges_read_what_the_serial_simulator_reads():
    """``pin_force()`` / ``drag_force()`` under MPI (a collective call) were a refusal that
    never ran (defined outside the class: the serial method then indexed the local arrays
    with global tets, IndexError).  Each rank now sums its owned points' forces, whole on it:
    on a hanging, dragged, wobbling gelatin cube split over 3 ranks the readings equal the
    serial ones to rounding (the states are bitwise equal), and they are the body's load:
    the pins carry the weight and the pull, give or take the wobble's inertia.  ``energy()``
    and ``volume_ratios()`` (a traceback under MPI before session 24) are refused by name on
    every rank (the script exits non-zero otherwise)."""
    import json

    proc, _ = _mpirun(3, str(DATA / "gauges_check.py"), timeout=240)
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["ranks"] == 3 and r["same_state"]
    assert r["pin_error"] <= 1e-12 * r["weight"] and r["drag_error"] <= 1e-12 * r["weight"]
    pin, drag = np.array(r["pin_serial"]), np.array(r["drag_serial"])
    assert drag[1] < -0.05 * r["weight"]            # the spring pulls the corner down
    assert pin[1] > 0.5 * r["weight"]               # the pins hold the body up


@needs_mpi
def test_mpiexec_physical_path_retries_an_unstable_impact_like_serial(tmp_path):
    # 8 substeps per frame where 72 are needed: the impact blows up and the frames are taken
    # again with 16, then 32 substeps (serially too); every rank must agree on each retry
    scene = tmp_path / "retry.toml"
    scene.write_text((DATA / "gelatin_drop.toml").read_text().replace(
        "steps = 14", "steps = 14\nsubsteps = 8"))
    said = run_scene(Scene.load(scene), tmp_path / "serial", progress=False, vtu=False).warnings
    assert sum("again with 32 substeps per frame" in w for w in said) == 1
    ref = load_trajectory(tmp_path / "serial" / "trajectory.npz")
    proc, _ = _mpirun(3, "-m", "jellysim.cli", "run", str(scene), "--out",
                      str(tmp_path / "mpi"), "--quiet", "--no-vtu")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("again with 32 substeps per frame") == 1  # said once, by rank 0
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz")
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)


# -- the implicit integrator, split among ranks ----------------------------------------------
@needs_mpi
@pytest.mark.parametrize("scheme,ranks,where", [("theta", 2, "lean"), ("bdf2", 3, "full")])
def test_mpiexec_implicit_solve_is_split_and_agrees_with_serial_within_the_cg_tolerance(
        scheme, ranks, where):
    import json

    tol = 1e-6
    proc, _ = _mpirun(ranks, str(DATA / "implicit_check.py"), scheme, str(tol), where)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert got["lean"] == (where == "lean")
    assert got["others_hold_global"] == (where == "full")  # lean: only rank 0 holds the body
    assert 0 < got["owned"] < got["owned_total"] == 500 and got["ghosts"] > 0  # split
    assert got["travel"] > 0.1  # the body vibrated and turned: every step a real solve
    # dot products summed in another order: the same solution to within the CG tolerance
    assert got["rel_error"] < tol and got["v_rel_error"] < tol
    assert abs(got["cg_iterations"] - got["serial_cg_iterations"]) <= 0.02 * got[
        "serial_cg_iterations"]


@needs_mpi
def test_mpiexec_implicit_scene_with_contact_runs_split(tmp_path):
    path = DATA / "implicit_springs.toml"
    ref = _serial(path, tmp_path / "serial")
    proc, _ = _mpirun(2, "-m", "jellysim.cli", "run", str(path), "--out", str(tmp_path / "mpi"),
                      "--quiet", "--no-vtu")
    assert proc.returncode == 0, proc.stderr
    assert "whole body" not in proc.stderr  # split among the ranks, not replicated
    got = load_trajectory(tmp_path / "mpi" / "trajectory.npz").positions
    x = ref.positions
    assert got.shape == x.shape
    flying = x[:, :, 1].min(axis=1) > 0.01  # before the landing: equal to the CG tolerance
    assert flying.sum() >= 3
    assert np.abs(got[flying] - x[flying]).max() < 1e-6 * np.abs(x - x[0]).max()
    # a contact event amplifies rounding (serially too: CG tolerance 1e-8 vs 1e-12 moves points
    # by centimetres after this landing), so afterwards: the same physics, not the same digits
    assert got[:, :, 1].min() > -1e-12 and got[-1, :, 1].min() < 1e-9  # landed, never below


@needs_mpi
def test_mpiexec_run_refuses_a_folder_a_live_run_holds(tmp_path):
    """Under mpiexec rank 0 claims the output folder as a serial run does: a live run's lock
    (this test process) makes every rank stop with one clear error, nothing written; once the
    lock is gone the run goes through and leaves none behind."""
    import socket

    from jellysim.io.lock import LOCK_NAME

    out = tmp_path / "o"
    out.mkdir()
    lock = out / LOCK_NAME
    lock.write_text(f"{os.getpid()} {socket.gethostname()}\n")
    args = ("-m", "jellysim.cli", "run", str(DATA / "paper_springs.toml"), "--out", str(out),
            "--quiet", "--no-vtu", "--steps", "4")
    proc, _ = _mpirun(2, *args)
    assert proc.returncode != 0
    assert proc.stderr.count("error:") == 1 and f"(process {os.getpid()})" in proc.stderr
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]
    lock.unlink()
    proc, _ = _mpirun(2, *args)
    assert proc.returncode == 0, proc.stderr
    assert (out / "trajectory.npz").exists() and not lock.exists()


@needs_mpi
def test_mpiexec_run_refuses_an_earlier_run_unless_overwrite(tmp_path):
    """As a serial run: under mpiexec a folder holding an earlier run is refused (one error,
    nothing touched); with --overwrite that run's files go first."""
    out = tmp_path / "o"
    args = ("-m", "jellysim.cli", "run", str(DATA / "paper_springs.toml"), "--out", str(out),
            "--quiet", "--steps", "{}")
    proc, _ = _mpirun(2, *[a.format(8) for a in args])
    assert proc.returncode == 0, proc.stderr
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    proc, _ = _mpirun(2, *[a.format(4) for a in args])
    assert proc.returncode != 0 and proc.stderr.count("error:") == 1
    assert "holds an earlier run" in proc.stderr and "--overwrite" in proc.stderr
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    proc, _ = _mpirun(2, *[a.format(4) for a in args], "--overwrite")
    assert proc.returncode == 0, proc.stderr
    assert load_trajectory(out / "trajectory.npz").steps[-1] == 4  # the new run's


@needs_mpi
def test_mpiexec_blow_up_into_the_ground_and_an_obstacle_is_agreed_not_a_hang(tmp_path):
    """The HPC trial: a blow-up on a springs body with a contact ground and a sphere
    obstacle hung `mpiexec -n 3` (two ranks in MPI_Finalize, the third spinning in Allreduce
    for ten minutes, Ctrl-C ignored) and with -n 2 said "points are below the ground ...
    moved there from outside" with no trajectory.  The check of a state moved by hand ran on
    each rank's own simulator, whose ghost points the exchange writes: a neighbour's blown-up
    points tripped it on one rank only.  Now the job fails as the serial run does, at the
    same step, with the same failed trajectory."""
    scene = tmp_path / "blow.toml"
    scene.write_text("""[body]
type = "box"
points = 3000
distribution = "uniform"
lower = [0.0, 0.2, 0.0]
upper = [1.0, 1.2, 1.0]
seed = 3
[springs]
radius = 0.15
stiffness = 1e5
[mass]
density = 100.0
[physics]
damping = 0.5
[integrator]
name = "symplectic"
dt = 0.01
substeps = 1
steps = 200
[provot]
enabled = false
[ground]
model = "contact"
restitution = 0.3
friction = 0.5
[[obstacle]]
kind = "sphere"
center = [0.5, -0.1, 0.5]
radius = 0.25
[output]
every = 10
""")
    with pytest.raises(SimulationError) as serial:
        run_scene(Scene.load(scene), tmp_path / "serial", progress=False, vtu=False)
    for ranks in (2, 3):
        proc, _ = _mpirun(ranks, "-m", "jellysim.cli", "run", str(scene), "--out",
                          str(tmp_path / f"mpi{ranks}"), "--quiet", "--no-vtu", timeout=100)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.count("error:") == 1
        assert f"went unstable at step {serial.value.step} " in proc.stderr
        got = load_trajectory(tmp_path / f"mpi{ranks}" / "trajectory.npz")
        ref = load_trajectory(tmp_path / "serial" / "trajectory.npz")
        assert got.status.startswith("failed") and np.array_equal(got.positions, ref.positions)
