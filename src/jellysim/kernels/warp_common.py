"""What the Warp kernel modules share: array type aliases, per-precision structs, overloads.

Every kernel is generic (``typing.Any`` for the float type) and gets its float32 and float64
overloads registered up front (:func:`register_overloads`), so each Warp module compiles once
for both precisions.  Warp structs cannot be generic, so a struct is declared once as a field
list (:func:`precision_structs`) and made twice, ``<Name>32`` and ``<Name>64``; a kernel takes it
as an ``Any`` argument that the overloads resolve to the struct of that precision.
"""
from __future__ import annotations

from typing import Any

import warp as wp

if wp.config.log_level == wp.LOG_INFO:  # no banner / "module loaded" lines unless asked for
    wp.config.log_level = wp.LOG_WARNING

I32 = wp.array(dtype=wp.int32)
AT = wp.array(dtype=Any)
A2 = wp.array2d(dtype=Any)

FLOAT = "float"
"""Placeholder in a struct field list: the precision's float type."""


def _field(spec, T):
    if spec == FLOAT:
        return T
    if isinstance(spec, tuple):  # ("array", ndim): an array of the precision's floats
        return wp.array(dtype=T, ndim=spec[1])
    return spec


def precision_structs(name: str, fields: dict, module: str) -> dict:
    """``{wp.float32: <name>32, wp.float64: <name>64}``: a Warp struct per precision from a
    field list (``FLOAT``, ``("array", ndim)`` for float arrays, or a concrete Warp type)."""
    out = {}
    for T, bits in ((wp.float32, 32), (wp.float64, 64)):
        cname = f"{name}{bits}"
        cls = type(cname, (), {"__annotations__": {k: _field(v, T) for k, v in fields.items()},
                               "__module__": module, "__qualname__": cname})
        out[T] = wp.struct(cls)
    return out


def register_overloads(kernels, structs: dict | None = None) -> None:
    """Register the float32 and float64 overloads of generic kernels.  ``structs``: argument
    name -> :func:`precision_structs` result, for ``Any`` arguments that are structs."""
    structs = structs or {}
    for kern in kernels:
        for T in (wp.float32, wp.float64):
            sig = {}
            for name, t in kern.adj.arg_types.items():
                if name in structs:
                    sig[name] = structs[name][T]
                elif t is Any:
                    sig[name] = T
                elif wp.types.is_array(t) and t.dtype is Any:
                    sig[name] = wp.array(dtype=T, ndim=t.ndim)
            if sig:
                wp.overload(kern, sig)
