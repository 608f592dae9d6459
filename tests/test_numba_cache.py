"""The numba cache is dropped when any compiled package's source changes (numba itself
re-validates a cached kernel against its own file only, not the modules it inlines)."""
from pathlib import Path

from jellysim._numba_cache import sync


def _package(tmp_path: Path) -> Path:
    root = tmp_path / "pkg"
    for sub in ("kernels", "geometry", "physics"):
        (root / sub / "__pycache__").mkdir(parents=True)
        (root / sub / "a.py").write_text(f"X = 1  # {sub}\n")
    return root


def _cached(root: Path, sub: str) -> Path:
    f = root / sub / "__pycache__" / "a.f-1.py311.1.nbc"
    f.write_bytes(b"machine code")
    return f


def test_cache_survives_unchanged_sources_and_goes_when_a_dependency_changes(tmp_path):
    root = _package(tmp_path)
    assert sync(root)  # no fingerprint yet: a fresh cache
    kept = _cached(root, "kernels")
    assert not sync(root) and kept.exists()
    # a change in another sub-package (a function the kernels inline) drops every cache
    (root / "geometry" / "a.py").write_text("X = 2\n")
    other = _cached(root, "physics")
    assert sync(root)
    assert not kept.exists() and not other.exists()
    assert not sync(root)
