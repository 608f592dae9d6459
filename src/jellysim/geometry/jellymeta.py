"""The ``meta`` line of a ``.jello`` file: finite, bounded JSON (docs/jello-format.md)."""
from __future__ import annotations

import json
import math

MAX_META_DEPTH = 64
"""Deepest nesting of arrays/objects accepted in ``meta``."""


def _json_depth(js: str) -> int:
    """Deepest bracket nesting of a JSON text (outside strings), without parsing it."""
    depth = best = 0
    in_str = esc = False
    for ch in js:
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            best = max(best, depth)
        elif ch in "]}":
            depth -= 1
    return best


def _finite_float(tok: str) -> float:
    v = float(tok)
    if not math.isfinite(v):
        raise ValueError(f"number {tok[:20]} is not finite")
    return v


def _no_constant(tok: str):
    raise ValueError(f"{tok} is not allowed (JSON numbers must be finite)")


def _meta_json(js: str):
    """Parse ``meta`` JSON strictly: finite numbers only (no NaN/Infinity), integers of at most
    :data:`jellysim.geometry.jellyfile.MAX_COUNT_DIGITS` x 20 digits, nesting at most :data:`MAX_META_DEPTH`.  Raises
    ``ValueError`` (with ``pos`` when the JSON itself is bad)."""
    if _json_depth(js) > MAX_META_DEPTH:
        raise ValueError(f"nested deeper than {MAX_META_DEPTH} levels")

    def big_int(tok: str) -> int:
        if len(tok) > 300:
            raise ValueError(f"an integer of {len(tok)} digits")
        return int(tok)

    return json.loads(js, parse_float=_finite_float, parse_int=big_int,
                      parse_constant=_no_constant)
