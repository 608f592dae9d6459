"""The ``.jello`` points-and-springs file (report section 4.2) and its ``.npz`` twin.

The text format is specified in ``docs/jello-format.md``; in short::

    jello 1                          # magic + format version, first non-comment line
    points 3 mass                    # section: name, row count, optional columns
    0.0 0.0 0.0 0.1                  # x y z [m] (mass [kg])
    ...
    springs 2 rest_length stiffness  # i j (rest_length [m]) (stiffness [N/m]), 0-based
    0 1 0.5 100.0
    ...
    tets 0                           # optional: a b c d
    triangles 0                      # optional: a b c
    skin_vertices 0                  # optional: x y z [m] of the skin (the built-from mesh)
    skin_faces 0                     # with it: a b c, indices into skin_vertices
    skin_uv 0                        # optional: u0 v0 u1 v1 u2 v2, each skin face's UVs
    skin_material 0                  # optional: m, each skin face's material (names: meta)
    volume 0.125                     # optional: [m^3]
    meta {"builder": "delaunay"}     # optional: one line of JSON
    end

:func:`write_jello` / :func:`read_jello` round-trip a :class:`~jellysim.body.Body` exactly
(floats are written with Python's shortest round-trip ``repr``).  :func:`write_body` /
:func:`read_body` pick the format by suffix (``.jello`` or ``.npz``).  Every problem in a file
raises :class:`~jellysim.errors.JelloFileError` naming the file, the line and column (text) or the
array (npz), and what was expected.  Writing is atomic: the data goes to a temporary file in
the target directory, which then replaces the target with :func:`os.replace`.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from jellysim.body import Body
from jellysim.errors import JelloFileError

__all__ = ["MAGIC", "VERSION", "read_jello", "parse_jello", "write_jello", "read_body",
           "write_body"]

MAGIC = "jello"
VERSION = 1
NPZ_FORMAT = "jello-npz 1"

_TOKEN = re.compile(r"[^ \t]+")  # the spec: tokens are separated by spaces or tabs only
MAX_COUNT_DIGITS = 15
"""Row counts and indices longer than this many digits are refused before ``int()``."""
from .jellymeta import MAX_META_DEPTH  # noqa: E402,F401 (deepest meta nesting accepted)
# section -> (fixed fields, allowed optional columns)
from .jellymeta import _meta_json  # noqa: E402 (the meta line's JSON rules)
from .jellyarrays import validate_arrays  # noqa: E402 (the arrays' checks)

_SECTIONS = {
    "points": (("x", "y", "z"), ("mass",)),
    "springs": (("i", "j"), ("rest_length", "stiffness")),
    "tets": (("a", "b", "c", "d"), ()),
    "triangles": (("a", "b", "c"), ()),
    "skin_vertices": (("x", "y", "z"), ()),
    "skin_faces": (("a", "b", "c"), ()),
    "skin_uv": (("u0", "v0", "u1", "v1", "u2", "v2"), ()),
    "skin_material": (("m",), ()),
}
_ORDER = ("points", "springs", "tets", "triangles", "skin_vertices", "skin_faces", "skin_uv",
          "skin_material", "volume", "meta")
_POSITIVE = {"mass": "mass [kg]", "rest_length": "rest length [m]", "stiffness": "stiffness [N/m]"}


# ----------------------------------------------------------------------------------------------
# Text reader
# ----------------------------------------------------------------------------------------------
class _Lines:
    """Significant lines of a text file: (line number, [(column, token), ...]); comments and
    blank lines skipped.  Columns and line numbers are 1-based."""

    def __init__(self, path: str, text: str):
        self.path = path
        self.rows: list[tuple[int, list[tuple[int, str]], str]] = []
        # line breaks are '\n' and '\r\n' only (the spec): no splitlines(), which also breaks
        # at form feeds, U+2028, '\x85' ...; a bare '\r' is an error
        self.raw = text.split("\n")
        if self.raw and self.raw[-1] == "":
            self.raw.pop()
        for no, raw in enumerate(self.raw, start=1):
            if raw.endswith("\r"):
                raw = raw[:-1]
                self.raw[no - 1] = raw
            cr = raw.find("\r")
            if cr >= 0:
                raise self.error(no, cr + 1, "bare carriage return (CR) in a line; lines end "
                                 "with LF or CR LF only")
            body = raw.split("#", 1)[0]
            toks = [(m.start() + 1, m.group()) for m in _TOKEN.finditer(body)]
            if toks:
                self.rows.append((no, toks, body))
        self.pos = 0
        self.last_line = len(self.raw)

    def next(self, expected: str):
        if self.pos >= len(self.rows):
            raise self.error(self.last_line + 1, 1,
                             f"truncated file: it ends here, expected {expected}")
        row = self.rows[self.pos]
        self.pos += 1
        return row

    def error(self, line: int, col: int, msg: str) -> JelloFileError:
        return JelloFileError(f"{self.path}:{line}:{col}: {msg}")


_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NONFINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


def _parse_float(lines: _Lines, line: int, col: int, tok: str, what: str) -> float:
    if _NONFINITE.fullmatch(tok):
        raise lines.error(line, col, f"{tok!r} is not finite; expected a finite {what}")
    if not _FLOAT.fullmatch(tok):  # C syntax only: no '1_000', no hex
        raise lines.error(line, col, f"cannot parse {tok!r} as a number; expected {what}")
    val = float(tok)
    if not math.isfinite(val):  # e.g. 1e999 overflows
        raise lines.error(line, col, f"{tok!r} is not finite; expected a finite {what}")
    return val


def _parse_int(lines: _Lines, line: int, col: int, tok: str, what: str, n: int) -> int:
    if not re.fullmatch(r"[+-]?[0-9]+", tok):
        raise lines.error(line, col, f"cannot parse {tok!r} as an integer; expected {what}")
    if len(tok.lstrip("+-").lstrip("0")) > MAX_COUNT_DIGITS:
        raise lines.error(line, col, f"index of {len(tok)} digits out of range; expected "
                          f"{what} in 0..{max(n - 1, 0)}")
    val = int(tok)
    if not 0 <= val < n:
        raise lines.error(line, col, f"index {val} out of range; expected {what} in 0..{n - 1}"
                          if n else f"index {val} out of range: there are no points")
    return val


def _parse_count(lines: _Lines, line: int, col: int, tok: str | None, name: str) -> int:
    if tok is None:
        raise lines.error(line, col, f"missing row count after '{name}'; expected "
                          f"'{name} <count>'")
    if not re.fullmatch(r"\+?[0-9]+", tok):
        raise lines.error(line, col, f"bad row count {tok!r} for section '{name}'; expected a "
                          "non-negative integer")
    if len(tok.lstrip("+").lstrip("0")) > MAX_COUNT_DIGITS:
        raise lines.error(line, col, f"row count of {len(tok)} digits for section '{name}' is "
                          f"too large; expected at most {MAX_COUNT_DIGITS} digits")
    val = int(tok)
    if name == "points" and val == 0:
        raise lines.error(line, col, "'points 0': a body needs at least one point")
    return val


def _parse_meta(lines, no: int, col: int, js: str) -> dict:
    try:
        meta = _meta_json(js)
    except json.JSONDecodeError as exc:
        raise lines.error(no, col + exc.pos, f"bad JSON in 'meta': {exc.msg}") from None
    except (ValueError, RecursionError) as exc:
        raise lines.error(no, col, f"'meta' JSON refused: {exc}; expected a JSON object "
                          "of finite numbers, strings, lists and objects") from None
    if not isinstance(meta, dict):
        raise lines.error(no, col, "expected a JSON object after 'meta'")
    return meta


def read_jello(path) -> Body:
    """Read a ``.jello`` text file (format version 1) into a :class:`Body`.

    Springs may be written in any order and orientation; the returned body has rows
    ``i < j`` sorted lexicographically (per-spring columns permuted alongside).
    """
    path = Path(path)
    name = str(path)
    try:
        data_bytes = path.read_bytes()
    except FileNotFoundError:
        raise JelloFileError(f"{name}: file not found") from None
    except OSError as exc:
        raise JelloFileError(f"{name}: cannot read ({exc.strerror})") from None
    return parse_jello(data_bytes, name=name)


def parse_jello(data_bytes: bytes, *, name: str = "<text>") -> Body:
    """Parse the bytes of a ``.jello`` file (see :func:`read_jello`); ``name`` is used in
    error messages."""
    try:
        text = data_bytes.decode("utf-8")
    except UnicodeDecodeError as exc:
        start = data_bytes.rfind(b"\n", 0, exc.start) + 1
        line = data_bytes.count(b"\n", 0, exc.start) + 1
        col = len(data_bytes[start:exc.start].decode("utf-8", errors="replace")) + 1
        raise JelloFileError(f"{name}:{line}:{col}: not UTF-8 text (byte "
                             f"0x{data_bytes[exc.start]:02x}: {exc.reason}); .jello files are "
                             "UTF-8") from None
    if text.startswith("\ufeff"):  # a byte-order mark (Notepad's UTF-8) is not content
        text = text[1:]
    lines = _Lines(name, text)

    # header
    if not lines.rows:
        raise lines.error(1, 1, f"empty file; expected the header '{MAGIC} {VERSION}'")
    no, toks, _ = lines.next("the header")
    if toks[0][1] != MAGIC:
        raise lines.error(no, toks[0][0], f"missing header: found {toks[0][1]!r}, expected "
                          f"'{MAGIC} {VERSION}' as the first line")
    if len(toks) != 2:
        col = toks[2][0] if len(toks) > 2 else toks[0][0] + len(MAGIC)
        raise lines.error(no, col, f"header must be exactly '{MAGIC} <version>'")
    if toks[1][1] != str(VERSION):
        raise lines.error(no, toks[1][0], f"unsupported version {toks[1][1]!r}; this reader "
                          f"supports version {VERSION}")

    seen: dict[str, int] = {}
    data: dict[str, object] = {}
    n_points = n_skin = 0
    while True:
        no, toks, _ = lines.next("a section (" + ", ".join(repr(w) for w in _ORDER)
                                 + ") or 'end'")
        col, word = toks[0]
        if word == "end":
            if len(toks) > 1:
                raise lines.error(no, toks[1][0], "unexpected text after 'end'")
            break
        if word not in _ORDER:
            raise lines.error(no, col, f"unknown section {word!r}; expected one of "
                              + ", ".join(repr(s) for s in _ORDER) + " or 'end'")
        if word in seen:
            raise lines.error(no, col, f"section {word!r} repeated (first at line {seen[word]})")
        if word != "points" and "points" not in seen:
            raise lines.error(no, col, f"section {word!r} before 'points'; expected 'points' "
                              "first")
        if word == "skin_faces" and "skin_vertices" not in seen:
            raise lines.error(no, col, "section 'skin_faces' before 'skin_vertices'; expected "
                              "the skin's vertices first (its faces index them)")
        if word in ("skin_uv", "skin_material") and "skin_faces" not in seen:
            raise lines.error(no, col, f"section '{word}' before 'skin_faces'; expected the "
                              "skin's faces first (it gives each face's "
                              + ("corners' UVs)" if word == "skin_uv" else "material)"))
        seen[word] = no
        if word == "volume":
            if len(toks) != 2:
                raise lines.error(no, col, "expected 'volume <V [m^3]>'")
            v = _parse_float(lines, no, toks[1][0], toks[1][1], "volume [m^3]")
            if v <= 0:
                raise lines.error(no, toks[1][0], f"volume {toks[1][1]} must be > 0")
            data["volume"] = v
            continue
        if word == "meta":
            # the rest of the raw line is JSON ('#' is no comment here: it may be in a string)
            raw = lines.raw[no - 1]
            js = raw[toks[1][0] - 1:].strip() if len(toks) > 1 else ""
            meta = _parse_meta(lines, no, toks[1][0] if len(toks) > 1 else col, js)
            if not isinstance(meta, dict):
                raise lines.error(no, toks[1][0], "expected a JSON object after 'meta'")
            data["meta"] = meta
            continue

        fixed, optional = _SECTIONS[word]
        count = _parse_count(lines, no, toks[1][0] if len(toks) > 1 else col + len(word) + 1,
                             toks[1][1] if len(toks) > 1 else None, word)
        if word in ("skin_uv", "skin_material") and count != len(data["skin_faces"][1]):
            raise lines.error(no, toks[1][0], f"section '{word}' has {count} rows; expected "
                              f"one per skin face ({len(data['skin_faces'][1])})")
        cols = []
        for c, t in toks[2:]:
            if t not in optional:
                raise lines.error(no, c, f"unknown column {t!r} for section {word!r}; expected "
                                  + (" / ".join(optional) if optional else "no columns"))
            if t in cols:
                raise lines.error(no, c, f"column {t!r} given twice")
            cols.append(t)
        nf = len(fixed) + len(cols)
        what = " ".join(fixed + tuple(cols))
        rows = []
        idx_rows = []
        for r in range(count):
            rno, rtoks, _ = lines.next(f"row {r + 1} of {count} of section '{word}' ({what})")
            if rtoks[0][1] in _SECTIONS or rtoks[0][1] in ("end", "volume", "meta"):
                raise lines.error(rno, rtoks[0][0], f"section '{word}' declares {count} rows "
                                  f"but '{rtoks[0][1]}' starts after {r}: make the count "
                                  f"{r}, or add the missing rows")
            if len(rtoks) != nf:
                c = rtoks[nf][0] if len(rtoks) > nf else rtoks[-1][0] + len(rtoks[-1][1])
                hint = ""
                extra = [k for k in optional if k not in cols]
                if len(rtoks) > nf and extra:
                    hint = (f"; a further column must be named in the section line, e.g. "
                            f"'{word} {count} {' '.join(cols + [extra[0]])}'")
                raise lines.error(rno, c, f"{len(rtoks)} fields in section '{word}'; expected "
                                  f"{nf} ({what}){hint}")
            if word in ("points", "skin_vertices", "skin_uv"):
                vals = [_parse_float(lines, rno, c, t, "texture coordinate" if word == "skin_uv"
                                     else "coordinate [m]" if k < 3 else
                                     _POSITIVE[cols[k - 3]]) for k, (c, t) in enumerate(rtoks)]
            else:
                nidx = len(fixed)
                vals = [_parse_int(lines, rno, c, t, "a skin vertex index", n_skin)
                        if word == "skin_faces" else
                        _parse_int(lines, rno, c, t, "a material number", 2**31)
                        if word == "skin_material" else
                        _parse_int(lines, rno, c, t, "a point index", n_points)
                        for c, t in rtoks[:nidx]]
                for (c, t), (c2, t2) in ((a, b) for k, a in enumerate(rtoks[:nidx])
                                         for b in rtoks[k + 1:nidx]):
                    if int(t) == int(t2):
                        msg = (f"self-spring: both ends are point {int(t)}" if word == "springs"
                               else f"vertex {int(t)} repeated in one face" if word == "skin_faces"
                               else f"point {int(t)} repeated in one {word[:-1]}")
                        raise lines.error(rno, c2, msg)
                vals += [_parse_float(lines, rno, c, t, _POSITIVE[cols[k]])
                         for k, (c, t) in enumerate(rtoks[nidx:])]
            # positivity of optional columns
            for k, cname in enumerate(cols):
                c, t = rtoks[len(fixed) + k]
                if vals[len(fixed) + k] <= 0:
                    raise lines.error(rno, c, f"{_POSITIVE[cname]} {t} must be > 0")
            rows.append(vals)
            idx_rows.append((rno, rtoks[0][0]))
        if word == "points":
            n_points = count
        if word == "skin_vertices":
            n_skin = count
        data[word] = (cols, rows, idx_rows)

    # trailing content after 'end'
    if lines.pos < len(lines.rows):
        no, toks, _ = lines.rows[lines.pos]
        raise lines.error(no, toks[0][0], "unexpected text after 'end'")
    for req in ("points", "springs"):
        if req not in data:
            raise lines.error(no, 1, f"missing section {req!r} before 'end'")
    if "skin_vertices" in data and "skin_faces" not in data:
        raise lines.error(seen["skin_vertices"], 1, "section 'skin_vertices' without "
                          "'skin_faces'; a skin needs both")

    cols, rows, _ = data["points"]
    arr = np.array(rows, dtype=np.float64).reshape(-1, 3 + len(cols))
    points = np.ascontiguousarray(arr[:, :3])
    masses = np.ascontiguousarray(arr[:, 3]) if cols else None

    cols, rows, rnos = data["springs"]
    k = len(rows)
    ij = np.array([r[:2] for r in rows], dtype=np.int64).reshape(k, 2)
    extra = {c: np.array([r[2 + m] for r in rows], dtype=np.float64) for m, c in enumerate(cols)}
    lo, hi = ij.min(axis=1), ij.max(axis=1)
    key = lo * max(n_points, 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    dup = np.flatnonzero(ks[1:] == ks[:-1])
    if dup.size:
        a, b = order[dup[0]], order[dup[0] + 1]
        line, col = rnos[max(a, b)]
        raise lines.error(line, col, f"duplicate spring {lo[a]}-{hi[a]} (already at line "
                          f"{rnos[min(a, b)][0]}; i-j and j-i are the same spring)")
    springs = np.stack([lo, hi], axis=1)[order].astype(np.int64).reshape(k, 2)

    def _idx(sec, width):
        if sec not in data:
            return None
        return np.array(data[sec][1], dtype=np.int64).reshape(-1, width)

    return Body(
        points=points,
        springs=np.ascontiguousarray(springs),
        rest_length=np.ascontiguousarray(extra["rest_length"][order]) if "rest_length" in extra
        else None,
        stiffness=np.ascontiguousarray(extra["stiffness"][order]) if "stiffness" in extra
        else None,
        masses=masses,
        tets=_idx("tets", 4),
        triangles=_idx("triangles", 3),
        volume=data.get("volume"),
        meta=data.get("meta", {}),
        skin_vertices=None if "skin_vertices" not in data else np.array(
            data["skin_vertices"][1], dtype=np.float64).reshape(-1, 3),
        skin_faces=_idx("skin_faces", 3),
        skin_uv=None if "skin_uv" not in data else np.array(
            data["skin_uv"][1], dtype=np.float64).reshape(-1, 3, 2),
        skin_material=None if "skin_material" not in data else _idx("skin_material", 1)[:, 0],
    )


# ----------------------------------------------------------------------------------------------
# Writers (atomic)
# ----------------------------------------------------------------------------------------------
def _atomic_write(path: Path, write) -> None:
    from jellysim.io.atomic import atomic_write

    atomic_write(path, write)


def _body_arrays(path, body: Body) -> dict:
    return validate_arrays(f"{path} (writing)", body.points, body.springs, body.rest_length,
                           body.stiffness, body.masses, body.tets, body.triangles, body.volume,
                           body.skin_vertices, body.skin_faces, body.skin_uv,
                           body.skin_material)


def write_jello(path, body: Body) -> None:
    """Write ``body`` as a ``.jello`` text file (atomically).  Floats use ``repr`` (shortest
    string that reads back to the same float64), so :func:`read_jello` returns equal arrays."""
    path = Path(path)
    a = _body_arrays(path, body)
    try:
        meta_line = json.dumps(body.meta or {}, allow_nan=False, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise JelloFileError(f"{path} (writing): meta is not JSON-serialisable: {exc}") from None
    if "\n" in meta_line:  # pragma: no cover - json.dumps escapes newlines
        raise JelloFileError(f"{path} (writing): meta does not fit on one line")

    def fmt(rows) -> str:
        return "".join(" ".join(map(repr, r)) + "\n" for r in rows)

    def write(fh):
        out = [f"{MAGIC} {VERSION}\n",
               "# jellysim body: SI units (m, kg, N/m), 0-based point indices; "
               "spec: docs/jello-format.md\n"]
        pts = a["points"]
        if a["masses"] is not None:
            out.append(f"points {pts.shape[0]} mass\n")
            out.append(fmt(np.column_stack([pts, a["masses"]]).tolist()))
        else:
            out.append(f"points {pts.shape[0]}\n")
            out.append(fmt(pts.tolist()))
        cols = [c for c in ("rest_length", "stiffness") if a[c] is not None]
        s = a["springs"]
        out.append(" ".join(["springs", str(s.shape[0])] + cols) + "\n")
        rows = [list(map(int, r)) for r in s.tolist()]
        for c in cols:
            for r, x in zip(rows, a[c].tolist()):
                r.append(x)
        out.append(fmt(rows))
        for sec in ("tets", "triangles", "skin_vertices", "skin_faces", "skin_uv",
                    "skin_material"):
            if a[sec] is not None:
                out.append(f"{sec} {a[sec].shape[0]}\n")
                out.append(fmt(a[sec].reshape(a[sec].shape[0], -1).tolist()))
        if a["volume"] is not None:
            out.append(f"volume {a['volume']!r}\n")
        if body.meta:
            out.append(f"meta {meta_line}\n")
        out.append("end\n")
        fh.write("".join(out).encode("utf-8"))

    _atomic_write(path, write)


def write_npz(path, body: Body) -> None:
    """Write ``body`` as an uncompressed ``.npz`` (atomically; arrays as in :class:`Body`)."""
    path = Path(path)
    a = _body_arrays(path, body)
    try:
        meta = json.dumps(body.meta or {}, allow_nan=False, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise JelloFileError(f"{path} (writing): meta is not JSON-serialisable: {exc}") from None
    arrays = {k: v for k, v in a.items() if v is not None and k != "volume"}
    if a["volume"] is not None:
        arrays["volume"] = np.float64(a["volume"])
    arrays["format"] = np.str_(NPZ_FORMAT)
    arrays["meta"] = np.str_(meta)
    _atomic_write(path, lambda fh: np.savez(fh, **arrays))


def read_npz(path) -> Body:
    """Read a body written by :func:`write_npz`, validated like the text format.  ``path``
    may also be a binary file object (error messages then use its ``name``, if any)."""
    if hasattr(path, "read"):
        src = str(getattr(path, "name", "<npz>"))
    else:
        path = Path(path)
        src = str(path)
    from zipfile import BadZipFile

    from jellysim.io.npzcheck import check_npz

    try:
        check_npz(path)
        if hasattr(path, "seek"):
            path.seek(0)
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise JelloFileError(f"{src}: file not found") from None
    except (OSError, ValueError, EOFError, BadZipFile, KeyError, SyntaxError,
            NotImplementedError, MemoryError) as exc:
        raise JelloFileError(f"{src}: not a readable .npz file ({exc})") from None
    fmt = arrays.pop("format", None)
    if fmt is None and "positions" in arrays and "times" in arrays:
        raise JelloFileError(f"{src}: this is a trajectory (a run's frames), not a body file; "
                             "jellysim render / plot / export read it, and a body file comes "
                             "from jellysim build")
    if fmt is None or fmt.shape != () or str(fmt) != NPZ_FORMAT:
        raise JelloFileError(f"{src}: array 'format': expected {NPZ_FORMAT!r}, found "
                             f"{None if fmt is None else str(fmt)!r}")
    for req in ("points", "springs"):
        if req not in arrays:
            raise JelloFileError(f"{src}: array '{req}' is missing")
    known = {"points", "springs", "rest_length", "stiffness", "masses", "tets", "triangles",
             "skin_vertices", "skin_faces", "skin_uv", "skin_material", "volume", "meta"}
    unknown = sorted(set(arrays) - known)
    if unknown:
        raise JelloFileError(f"{src}: array '{unknown[0]}' is not part of the format; expected "
                             "only " + ", ".join(sorted(known | {"format"})))
    meta_s = arrays.pop("meta", None)
    meta = {}
    if meta_s is not None:
        try:
            meta = _meta_json(str(meta_s))
        except json.JSONDecodeError as exc:
            raise JelloFileError(f"{src}: array 'meta': bad JSON ({exc.msg})") from None
        except (ValueError, RecursionError) as exc:
            raise JelloFileError(f"{src}: array 'meta': refused ({exc}); expected a JSON "
                                 "object of finite values") from None
        if not isinstance(meta, dict):
            raise JelloFileError(f"{src}: array 'meta': expected a JSON object")
    a = validate_arrays(src, **arrays)
    return Body(meta=meta, **a)


# ----------------------------------------------------------------------------------------------
# Dispatch
# ----------------------------------------------------------------------------------------------
def _kind(path) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in (".jello", ".npz"):
        raise JelloFileError(f"{path}: unknown body file suffix {suffix!r}; expected '.jello' "
                             "or '.npz'")
    return suffix


def write_body(path, body: Body) -> None:
    """Write ``body`` to ``path``: ``.jello`` text or ``.npz`` by suffix (atomically)."""
    if not isinstance(body, Body):
        from jellysim.errors import ParameterError

        swapped = " (the arguments are (path, body): swapped?)" if isinstance(path, Body) else ""
        raise ParameterError(f"write_body(path, body): body must be a jellysim Body, got "
                             f"{type(body).__name__}{swapped}")
    (write_jello if _kind(path) == ".jello" else write_npz)(path, body)


def read_body(path) -> Body:
    """Read a body from ``path``: ``.jello`` text or ``.npz`` by suffix."""
    return (read_jello if _kind(path) == ".jello" else read_npz)(path)
