"""``jellysim scene-help``: the scene format as Markdown, generated from the schema."""
from __future__ import annotations

__all__ = ["schema_markdown"]


def schema_markdown() -> str:
    """The scene format as a Markdown table (for docs/scene.md)."""
    from .presets import PRESETS
    from .scene import OBSTACLE_SCHEMA, SCHEMA
    from .scene_spec import REQUIRED

    lines = []
    for section, keys in SCHEMA.items():
        lines += [f"### `[{section}]`", "", "| key | type | default | allowed | meaning |",
                  "|---|---|---|---|---|"]
        for key, spec in keys.items():
            default = "**required**" if spec.default is REQUIRED else f"`{_shown(spec.default)!r}`"
            given = [name for name, p in PRESETS.items() if key in p.get(section, {})]
            if spec.default is REQUIRED and given:  # (the gelatin preset's dt = 1/60 s ...)
                default += " unless a preset gives it (" + ", ".join(
                    f"{name}: `{_brief(PRESETS[name][section][key])}`" for name in given) + ")"
            allowed = spec.allowed or (", ".join(f"`{c}`" for c in spec.choices))
            lines.append(f"| `{key}` | {spec.kind} | {default} | {allowed} | {spec.doc} |")
        lines.append("")
    lines += ["### `[[obstacle]]` (any number)", "",
              "Static obstacles with restitution and Coulomb friction.  A plane takes `point` "
              "and `normal`, a sphere `center` and `radius`, a box `lower` and `upper`.", "",
              "| key | type | default | allowed | meaning |", "|---|---|---|---|---|"]
    for key, spec in OBSTACLE_SCHEMA.items():
        default = "**required**" if spec.default is REQUIRED else f"`{_shown(spec.default)!r}`"
        allowed = spec.allowed or (", ".join(f"`{c}`" for c in spec.choices))
        lines.append(f"| `{key}` | {spec.kind} | {default} | {allowed} | {spec.doc} |")
    lines += ["", "### `[[handle]]` (any number; physical path)", "",
              "Hold or push chosen points (:mod:`jellysim.handles`).  Exactly one selection "
              "per handle, taken at the start positions.  Tables of one kind may not "
              "share points (a pin along a path, a force, a gravity scale: the later one "
              "would replace the earlier there; refused, naming both); a force on pinned "
              "points does nothing and is warned, as is a pin path into the ground or an "
              "obstacle (their contact holds the points on the surface: it wins over the "
              "pin) and a path or force likely typed in other units.", "",
              "| key | type | meaning |", "|---|---|---|",
              "| `kind` | str | 'pin' (fix the points, or move them along `path`), 'force' "
              "(a constant total `force`), 'gravity' (multiply gravity by `scale`). |",
              "| `box` | [[x0, y0, z0], [x1, y1, z1]] | Select the points in this box [m]. |",
              "| `sphere` | {center = [x, y, z], radius = r} | Select the points in this "
              "sphere [m]. |",
              "| `indices` | [i, ...] | Select these points. |",
              "| `path` | [[t, dx, dy, dz], ...] | Pin: offsets [m] from the start positions "
              "at times [s], linear between rows; from a zero offset at t = 0 to the first "
              "row (a non-zero offset at t = 0 is refused: the points would jump). |",
              "| `shake` | {amplitude = [ax, ay, az], frequency = f, seconds = s} | Pin: "
              "instead of `path`, the offset amplitude sin(2 pi f t) [m] for s seconds "
              "(`start` [s], optional, delays it; 32 keyframes a period: "
              "`jellysim.shake_path`; a shake faster than half the saved frame rate is "
              "said: its frames would show a false, slower swing). |",
              "| `force` | [fx, fy, fz] | Force: total force [N], split evenly. |",
              "| `until` | float | Force: release time [s] (the force acts from the start "
              "until then: a push, then a free wobble); default: the whole run. |",
              "| `scale` | float | Gravity: factor on gravity [-]. |"]
    return "\n".join(lines)


def _brief(value) -> str:
    """A preset's value, a float to 4 digits (1/60 s: 0.01667)."""
    return f"{value:.4g}" if isinstance(value, float) else repr(_shown(value))


def _shown(value):
    """A default as a scene file writes it (an Enum member as its value)."""
    from enum import Enum

    return value.value if isinstance(value, Enum) else value
