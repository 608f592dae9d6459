"""What a scene will run, before running it (``jellysim inspect scene.toml``).

The body it builds (counts, mass, bounds), the path it takes (the physical path's tets or the
springs, and why), the step (integrator, dt, substeps per step where they are automatic, the
simulated time) and what touches the body (ground, obstacles, handles).  Building the model
and the simulator is all it does: nothing is stepped or written.
"""
from __future__ import annotations

import numpy as np

from .errors import JellysimError

__all__ = ["scene_summary"]


def _corners(x) -> str:
    return " .. ".join("[" + ", ".join(f"{c:.4g}" for c in corner) + "]"
                       for corner in (x.min(axis=0), x.max(axis=0)))


def _seconds(t: float) -> str:
    return f"{t * 1e6:.3g} us" if t < 1e-3 else f"{t * 1e3:.3g} ms"


def _name(option) -> str:
    return str(getattr(option, "value", option))


def scene_summary(scene, said: list | None = None) -> list[tuple[str, str]]:
    """Rows ``(label, text)`` describing :class:`~jellysim.scene.Scene` ``scene``; the
    warnings of the build (mesh units, the stability estimate) go to ``said`` if given."""
    import warnings

    p = scene.params
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model = scene.build_model()
            sim = scene.simulator(model, settle=False)  # nothing is run
        except JellysimError:
            if said is not None:  # what the build said may explain the refusal (mesh units)
                said.extend(dict.fromkeys(str(w.message) for w in caught))
            raise
    if said is not None:
        said.extend(dict.fromkeys(str(w.message) for w in caught))
    x = np.asarray(model.point_x0)
    b, it, g = p["body"], p["integrator"], p["ground"]
    tets = model.fem.tets if model.fem is not None else model.body.tets
    rows = [
        ("body", f"type {b['type']!r}" + (f", {b['path']}" if b["path"] else "")
         + (f", distribution {b['distribution']!r}" if b["type"] == "box" else "")),
        ("points", f"{model.point_count}" + _points_note(b, p["springs"], model.point_count)),
        ("springs", f"{model.spring_count}"),
        ("tets", "none" if tets is None else f"{len(tets)}"),
        ("mass [kg]", f"{model.total_mass:.6g}"),
        ("bounds [m]", _corners(x)),
        ("size [m]", " x ".join(f"{e:.4g}" for e in np.ptp(x, axis=0))),
    ]
    if model.fem is not None:
        mat = scene.material()
        rows.append(("path", f"physical: Stable Neo-Hookean tets, E = {mat.youngs_modulus:g} "
                             f"Pa, nu = {mat.poisson_ratio:g}, damping ratio "
                             f"{mat.damping_ratio:g} at {mat.damping_frequency:g} Hz"))
    else:
        why = getattr(scene, "_springs_reason", None)
        rows.append(("path", "springs" + (f" ({why})" if why else "")))
    steps, dt = scene.steps, float(it["dt"])
    step = f"{_name(sim.integrator)}, dt = {dt:g} s, {steps} steps = {steps * dt:g} s simulated"
    given = it["substeps"] is not None
    if sim.physical or sim.substeps > 1 or given:
        step += (f"; {sim.substeps} substeps per step "
                 + ("(set in the scene)" if given else "from the stability estimate")
                 + f" (each {_seconds(dt / sim.substeps)} of simulated time)")
    rows.append(("step", step))
    pv = getattr(sim, "provot", None)
    if not sim.physical and pv is not None:  # (the physical path has no Provot)
        n = model.point_count
        pairs = (f"all pairs ({n * (n - 1) // 2:,} per loop)" if _name(pv.pairs) == "all"
                 else f"the springs ({model.spring_count:,} per loop)")
        rows.append(("provot", "off" if not pv.enabled else (
            f"tau = {pv.tau:g}, {pv.loops} loop(s), {pairs}, {_name(pv.order)} order, "
            + ("correction / dt added to the velocity" if pv.velocity_update
               else "positions only (the report's)"))))
    choice = getattr(sim, "_thread_choice", None)
    rows.append(("backend", f"{_name(sim.backend)}, {sim.threads} thread(s)" + (
        f" to start, then the faster of {' and '.join(map(str, choice.counts))} (timed as it "
        "runs)" if choice else "")))
    kind = scene.ground_params(model).model.value  # an unset model: the body's path's
    ground = "off" if not g["enabled"] else (
        kind + (f", restitution {g['restitution']:g}, friction {g['friction']:g}"
                + (f" (static {g['static_friction']:g}, falling to it over "
                   f"{g['slip_distance']:g} m of slip)"
                   if (g["static_friction"] or 0.0) > g["friction"] else "")
                + (", no slip" if g["no_slip"] else "")
                if kind == "contact" else f", mu {g['mu']:g}, nu {g['nu']:g}"))
    rows.append(("ground", ground))
    rows.append(("obstacles", f"{len(scene.obstacles())}"))
    rows.append(("handles", _handles(sim, p.get("handle") or [])))
    return rows


def _handles(sim, tables: list) -> str:
    """The ``[[handle]]`` tables, each with the points it holds: "2: #1 pin, 121 points along
    a path; #2 force [0.1, 0, 0] N on 121 points until 0.2 s"."""
    from .handles import select_points

    parts = []
    for k, entry in enumerate(tables, 1):
        sphere = entry.get("sphere")
        try:
            count = len(select_points(sim.state.x, box=entry.get("box"), indices=entry.get(
                "indices"), sphere=None if sphere is None else (sphere["center"],
                                                                 sphere["radius"])))
        except JellysimError:
            count = 0
        kind = entry["kind"]
        if kind == "pin":
            text = f"#{k} pin, {count} points" + (" along a path" if entry.get("path") else "")
        elif kind == "force":
            text = (f"#{k} force [" + ", ".join(f"{c:.4g}" for c in entry["force"])
                    + f"] N on {count} points"
                    + (f" until {entry['until']:g} s" if entry.get("until") is not None else ""))
        else:
            text = f"#{k} gravity x {entry['scale']:g} on {count} points"
        parts.append(text)
    return f"{len(tables)}" + (": " + "; ".join(parts) if parts else "")


def _points_note(b: dict, s: dict, count: int) -> str:
    """Why a body has far more or fewer points than ``[body] points`` (a grid counts cells,
    a Delaunay body adds its surface samples, a marching one fills its grid), or ``""``."""
    asked = b.get("points")
    if not asked or 0.8 <= count / asked <= 1.25:
        return ""
    if b["type"] == "box":
        return f" (a grid of about {asked} cells: [body] points counts the cells)"
    if b["type"] == "mesh":
        how = {"delaunay": "adds points sampled on the surface",
               "marching": "fills its grid inside the mesh"}.get(s.get("connect"), "")
        return f" ({asked} asked: {s.get('connect')} {how})" if how else ""
    return ""
