"""docs/architecture.md names what the code has (a contributor's trial, session 31: one
equation row named dead code, helper names were given for a backend that has none, and the
records table lacked a field; nothing compared the two)."""
from __future__ import annotations

import importlib
import re
from pathlib import Path

from jellysim.kernels import records

DOC = (Path(__file__).resolve().parents[1] / "docs" / "architecture.md").read_text()


def _rows(first_cell: str) -> list[str]:
    return [line for line in DOC.splitlines() if line.startswith(f"| {first_cell}")]


def test_the_records_table_lists_each_records_fields():
    """Each record's row names exactly its fields (in backticks)."""
    checked = 0
    for name in ("SpringArrays", "PointArrays", "ProvotOptions", "GroundGuard", "Obstacles",
                 "ImplicitOptions"):
        rows = _rows(f"`{name}` |")
        assert len(rows) == 1, name
        cells = rows[0].split("|")[2]
        named = set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", cells))
        assert named == set(getattr(records, name)._fields), name
        checked += 1
    assert checked == 6


def test_every_kernel_function_the_equation_table_names_exists():
    """Every ``module.function`` of the equations table's last column exists (``*``: in both
    the numpy and the numba module)."""
    start = DOC.index("## Equations and the functions that compute them")
    table = DOC[start:DOC.index("\n## ", start + 5)]
    names = set()
    for line in table.splitlines():
        if line.startswith("| ") and not line.startswith(("| equation", "|---")):
            names |= set(re.findall(r"`([a-z_]+(?:_\*|_numpy|_numba))\.([A-Za-z_]\w*)",
                                    line.split("|")[3]))
    assert len(names) >= 15
    missing = []
    for module, func in sorted(names):
        for mod in ([module.replace("*", "numpy"), module.replace("*", "numba")]
                    if "*" in module else [module]):
            m = importlib.import_module(f"jellysim.kernels.{mod}")
            if not hasattr(m, func):
                missing.append(f"{mod}.{func}")
    assert not missing, missing


def test_every_helper_the_equation_table_names_is_defined():
    """The bare helper names of the table's last column (``_drift``, ``k_mass_moves``, ...)
    are each defined (``def name``) in a kernels module."""
    start = DOC.index("## Equations and the functions that compute them")
    table = DOC[start:DOC.index("\n## ", start + 5)]
    kernels = Path(records.__file__).parent
    defined = set()
    for path in kernels.glob("*.py"):
        defined |= set(re.findall(r"^def (\w+)\(", path.read_text(), flags=re.M))
    bare = set()
    for line in table.splitlines():
        if line.startswith("| ") and not line.startswith(("| equation", "|---")):
            cell = line.split("|")[3]
            bare |= {n for n in re.findall(r"(?<![.\w])`(\w+)`", cell)}
    assert len(bare) >= 15
    missing = sorted(bare - defined)
    assert not missing, missing
