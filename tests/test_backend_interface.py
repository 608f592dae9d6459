"""The backend interface holds what docs/architecture.md says (a contributor's trial, session
31: the physical path called ``fem_numba`` / ``fem_numpy`` by name, so a registered backend was
silently bypassed there; ``precision = "float32"`` was refused only for backends named in the
check, so another took it and computed in float64; the backend choices were typed out in three
places)."""
from __future__ import annotations

import numpy as np
import pytest

import jellysim
from jellysim.errors import SceneError
from jellysim.kernels import Backend, get_backend


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_the_physical_path_steps_through_the_backends_physical_steps(backend, monkeypatch):
    """Each substep batch of the physical path is a call of the backend's ``physical_steps``
    (one call per frame here), and what it returns is the run: replacing it replaces the run."""
    body = jellysim.Body.box((0, 0.01, 0), (0.02, 0.03, 0.02), points=27)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    mod = get_backend(backend)
    real = mod.physical_steps
    calls = []

    def counting(nsteps, dt, x, *rest):
        calls.append(nsteps)
        return real(nsteps, dt, x, *rest)

    monkeypatch.setattr(mod, "physical_steps", counting, raising=False)
    sim = jellysim.Simulator(model, dt=1 / 60, backend=backend, threads=1)
    sim.advance(3)
    assert calls == [sim.substeps] * 3
    start = sim.state.x.copy()
    monkeypatch.setattr(mod, "physical_steps", lambda nsteps, *rest: (nsteps, 0), raising=False)
    sim.advance(2)  # (a backend whose driver moves nothing: nothing moves)
    assert np.array_equal(sim.state.x, start)


def test_backend_choices_are_the_enums_members():
    """The scene key and both CLI options list exactly the ``Backend`` members."""
    from jellysim.cli import cli
    from jellysim.scene_schema import SCHEMA

    members = [b.value for b in Backend]
    assert list(SCHEMA["integrator"]["backend"].choices) == members
    for command in ("run", "demo"):
        opt = next(p for p in cli.commands[command].params if p.name == "backend")
        assert list(opt.type.choices) == members


def test_float32_is_refused_on_a_backend_that_does_not_implement_it():
    """Only the numba (explicit springs) and Warp backends store float32 state: any other
    backend name, present or future, is refused by name rather than run in float64."""
    from jellysim.scene_spec import check_backend

    check_backend("numba", "paper", precision="float32")
    for other in ("numpy", "numpy_threads"):
        with pytest.raises(SceneError, match=rf"backend = '{other}' with name = 'paper' "
                                             r"computes in float64"):
            check_backend(other, "paper", precision="float32")
