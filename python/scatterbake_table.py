"""Reader for scatterbake tables (``.sbt``), formats 1.x, 2.x and 3.x. Needs numpy and zstandard.

    import sys; sys.path.insert(0, "python")
    import scatterbake_table as sbt
    t = sbt.open_table("tables/rainbow-mie.sbt")  # verifies every checksum
    t.axes            # list of Axis(name, unit, coords: numpy float64 array, symmetry)
    t.channels        # list of Channel(name, unit, meaning)
    t.data            # numpy float32 array, shape = axis lengths + (number of channels,)
    t.channel("phase")            # view without the channel dimension
    p = t.sample([400.0, 650.0, 138.0])  # radius µm, wavelength nm, angle deg (axis order) → every
                                         # channel; multilinear, clamped at the axis ends, like Rust
                                         # (folded first on an even-periodic axis: Axis.fold)

Byte layout (see docs/table-format.md): magic ``SBTABLE\\0`` (8 bytes), format major and minor
(u16 LE each), flags (u32 LE), header length H (u64 LE), SHA-256 of bytes [0, 24) + header,
the UTF-8 JSON header, then one zstd frame of ``header.payload.compressed_bytes`` bytes holding
the row-major float32 little-endian samples (format 2.0 may store 16-bit codes instead, with a
previous-row predictor, and derive channels from two stored ones: ``t.data`` is always the
decoded float32 values of every channel; format 3.0 may declare an axis even and periodic, storing
only half a period). The reader refuses newer major versions (naming the version), reads any
minor version of formats 1 to 3 and ignores header fields it does not know (newer minors only
add fields), checks the header checksum, the SHA-256 of the compressed
and of the uncompressed payload, the sizes, and that nothing follows the payload.
"""

from __future__ import annotations

import hashlib
import io
import itertools
import json
import math
import re
import struct
from dataclasses import dataclass, field

import numpy as np
import zstandard

MAGIC = b"SBTABLE\0"
FORMAT_MAJOR = 3
FORMAT_MINOR = 0
#: Minor version implemented of each major version read.
_MINOR_OF = {1: 0, 2: 0, 3: 0}
#: ``axes[].symmetry.kind`` of an even, periodic axis (format 3.0).
EVEN_PERIODIC = "even-periodic"
#: Value encoding of format 2 (docs/table-format.md, "Format 2: 16-bit values").
TOP16 = "f32-top16le"
_DERIVED_OPS = ("mean", "normalized-difference")
_DECODE_ROWS = 1 << 16
PREAMBLE = 56
#: Largest header accepted (64 MiB).
MAX_HEADER_BYTES = 64 << 20
#: Default largest uncompressed payload (4 GiB); pass ``max_payload_bytes`` to raise it.
DEFAULT_MAX_PAYLOAD_BYTES = 4 << 30
#: Largest number of axes (a lookup touches up to 2**axes grid points).
MAX_AXES = 16
#: Deepest nesting of JSON arrays/objects in a header.
MAX_JSON_DEPTH = 64
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
_CHUNK = 1 << 16
_HEADER_FIELDS = ("schema", "description", "axes", "channels", "layout", "attributes", "provenance", "payload")
_U64 = 1 << 64


class TableError(Exception):
    """The file is not a valid scatterbake table (corrupt, truncated, newer major, ...). The only
    exception the reader raises for bad input."""


@dataclass
class Axis:
    name: str
    unit: str
    coords: np.ndarray
    #: None, or ``{"kind": "even-periodic", "period": P}`` (format 3.0): the axis stores 0 … P/2.
    symmetry: dict = None
    #: ``(start, step, count)`` of a uniform axis (its lookups locate ``x`` as the Rust reader
    #: does, from ``(x - start) / step``), None for explicit coordinates.
    uniform: tuple = None

    def fold(self, x: float) -> float:
        """The coordinate a lookup uses for ``x``: on an even-periodic axis of period P,
        ``r = fmod(|x|, P)`` (exact in binary64), then ``P - r`` when ``r > P/2``, the bits of
        every reader (NaN for an infinite ``x``); ``x`` itself on any other axis."""
        if self.symmetry is None:
            return x
        period = self.symmetry["period"]
        if not math.isfinite(x):
            return math.nan
        r = math.fmod(abs(float(x)), period)
        return period - r if r > 0.5 * period else r


@dataclass
class Channel:
    name: str
    unit: str
    meaning: str


@dataclass
class Table:
    header: dict
    axes: list
    channels: list
    data: np.ndarray
    format_version: tuple = field(default=(1, 0))

    def axis(self, name: str) -> Axis:
        for a in self.axes:
            if a.name == name:
                return a
        raise KeyError(f"no axis named {name!r}")

    def channel_index(self, name: str) -> int:
        for i, c in enumerate(self.channels):
            if c.name == name:
                return i
        raise KeyError(f"no channel named {name!r}")

    def channel(self, name: str) -> np.ndarray:
        return self.data[..., self.channel_index(name)]

    def sample(self, coords) -> np.ndarray:
        """Multilinear interpolation of every channel at ``coords`` (one per axis, axis units),
        folded on an even-periodic axis (``Axis.fold``) and clamped at the axis ends: the same
        lookup formula as the Rust ``Table::sample``."""
        if len(coords) != len(self.axes):
            raise ValueError(f"expected {len(self.axes)} coordinates, got {len(coords)}")
        cells = []
        for a, x in zip(self.axes, coords):
            if np.isnan(x):
                raise ValueError(f"coordinate for axis {a.name!r} is NaN")
            if a.symmetry is not None:
                if not math.isfinite(x):
                    raise ValueError(f"coordinate for axis {a.name!r} is {x}: an even-periodic axis needs a finite one")
                x = a.fold(x)
            g = a.coords
            n = len(g)
            if n >= 2 and a.uniform is not None:
                # As the Rust reader: u = (x - start) / step clamped to [0, n - 1].
                start, step, _ = a.uniform
                u = min(max((x - start) / step, 0.0), float(n - 1))
                i = min(int(math.floor(u)), n - 2)
                cells.append((i, u - i))
            elif n < 2 or x <= g[0]:
                cells.append((0, 0.0))
            elif x >= g[-1]:
                cells.append((n - 2, 1.0))
            else:
                i = int(np.searchsorted(g, x, side="right")) - 1
                cells.append((i, (x - g[i]) / (g[i + 1] - g[i])))
        out = np.zeros(len(self.channels))
        for corner in range(1 << len(self.axes)):
            w = 1.0
            idx = []
            skip = False
            for d, (i, t) in enumerate(cells):
                bit = (corner >> d) & 1
                if len(self.axes[d].coords) == 1:
                    if bit:
                        skip = True
                        break
                    idx.append(0)
                    continue
                w *= t if bit else 1.0 - t
                idx.append(i + bit)
            if skip or w == 0.0:
                continue
            out += w * self.data[tuple(idx)].astype(np.float64)
        return out


class _Bad(Exception):
    """Internal: a header rule is broken (message without the file name)."""


def _json_depth_ok(text: str) -> None:
    # Strings removed, then brackets counted: the nesting depth of arrays and objects.
    stripped = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)
    depth = 0
    for m in re.finditer(r"[\[\]{}]", stripped):
        if m.group(0) in "[{":
            depth += 1
            if depth > MAX_JSON_DEPTH:
                raise _Bad(f"JSON: nesting deeper than {MAX_JSON_DEPTH} levels")
        else:
            depth -= 1


def _no_duplicates(pairs):
    d = {}
    for k, v in pairs:
        if k in d:
            raise _Bad(f"JSON: duplicate key `{k}`")
        d[k] = v
    return d


def _refuse_constant(name):
    raise _Bad(f"JSON: {name} is not a JSON number")


def _finite_float(text: str) -> float:
    # JSON numbers must be finite (rule 3): 1e999 overflows to inf and is refused here, while
    # parsing, like the Rust reader ("number out of range"), not later by the field's check.
    v = float(text)
    if not math.isfinite(v):
        raise _Bad("JSON: number out of range")
    return v


def _check_strings(v) -> None:
    # JSON escapes can encode lone surrogates, which are not Unicode scalar values.
    stack = [v]
    while stack:
        x = stack.pop()
        if isinstance(x, str):
            x.encode("utf-8")
        elif isinstance(x, dict):
            for k, y in x.items():
                k.encode("utf-8")
                stack.append(y)
        elif isinstance(x, list):
            stack.extend(x)


def _obj(v, what: str) -> dict:
    if not isinstance(v, dict):
        raise _Bad(f"{what}: expected an object")
    return v


def _field(d: dict, key: str, what: str):
    if key not in d:
        raise _Bad(f"{what}: missing field `{key}`")
    return d[key]


def _str(d: dict, key: str, what: str, optional: bool = False):
    if optional and d.get(key) is None:
        return None
    v = _field(d, key, what)
    if not isinstance(v, str):
        raise _Bad(f"{what}.{key}: expected a string")
    return v


def _uint(v, what: str, limit: int = _U64) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < limit:
        raise _Bad(f"{what}: expected an unsigned integer below {limit}")
    return v


def _float(v, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _Bad(f"{what}: expected a number")
    try:
        return float(v)
    except OverflowError:
        raise _Bad(f"{what}: number out of range") from None


def _parse_header(header_bytes: bytes, major: int, minor: int, max_payload_bytes: int):
    try:
        text = header_bytes.decode("utf-8")
    except UnicodeDecodeError as e:
        raise _Bad(f"JSON: header is not UTF-8 ({e.reason} at byte {e.start})") from None
    _json_depth_ok(text)
    try:
        header = json.loads(
            text,
            object_pairs_hook=_no_duplicates,
            parse_constant=_refuse_constant,
            parse_float=_finite_float,
        )
    except json.JSONDecodeError as e:
        raise _Bad(f"JSON: {e}") from None
    except (RecursionError, ValueError) as e:
        raise _Bad(f"JSON: {e}") from None
    try:
        _check_strings(header)
    except UnicodeEncodeError:
        raise _Bad("JSON: a string holds a lone surrogate") from None
    if not isinstance(header, dict):
        raise _Bad("the header is not a JSON object")
    if minor <= _MINOR_OF[major]:
        for k in header:
            if k not in _HEADER_FIELDS:
                raise _Bad(f"unknown field `{k}` in a format {major}.{minor} header (only a newer minor version may add fields)")
    # Types of every field the reader uses (the fields of format 1.0).
    schema = _obj(_field(header, "schema", "header"), "schema")
    _str(schema, "name", "schema")
    _uint(_field(schema, "version", "schema"), "schema.version", 1 << 32)
    _str(header, "description", "header")
    axes_j = _field(header, "axes", "header")
    chans_j = _field(header, "channels", "header")
    for name, v in (("axes", axes_j), ("channels", chans_j)):
        if not isinstance(v, list):
            raise _Bad(f"{name}: expected an array")
    _obj(_field(header, "attributes", "header"), "attributes")
    prov = _obj(_field(header, "provenance", "header"), "provenance")
    for k in ("tool", "tool_version", "parameters_digest", "created_utc"):
        _str(prov, k, "provenance")
    # `parameters` holds any JSON value (null included) but must be present, as in Rust.
    _field(prov, "parameters", "provenance")
    for k in ("git_commit", "manifest", "entry", "stage"):
        _str(prov, k, "provenance", optional=True)
    layout = _obj(_field(header, "layout", "header"), "layout")
    payload = _obj(_field(header, "payload", "header"), "payload")
    order = _str(layout, "order", "layout")
    dtype = _str(layout, "dtype", "layout")
    axis_order = _field(layout, "axis_order", "layout")
    if not isinstance(axis_order, list) or not all(isinstance(x, str) for x in axis_order):
        raise _Bad("layout.axis_order: expected an array of strings")
    lshape = _field(layout, "shape", "layout")
    if not isinstance(lshape, list):
        raise _Bad("layout.shape: expected an array")
    lshape = [_uint(x, "layout.shape") for x in lshape]
    compression = _str(payload, "compression", "payload")
    cbytes = _uint(_field(payload, "compressed_bytes", "payload"), "payload.compressed_bytes")
    ubytes = _uint(_field(payload, "uncompressed_bytes", "payload"), "payload.uncompressed_bytes")
    _str(payload, "sha256_compressed", "payload")
    _str(payload, "sha256_uncompressed", "payload")
    axes = []  # (name, unit, kind, values-or-(start, step, count))
    symmetries = []  # per axis: None or {"kind", "period"} (format 3.0)
    for i, a in enumerate(axes_j):
        a = _obj(a, f"axes[{i}]")
        name = _str(a, "name", f"axes[{i}]")
        unit = _str(a, "unit", f"axes[{i}]")
        pts = _obj(_field(a, "points", f"axes[{i}]"), f"axes[{i}].points")
        if len(pts) != 1 or next(iter(pts)) not in ("values", "uniform"):
            raise _Bad(f"axes[{i}].points: expected exactly one of `values` or `uniform`")
        if "values" in pts:
            vals = pts["values"]
            if not isinstance(vals, list):
                raise _Bad(f"axes[{i}].points.values: expected an array")
            axes.append((name, unit, "values", [_float(x, f"axes[{i}].points.values") for x in vals]))
        else:
            u = _obj(pts["uniform"], f"axes[{i}].points.uniform")
            start = _float(_field(u, "start", "uniform"), "uniform.start")
            step = _float(_field(u, "step", "uniform"), "uniform.step")
            count = _uint(_field(u, "count", "uniform"), "uniform.count")
            axes.append((name, unit, "uniform", (start, step, count)))
        # Not a field of 1.x and 2.x: ignored there, whatever it holds.
        symmetries.append(_symmetry(a.get("symmetry"), axes[-1], i) if major >= 3 else None)
    channels = []
    derived_j = []
    for i, c in enumerate(chans_j):
        c = _obj(c, f"channels[{i}]")
        channels.append(Channel(_str(c, "name", f"channels[{i}]"), _str(c, "unit", f"channels[{i}]"), _str(c, "meaning", f"channels[{i}]")))
        derived_j.append(c.get("derived"))
    # Structural rules, in the order of the Rust reader.
    if order != "row-major" or dtype not in (("f32le", TOP16) if major >= 2 else ("f32le",)):
        raise _Bad(f"unsupported layout {order} / {dtype}")
    if compression != "zstd":
        raise _Bad(f"unsupported compression `{compression}`")
    if not axes:
        raise _Bad("a table needs at least one axis")
    if len(axes) > MAX_AXES:
        raise _Bad(f"{len(axes)} axes, more than the limit of {MAX_AXES}")
    if not channels:
        raise _Bad("a table needs at least one channel")
    lens = [len(a[3]) if a[2] == "values" else a[3][2] for a in axes]
    for a, n in zip(axes, lens):
        if n == 0:
            raise _Bad(f"axis `{a[0]}` is empty")
    enc = _storage(major, dtype, layout, channels, derived_j)
    shape = lens + [len(channels) if enc is None else len(enc.stored)]
    if shape != lshape:
        raise _Bad(f"layout shape {lshape} disagrees with axes/channels {shape}")
    if axis_order != [a[0] for a in axes] + ["channel"]:
        raise _Bad(f"layout axis_order {axis_order} disagrees with the axis names followed by `channel`")
    nbytes = 4 if enc is None else enc.item_bytes
    for n in shape:
        nbytes *= n
        if nbytes >= _U64:
            raise _Bad(f"shape {shape} overflows a 64-bit byte count")
    if nbytes != ubytes:
        raise _Bad(f"shape {shape} implies {nbytes} bytes, payload.uncompressed_bytes says {ubytes}")
    if nbytes > max_payload_bytes:
        raise _Bad(f"payload of {nbytes} bytes exceeds the reader limit of {max_payload_bytes} bytes (raise it to read this table)")
    if enc is not None:
        enc.check(lens, len(channels), max_payload_bytes)
    for (name, unit, kind, pts) in axes:
        if kind == "values":
            _check_coords(name, np.asarray(pts, dtype=np.float64))
        else:
            start, step, count = pts
            if not math.isfinite(start):
                raise _Bad(f"axis `{name}`: uniform start {start} is not finite")
            if not (math.isfinite(step) and step > 0.0):
                raise _Bad(f"axis `{name}`: uniform step {step} is not finite and > 0")
    # Uniform coordinates are enumerated only once the payload has proved the grid exists.
    return header, axes, symmetries, channels, tuple(shape), cbytes, ubytes, enc


def _f64_text(x: float) -> str:
    """``x`` as the Rust reader prints an f64 in its messages where the two agree: integral
    values without a decimal point (``180``, ``-0``), any other as Python's shortest repr."""
    if math.isfinite(x) and x == int(x) and abs(x) < 1e16:
        return ("-" if math.copysign(1.0, x) < 0 else "") + str(abs(int(x)))
    return repr(x)


def _symmetry(sym, axis, i: int):
    """``axes[i].symmetry`` of a format-3 header, checked (docs/table-format.md, "Symmetric
    axes", rules S1-S5, in the Rust reader's order): None or ``{"kind", "period"}``."""
    if sym is None:
        return None
    what = f"axes[{i}].symmetry"
    if isinstance(sym, list):
        # As the Rust reader's first pass over the JSON words it.
        raise _Bad("JSON: axes[].symmetry must be an object, not an array")
    _obj(sym, what)
    kind = _str(sym, "kind", what)
    period = _float(_field(sym, "period", what), f"{what}.period")
    name, _, kind_pts, pts = axis
    if kind != EVEN_PERIODIC:
        raise _Bad(f"axis `{name}`: symmetry.kind `{kind}` is not `{EVEN_PERIODIC}`")
    if not (math.isfinite(period) and period > 0.0):
        raise _Bad(f"axis `{name}`: symmetry.period {_f64_text(period)} is not finite and > 0")
    n = len(pts) if kind_pts == "values" else pts[2]
    if n < 2:
        raise _Bad(f"axis `{name}`: an even-periodic axis needs at least 2 samples (it has {n})")
    if kind_pts == "values":
        first, last = pts[0], pts[-1]
    else:
        start, step, count = pts
        first, last = start, start + step * float(count - 1)
    half = 0.5 * period
    if first != 0.0:
        raise _Bad(f"axis `{name}`: an even-periodic axis starts at 0 (its first coordinate is {_f64_text(first)})")
    if last != half:
        raise _Bad(f"axis `{name}`: an even-periodic axis ends at half its period, {_f64_text(half)} (its last coordinate is {_f64_text(last)})")
    return {"kind": kind, "period": period}


@dataclass
class _Storage:
    """How a format-2 payload stores its values (docs/table-format.md, "16-bit values" and
    "Derived channels"): ``item_bytes`` 4 (f32) or 2 (16-bit codes: the upper 16 bits of each
    value's f32 after the sign bit), an optional previous-row predictor (``stride``, ``block``:
    codes stored as differences to the code ``stride`` values earlier within each block), and
    channels derived from two stored ones."""

    item_bytes: int
    stored: list  # indices (header order) of the stored channels
    derived: list  # (index, op, index of a, index of b)
    stride: int = 0  # 0: no predictor
    block: int = 0
    block_axes: int = 0  # k: a block is the last k axes times the stored channels

    def check(self, lens, n_channels: int, max_payload_bytes: int) -> None:
        s, b, ns = self.stride, self.block, len(self.stored)
        if self.stride or self.block:
            if s == 0:
                raise _Bad("layout.predictor.stride is 0; it must be at least 1")
            if s > b:
                raise _Bad(f"layout.predictor.stride {s} exceeds layout.predictor.block {b}")
            if b % s:
                raise _Bad(f"layout.predictor.block {b} is not a multiple of layout.predictor.stride {s}")
            prod = ns
            for k, n in enumerate(reversed(lens), start=1):
                prod *= n
                if prod >= _U64:
                    break
                if prod == b:
                    self.block_axes = k
                    break
            if self.block_axes == 0:
                raise _Bad(f"layout.predictor.block {b} is not the values of the last axes of the table")
        decoded = 4 * n_channels
        for n in lens:
            decoded *= n
        if decoded > max_payload_bytes:
            raise _Bad(f"decoded values of {decoded} bytes exceed the reader limit of {max_payload_bytes} bytes (raise it to read this table)")

    def decode(self, stored, n_channels: int) -> np.ndarray:
        """Every channel from the stored values: f32 bytes, or the 16-bit codes with the
        predictor already undone (``_CodeCheck.codes``)."""
        ns = len(self.stored)
        if self.item_bytes == 4:
            values = np.frombuffer(stored, dtype="<f4").reshape(-1, ns)
        else:
            values = stored.reshape(-1, ns)
        out = np.empty((values.shape[0], n_channels), dtype=np.float32)
        # In chunks, so that the temporaries stay small beside the decoded values.
        for lo in range(0, values.shape[0], _DECODE_ROWS):
            hi = min(lo + _DECODE_ROWS, values.shape[0])
            chunk = out[lo:hi]
            if self.item_bytes == 4:
                chunk[:, self.stored] = values[lo:hi]
            else:
                chunk[:, self.stored] = (values[lo:hi].astype(np.uint32) << np.uint32(15)).view(np.float32)
            for i, op, ia, ib in self.derived:
                a = chunk[:, ia].astype(np.float64)
                b = chunk[:, ib].astype(np.float64)
                if op == "mean":
                    chunk[:, i] = 0.5 * (a + b)
                else:
                    total = a + b
                    with np.errstate(divide="ignore", invalid="ignore"):
                        chunk[:, i] = np.where(total == 0.0, 0.0, (a - b) / total)
        return out.reshape(-1)


class _CodeCheck:
    """Undoes the predictor over the whole payload as it streams past (every entry, also those
    not kept) and remembers the first stored value whose code is not finite, as the Rust reader
    does: a file is accepted or refused as a whole. Memory: one row of codes and a chunk."""

    def __init__(self, storage: _Storage, lo: int, hi: int):
        self.lo, self.hi = lo, hi  # the stored values whose codes are kept
        self.parts = []
        self.stride = storage.stride or 1
        self.rows_per_block = (storage.block // storage.stride) if storage.stride else 1
        self.predicted = bool(storage.stride)
        self.ring = np.zeros(self.stride, dtype=np.uint16)
        self.pending = b""
        self.index = 0  # stored values consumed
        self.bad = None

    def feed(self, b: bytes) -> None:
        b = self.pending + b
        usable = len(b) - len(b) % 2
        self.pending = b[usable:]
        values = np.frombuffer(b[:usable], dtype="<u2")
        while values.size and self.bad is None:
            col = self.index % self.stride
            if col or values.size < self.stride:
                # Up to the end of the current row, against the ring's columns.
                n = min(values.size, self.stride - col)
                self._piece(values[:n], col)
            else:
                # Whole rows at once: a running sum that restarts at block starts.
                n = (values.size // self.stride) * self.stride
                self._rows(values[:n].reshape(-1, self.stride))
            values = values[n:]

    def _piece(self, stored, col: int) -> None:
        row = self.index // self.stride
        codes = stored + self.ring[col:col + stored.size] if self.predicted and row % self.rows_per_block else stored.copy()
        self.ring[col:col + stored.size] = codes
        self._check(codes)

    def _rows(self, stored) -> None:
        k = stored.shape[0]
        rows = self.index // self.stride + np.arange(k)
        restart = (rows % self.rows_per_block == 0) | (not self.predicted)
        first = stored[0] if restart[0] else stored[0] + self.ring
        arr = np.concatenate([first[None, :], stored[1:]])
        sums = np.cumsum(arr, axis=0, dtype=np.uint16)
        last = np.maximum.accumulate(np.where(restart, np.arange(k), 0))
        base = np.where((last > 0)[:, None], sums[np.maximum(last - 1, 0)], np.uint16(0))
        codes = (sums - base).astype(np.uint16)
        self.ring = codes[-1].copy()
        self._check(codes.reshape(-1))

    def _check(self, codes) -> None:
        over = np.flatnonzero(codes >= 0xFF00)
        if over.size and self.bad is None:
            self.bad = (self.index + int(over[0]), int(codes[over[0]]))
        a, c = max(self.lo, self.index), min(self.hi, self.index + codes.size)
        if a < c:
            self.parts.append(codes[a - self.index:c - self.index].copy())
        self.index += codes.size

    def codes(self) -> np.ndarray:
        return np.concatenate(self.parts) if self.parts else np.zeros(0, dtype=np.uint16)


def _storage(major: int, dtype: str, layout: dict, channels, derived_j):
    """The storage of a format-2 header (None: f32 with every channel stored, the only storage
    of format 1, whose readers ignore `predictor` and `derived`)."""
    pred = layout.get("predictor") if major >= 2 else None
    if major < 2 or (dtype != TOP16 and pred is None and all(d is None for d in derived_j)):
        return None
    if pred is not None and dtype != TOP16:
        raise _Bad(f"layout.predictor needs layout.dtype `{TOP16}` (this layout is `{dtype}`)")
    names = [c.name for c in channels]
    if any(d is not None for d in derived_j) and len(set(names)) != len(names):
        raise _Bad("channel names must be unique in a table with derived channels")
    stored = [i for i, d in enumerate(derived_j) if d is None]
    derived = []
    for i, d in enumerate(derived_j):
        if d is None:
            continue
        what = f"channel `{names[i]}`: derived"
        if not isinstance(d, dict):
            raise _Bad(f"{what} must be an object")
        op = _str(d, "op", what)
        if op not in _DERIVED_OPS:
            raise _Bad(f"{what}.op `{op}` is not `mean` or `normalized-difference`")
        of = _field(d, "of", what)
        if not isinstance(of, list) or not all(isinstance(x, str) for x in of):
            raise _Bad(f"{what}.of: expected an array of channel names")
        if len(of) != 2:
            raise _Bad(f"{what}.of must name two channels ({len(of)} given)")
        idx = []
        for x in of:
            if x not in names or derived_j[names.index(x)] is not None:
                raise _Bad(f"{what}.of names `{x}`, which is not a stored channel of the table")
            idx.append(names.index(x))
        derived.append((i, op, idx[0], idx[1]))
    st = _Storage(item_bytes=2 if dtype == TOP16 else 4, stored=stored, derived=derived)
    if pred is not None:
        if not isinstance(pred, dict):
            raise _Bad("layout.predictor must be an object")
        kind = _str(pred, "kind", "layout.predictor")
        if kind != "previous-row":
            raise _Bad(f"layout.predictor.kind `{kind}` is not `previous-row`")
        st.stride = _uint(_field(pred, "stride", "layout.predictor"), "layout.predictor.stride")
        st.block = _uint(_field(pred, "block", "layout.predictor"), "layout.predictor.block")
    return st


def _check_coords(name: str, coords) -> None:
    if not np.all(np.isfinite(coords)):
        raise _Bad(f"axis `{name}`: a coordinate is not finite")
    if len(coords) > 1 and not np.all(np.diff(coords) > 0):
        raise _Bad(f"axis `{name}`: coordinates are not strictly increasing")


def _axis_coords(name: str, kind: str, pts):
    if kind == "values":
        return np.asarray(pts, dtype=np.float64)
    start, step, count = pts
    with np.errstate(over="ignore", invalid="ignore"):
        coords = start + step * np.arange(count, dtype=np.float64)
    _check_coords(name, coords)
    return coords


def _frame_rules(content_size: int):
    """Step 6 (RFC 8878: exactly one frame declaring its content size, no dictionary) as a
    coroutine over the payload's bytes: it yields ``(offset, n)``, the next ``n`` bytes it needs
    and where they start, receives them, and returns the offset where the frame ends."""
    f = yield 0, 5
    if f[:4] != _ZSTD_MAGIC:
        raise _Bad("payload does not start with a zstd frame (magic 28 b5 2f fd)")
    fhd = f[4]
    fcs_flag, single, reserved, checksum, dict_flag = fhd >> 6, (fhd >> 5) & 1, (fhd >> 3) & 1, (fhd >> 2) & 1, fhd & 3
    if reserved:
        raise _Bad("zstd frame header has its reserved bit set")
    if dict_flag:
        raise _Bad("zstd frame names a dictionary")
    pos = 5 + (0 if single else 1)
    fcs_len = {0: 1 if single else 0, 1: 2, 2: 4, 3: 8}[fcs_flag]
    if fcs_len == 0:
        raise _Bad("zstd frame does not declare its content size")
    f = yield pos, fcs_len
    declared = int.from_bytes(f, "little") + (256 if fcs_len == 2 else 0)
    pos += fcs_len
    if declared != content_size:
        raise _Bad(f"zstd frame declares {declared} content bytes, payload.uncompressed_bytes says {content_size}")
    while True:
        f = yield pos, 3
        bh = f[0] | f[1] << 8 | f[2] << 16
        pos += 3
        btype = (bh >> 1) & 3
        if btype == 3:
            raise _Bad("zstd block of reserved type")
        pos += 1 if btype == 1 else bh >> 3
        if bh & 1:
            return pos + (4 if checksum else 0)


class _FrameWalker:
    """Checks the frame structure as the compressed bytes stream past (``feed`` them in order, in
    pieces of any size, then ``finish``), keeping a few bytes of state: the verdict and its
    message do not depend on the pieces."""

    def __init__(self, content_size: int):
        self._rules = _frame_rules(content_size)
        self._field = bytearray()
        self.fed = 0
        self.error = None
        self.end = None
        self._next, self._need = next(self._rules)

    def feed(self, b: bytes) -> None:
        i, n = 0, len(b)
        while i < n and self.error is None and self.end is None:
            if self.fed < self._next:
                k = min(self._next - self.fed, n - i)
                self.fed += k
                i += k
                continue
            k = min(self._need - len(self._field), n - i)
            self._field += b[i:i + k]
            self.fed += k
            i += k
            if len(self._field) == self._need:
                field, self._field = bytes(self._field), bytearray()
                try:
                    self._next, self._need = self._rules.send(field)
                except StopIteration as stop:
                    self.end = stop.value
                except _Bad as e:
                    self.error = str(e)
        self.fed += n - i

    def finish(self) -> None:
        """Raise ``_Bad`` with the first broken rule once every byte has been fed."""
        if self.error is not None:
            raise _Bad(self.error)
        if self.end is None and self._next == 0:
            raise _Bad("payload does not start with a zstd frame (magic 28 b5 2f fd)")
        if self.end is None or self.fed < self.end:
            raise _Bad("the zstd frame is truncated")
        if self.fed > self.end:
            raise _Bad(f"{self.fed - self.end} bytes follow the zstd frame (the payload must be exactly one frame)")


class _CompressedStream:
    """The compressed payload as the decompressor pulls it from the file: every byte is hashed
    and walked for the frame structure on its way. While ``stop_on_frame_error`` is set, a
    broken frame rule ends the stream (the frame is refused anyway)."""

    def __init__(self, f, size: int, content_size: int):
        self._f = f
        self.left = size
        self.sha = hashlib.sha256()
        self.frame = _FrameWalker(content_size)
        self.stop_on_frame_error = True

    def read(self, n: int = -1) -> bytes:
        if self.stop_on_frame_error and self.frame.error is not None:
            return b""
        n = self.left if n is None or n < 0 else min(n, self.left)
        b = self._f.read(min(n, 1 << 20)) if n else b""
        self.left -= len(b)
        self.sha.update(b)
        self.frame.feed(b)
        return b

    def drain(self) -> None:
        self.stop_on_frame_error = False
        while self.read(_CHUNK):
            pass


def _read_exact(f, n: int) -> bytes:
    """Read up to ``n`` bytes in chunks, so a declared size allocates only what is present."""
    parts, got = [], 0
    while got < n:
        b = f.read(min(n - got, 1 << 20))
        if not b:
            break
        parts.append(b)
        got += len(b)
    return b"".join(parts)


def _read_table(f, name: str, file_len, max_payload_bytes: int, entry=None) -> Table:
    magic = f.read(8)
    if len(magic) < 8 or magic != MAGIC:
        raise TableError(f"{name}: not a scatterbake table (bad magic bytes {magic.hex()})")
    rest = f.read(PREAMBLE - 8)
    if len(rest) < PREAMBLE - 8:
        raise TableError(f"{name}: file truncated: {8 + len(rest)} bytes, shorter than the {PREAMBLE}-byte preamble")
    pre = magic + rest
    major, minor, flags, hlen = struct.unpack_from("<HHIQ", pre, 8)
    if major > FORMAT_MAJOR:
        raise TableError(f"{name}: table format version {major}.{minor} is newer than this reader (supports 1.x to {FORMAT_MAJOR}.x)")
    if major == 0:
        raise TableError(f"{name}: header is not valid: format major version 0 does not exist")
    if flags != 0:
        raise TableError(f"{name}: header is not valid: reserved flags at offset 12 are {flags:#010x}, must be 0")
    if hlen > MAX_HEADER_BYTES:
        raise TableError(f"{name}: header length {hlen} (offset 16) exceeds the limit of {MAX_HEADER_BYTES} bytes")
    if file_len is not None and PREAMBLE + hlen > file_len:
        raise TableError(f"{name}: file truncated: header needs {hlen} bytes, {file_len - PREAMBLE} present")
    header_bytes = _read_exact(f, hlen)
    if len(header_bytes) < hlen:
        raise TableError(f"{name}: file truncated: header needs {hlen} bytes, {len(header_bytes)} present")
    if hashlib.sha256(pre[:24] + header_bytes).digest() != pre[24:56]:
        raise TableError(f"{name}: header checksum mismatch (file is corrupt)")
    try:
        header, axes, symmetries, channels, shape, cbytes, ubytes, enc = _parse_header(header_bytes, major, minor, max_payload_bytes)
    except _Bad as e:
        raise TableError(f"{name}: header is not valid: {e}") from None
    size = 4 if enc is None else enc.item_bytes
    if entry is None:
        first, count = 0, ubytes // size
    else:
        try:
            first, count = _entry_values(axes, shape[-1], entry)
            if enc is not None and enc.block_axes and len(entry) > len(axes) - enc.block_axes:
                raise _Bad(f"the 16-bit values decode in blocks of the last {enc.block_axes} axes: fix at most the first {len(axes) - enc.block_axes}")
        except _Bad as e:
            raise TableError(f"{name}: cannot open the entry: {e}") from None
    # 16-bit codes are decoded as they stream past (the predictor needs every earlier row of
    # the block), keeping those of the entry; no stored bytes are kept then.
    check = _CodeCheck(enc, first, first + count) if enc is not None and enc.item_bytes == 2 else None
    keep = size * count if check is None else 0
    raw = _read_payload(f, name, file_len, header["payload"], PREAMBLE + hlen, cbytes, ubytes, size * first, keep, None if check is None else check.feed)
    if check is not None and check.bad is not None:
        i, code = check.bad
        raise TableError(f"{name}: payload is not valid: stored value {i} decodes to code {code:#06x}, which is not a finite value (all exponent bits set)")
    try:
        axes = [Axis(an, unit, _axis_coords(an, kind, pts), sym, pts if kind == "uniform" else None)
                for (an, unit, kind, pts), sym in zip(axes, symmetries)]
    except _Bad as e:
        raise TableError(f"{name}: header is not valid: {e}") from None
    if entry is not None:
        # A fixed axis holds one sample, constant under any coordinate: no symmetry.
        axes = [Axis(a.name, a.unit, a.coords[i:i + 1].copy()) for a, i in zip(axes, entry)] + axes[len(entry):]
        shape = tuple(len(a.coords) for a in axes) + (len(channels),)
    if enc is None:
        data = np.frombuffer(raw, dtype="<f4").reshape(shape)
    else:
        try:
            data = enc.decode(raw if check is None else check.codes(), len(channels)).reshape(shape[:-1] + (len(channels),))
        except _Bad as e:
            raise TableError(f"{name}: payload is not valid: {e}") from None
    data.flags.writeable = False
    return Table(header=header, axes=axes, channels=channels, data=data, format_version=(major, minor))


def _entry_values(axes, n_channels: int, entry) -> tuple:
    """The values ``(first, count)`` of the row-major payload that ``entry`` (indices of the
    leading axes) selects; errors name the axis, as the Rust reader's."""
    lens = [len(a[3]) if a[2] == "values" else a[3][2] for a in axes]
    if len(entry) > len(axes):
        names = ", ".join(a[0] for a in axes)
        raise _Bad(f"{len(entry)} indices {list(entry)}, more than the table's axes ({names})")
    first = 0
    for a, n, i in zip(axes, lens, entry):
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < n:
            raise _Bad(f"index {i} of axis `{a[0]}` is out of range (the axis has {n} samples, indices 0 to {n - 1})")
        first = first * n + i
    count = n_channels
    for n in lens[len(entry):]:
        count *= n
    return first * count, count


def _read_payload(f, name: str, file_len, payload: dict, start: int, cbytes: int, ubytes: int, lo: int, hi_len: int, sink=None) -> bytearray:
    """Steps 5-7 in one pass over the file: the compressed bytes stream through their SHA-256
    and the frame check into the decompressor, the decompressed bytes through their SHA-256, and
    only the bytes [lo, lo + hi_len) stay in memory. The compressed bytes the decompressor
    leaves are still read and hashed, so a file breaking several rules is refused by the first
    in the document's order."""
    end = start + cbytes
    if end >= _U64:
        raise TableError(f"{name}: header is not valid: payload.compressed_bytes {cbytes} overflows the file size")
    if file_len is not None:
        if file_len < end:
            raise TableError(f"{name}: file truncated: payload needs {cbytes} bytes, {file_len - start} present")
        if file_len > end:
            raise TableError(f"{name}: {file_len - end} unexpected bytes after the payload")
    stream = _CompressedStream(f, cbytes, ubytes)
    kept, sha_u, failure = _decompress(stream, ubytes, lo, lo + hi_len, sink)
    stream.drain()
    if stream.left:
        raise TableError(f"{name}: file truncated: payload needs {cbytes} bytes, {cbytes - stream.left} present")
    if file_len is None:
        extra = len(f.read(1 << 20))
        if extra:
            raise TableError(f"{name}: {extra} unexpected bytes after the payload")
    if stream.sha.hexdigest() != payload["sha256_compressed"]:
        raise TableError(f"{name}: payload compressed checksum mismatch (file is corrupt)")
    try:
        stream.frame.finish()
    except _Bad as e:
        raise TableError(f"{name}: payload cannot be decompressed: {e}") from None
    if failure is not None:
        raise TableError(f"{name}: payload cannot be decompressed: {failure}")
    if sha_u != payload["sha256_uncompressed"]:
        raise TableError(f"{name}: payload uncompressed checksum mismatch (file is corrupt)")
    return kept


def _decompress(stream, ubytes: int, lo: int, hi: int, sink=None):
    """Decompress the frame in chunks of at most 64 KiB, checking its size, hashing every byte
    and keeping the bytes [lo, hi). Returns (kept bytes, SHA-256 hex, the step-7 failure or
    None)."""
    kept = bytearray()
    h = hashlib.sha256()
    got = 0
    try:
        with zstandard.ZstdDecompressor().stream_reader(stream, read_size=_CHUNK, read_across_frames=False) as r:
            while True:
                b = r.read(min(ubytes - got, _CHUNK) or 1)
                if got == ubytes:
                    if b:
                        return kept, None, f"payload decompresses to more than the {ubytes} bytes the header says"
                    break
                if not b:
                    return kept, None, f"payload decompresses to {got} bytes, header says {ubytes}"
                h.update(b)
                if sink is not None:
                    sink(b)
                a, c = max(got, lo), min(got + len(b), hi)
                if a < c:
                    kept += b[a - got:c - got]
                got += len(b)
    except zstandard.ZstdError as e:
        return kept, None, str(e)
    return kept, h.hexdigest(), None


def read_table_bytes(buf: bytes, name: str = "<bytes>", max_payload_bytes: int = DEFAULT_MAX_PAYLOAD_BYTES, entry=None) -> Table:
    """Parse and fully verify a table held in memory (``entry`` as in ``open_table``)."""
    return _read_table(io.BytesIO(buf), name, len(buf), max_payload_bytes, None if entry is None else list(entry))


#: Schema of tensor-train tables (docs/table-format.md, "Tensor-train tables").
TT_SCHEMA = "fur-medulla-tt"
TT_SCHEMA_VERSION = 1


def _tt_uint_list(at: dict, key: str) -> list:
    if key not in at:
        raise _Bad(f"missing attribute `{key}`")
    v = at[key]
    if not isinstance(v, list):
        raise _Bad(f"attribute `{key}` is not an array")
    if len(v) > MAX_AXES + 1:
        raise _Bad(f"attribute `{key}` has {len(v)} entries (at most {MAX_AXES + 1})")
    out = []
    for x in v:
        if isinstance(x, bool) or not isinstance(x, int) or x < 0 or x >= _U64:
            raise _Bad(f"attribute `{key}` holds {json.dumps(x)}, not a non-negative integer")
        out.append(x)
    return out


def _tt_contract(cores, dims, ranks, prefix=()) -> np.ndarray:
    """Left-to-right contraction in the order docs/table-format.md specifies (f64, multiply
    then add, a = 0 .. r-1 in order), for the indices ``prefix`` of the first modes (the block
    of the dense table they fix)."""
    m = np.ones((1, 1), dtype=np.float64)
    for k, core in enumerate(cores):
        r0, n, r1 = ranks[k], dims[k], ranks[k + 1]
        c = core.reshape(r0, n, r1)
        if k < len(prefix):
            c = c[:, prefix[k]:prefix[k] + 1, :]
            n = 1
        nxt = np.zeros((m.shape[0], n, r1), dtype=np.float64)
        for a in range(r0):
            nxt += m[:, a][:, None, None] * c[a][None, :, :]
        m = nxt.reshape(-1, r1)
    return m[:, 0]


#: Largest number of multiply-adds a reconstruction may take (docs/table-format.md, decision TF-2).
TT_MAX_MULTIPLY_ADDS = 1 << 34
_TT_BLOCK_BYTES = 8 << 20


def _tt_cost(dims, ranks) -> tuple:
    """``(fixed, bytes, multiply_adds)`` of the reconstruction, as the Rust reader's
    ``reconstruction_cost``: blocks fix the first ``fixed`` modes (the fewest whose blocks keep
    two consecutive f64 intermediates within 8 MiB, else all but the last); ``bytes`` counts the
    f32 values, the f64 cores and a block's two largest consecutive intermediates. Both saturate
    at 2**64 - 1 like the Rust reader's."""
    d = len(dims)
    top = _U64 - 1

    def block(fixed):
        blocks = math.prod(dims[:fixed])
        work = sum(ranks[k] * ranks[k + 1] for k in range(fixed))
        peak = max([1] + [ranks[k] + ranks[k + 1] for k in range(fixed)])
        rows = 1
        for k in range(fixed, d):
            work += rows * ranks[k] * dims[k] * ranks[k + 1]
            peak = max(peak, rows * ranks[k] + rows * dims[k] * ranks[k + 1])
            rows *= dims[k]
        return 8 * peak, blocks * work

    fixed = next((f for f in range(d) if block(f)[0] <= _TT_BLOCK_BYTES), d - 1)
    peak, work = block(fixed)
    cores = sum(ranks[k] * dims[k] * ranks[k + 1] for k in range(d))
    return fixed, min(4 * math.prod(dims) + 8 * cores + peak, top), min(work, top)


def reconstruct_tensor_train(t: Table, name: str = "<table>", max_payload_bytes: int = DEFAULT_MAX_PAYLOAD_BYTES) -> Table:
    """The dense table a tensor-train table (``fur-medulla-tt/1``) holds, after checking every
    rule of docs/table-format.md ("Tensor-train tables"); values bit-identical to the Rust
    reader's up to the last bit of ``exp`` for the logarithmic form (measured: see
    docs/python.md). Raises TableError naming the table and the rule."""
    try:
        return _reconstruct(t, max_payload_bytes)
    except _Bad as e:
        raise TableError(f"{name}: tensor-train table is not valid: {e}") from None
    except MemoryError:
        raise TableError(f"{name}: out of memory reconstructing the tensor train") from None


def _reconstruct(t: Table, max_payload_bytes: int) -> Table:
    h = t.header
    schema = h["schema"]
    if schema["name"] != TT_SCHEMA:
        raise _Bad(f"schema {schema['name']}/{schema['version']} is not {TT_SCHEMA}")
    if schema["version"] != TT_SCHEMA_VERSION:
        raise _Bad(f"schema version {schema['version']} is not supported (this reader knows {TT_SCHEMA}/{TT_SCHEMA_VERSION})")
    if len(t.axes) != 1 or len(t.channels) != 1:
        raise _Bad(f"needs exactly one axis and one channel (has {len(t.axes)} and {len(t.channels)})")
    at = h["attributes"]
    dims = _tt_uint_list(at, "dims")
    ranks = _tt_uint_list(at, "ranks")
    offsets = _tt_uint_list(at, "core_offsets")
    d = len(dims)
    if d == 0 or d > MAX_AXES:
        raise _Bad(f"{d} modes in `dims` (1 to {MAX_AXES})")
    if len(ranks) != d + 1 or len(offsets) != d + 1:
        raise _Bad(f"inconsistent ranks/dims: {d} dims need {d + 1} ranks and {d + 1} core offsets, found {len(ranks)} and {len(offsets)}")
    for k, n in enumerate(dims):
        if n == 0:
            raise _Bad(f"dims[{k}] is 0")
    if ranks[0] != 1 or ranks[d] != 1:
        raise _Bad(f"inconsistent ranks: the first and last rank must be 1 (ranks {ranks})")
    total = 1
    for n in dims:
        total *= n
    if total * 4 > max_payload_bytes:
        raise _Bad(f"dims {dims} describe more than the reader's limit of {max_payload_bytes} bytes")
    for k in range(d):
        if ranks[k] == 0:
            raise _Bad(f"inconsistent ranks: ranks[{k}] is 0")
        if ranks[k + 1] > ranks[k] * dims[k] or ranks[k] > dims[k] * ranks[k + 1]:
            raise _Bad(f"inconsistent ranks/dims: core {k} is {ranks[k]} x {dims[k]} x {ranks[k + 1]}, a rank exceeds its unfolding")
    fixed, need, work = _tt_cost(dims, ranks)
    if need > max_payload_bytes:
        raise _Bad(f"the reconstruction needs {need} bytes (f32 values, f64 cores and intermediates), more than the reader's limit of {max_payload_bytes} bytes")
    if work > TT_MAX_MULTIPLY_ADDS:
        raise _Bad(f"the reconstruction takes {work} multiply-adds, more than the limit of {TT_MAX_MULTIPLY_ADDS} (dims {dims}, ranks {ranks})")
    values = t.data.reshape(-1)
    nv = values.shape[0]
    if offsets[0] != 0 or offsets[d] != nv:
        raise _Bad(f"core offsets must run from 0 to the {nv} stored values (found {offsets[0]} .. {offsets[d]})")
    cores = []
    for k in range(d):
        size = ranks[k] * dims[k] * ranks[k + 1]
        stored = offsets[k + 1] - offsets[k]
        if stored != size:
            held = "a negative number of" if stored < 0 else str(stored)
            raise _Bad(f"inconsistent ranks/dims: core {k} holds {held} values, ranks and dims imply {ranks[k]} x {dims[k]} x {ranks[k + 1]}")
        core = values[offsets[k]:offsets[k + 1]]
        bad = np.flatnonzero(~np.isfinite(core))
        if bad.size:
            raise _Bad(f"core {k} holds a non-finite value at {int(bad[0])}")
        cores.append(core.astype(np.float64))
    src_axes = at.get("source_axes")
    if not isinstance(src_axes, list):
        raise _Bad("missing attribute `source_axes`" if src_axes is None else "attribute `source_axes`: expected an array")
    axes = []
    for i, a in enumerate(src_axes):
        a = _obj(a, f"source_axes[{i}]")
        an = _str(a, "name", f"source_axes[{i}]")
        unit = _str(a, "unit", f"source_axes[{i}]")
        pts = _obj(_field(a, "points", f"source_axes[{i}]"), f"source_axes[{i}].points")
        if len(pts) != 1 or next(iter(pts)) not in ("values", "uniform"):
            raise _Bad(f"source_axes[{i}].points: expected exactly one of `values` or `uniform`")
        if "values" in pts:
            vals = pts["values"]
            if not isinstance(vals, list):
                raise _Bad(f"source_axes[{i}].points.values: expected an array")
            axes.append((an, unit, "values", [_float(x, "points.values") for x in vals]))
        else:
            u = _obj(pts["uniform"], f"source_axes[{i}].points.uniform")
            axes.append((an, unit, "uniform", (_float(_field(u, "start", "uniform"), "uniform.start"), _float(_field(u, "step", "uniform"), "uniform.step"), _uint(_field(u, "count", "uniform"), "uniform.count"))))
    lens = [len(a[3]) if a[2] == "values" else a[3][2] for a in axes]
    if len(axes) != d or lens != dims:
        raise _Bad(f"inconsistent ranks/dims: source axes of lengths {lens} for dims {dims}")
    for (an, unit, kind, pts) in axes:
        if kind == "uniform":
            start, step, count = pts
            if not math.isfinite(start):
                raise _Bad(f"source axis: axis `{an}`: uniform start {start} is not finite")
            if not (math.isfinite(step) and step > 0.0):
                raise _Bad(f"source axis: axis `{an}`: uniform step {step} is not finite and > 0")
    coords = []
    for (an, unit, kind, pts) in axes:
        try:
            c = _axis_coords(an, kind, pts)
            if kind == "values":
                _check_coords(an, c)
        except _Bad as e:
            raise _Bad(f"source axis: {e}") from None
        coords.append(Axis(an, unit, c, None, pts if kind == "uniform" else None))
    axes = coords
    ch = _obj(at.get("source_channel"), "attribute `source_channel`")
    channel = Channel(_str(ch, "name", "source_channel"), _str(ch, "unit", "source_channel"), _str(ch, "meaning", "source_channel"))
    src_schema = at.get("source_schema")
    m = re.fullmatch(r"(.+)/(\d+)", src_schema) if isinstance(src_schema, str) else None
    if m is None:
        raise _Bad(f"attribute `source_schema` is `{src_schema}`, not NAME/VERSION")
    log_floor = at.get("log_floor")
    if log_floor is not None and (isinstance(log_floor, bool) or not isinstance(log_floor, (int, float)) or not math.isfinite(log_floor) or log_floor <= 0):
        raise _Bad(f"`log_floor` is {json.dumps(log_floor)}, not a positive number")
    src_attrs = at.get("source_attributes", {})
    if not isinstance(src_attrs, dict):
        raise _Bad("attribute `source_attributes` is not an object")
    out = np.empty(total, dtype=np.float32)
    size = math.prod(dims[fixed:])
    for b, prefix in enumerate(itertools.product(*(range(n) for n in dims[:fixed]))):
        v = _tt_contract(cores, dims, ranks, prefix)
        with np.errstate(over="ignore"):
            if log_floor is not None:
                v = np.exp(v)
            v = v.astype(np.float32)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise _Bad(f"reconstructed value {b * size + int(bad[0])} is not finite (after exp and rounding to f32)")
        out[b * size:(b + 1) * size] = v
    attributes = dict(src_attrs)
    for k in ("rel_frobenius_error", "max_abs_error", "max_abs_error_rel_to_max", "ranks", "rel_tol", "reconstruction_error"):
        if k in at:
            attributes[f"tt_{k}"] = at[k]
    attributes["tt_payload_sha256"] = h["payload"]["sha256_uncompressed"]
    header = {
        "schema": {"name": m.group(1), "version": int(m.group(2))},
        "description": f"{at.get('source_description', '')} (reconstructed from tensor train)",
        "axes": src_axes,
        "channels": [{"name": channel.name, "unit": channel.unit, "meaning": channel.meaning}],
        "attributes": attributes,
        "provenance": h["provenance"],
    }
    return Table(header=header, axes=axes, channels=[channel], data=out.reshape(tuple(dims) + (1,)), format_version=t.format_version)


def open_table(path, max_payload_bytes: int = DEFAULT_MAX_PAYLOAD_BYTES, reconstruct: bool = True, entry=None) -> Table:
    """Open and fully verify a ``.sbt`` file, streaming it (memory bounded by the data present
    and by ``max_payload_bytes``). A tensor-train table (``fur-medulla-tt/1``) is checked and
    reconstructed into the dense table it holds unless ``reconstruct=False``.

    ``entry`` (a sequence of indices of the first axes, e.g. ``(i_radius, i_wavelength,
    i_elevation)``) keeps only that entry: the file is verified as a whole (every checksum, the
    limit on the whole payload) while it streams past, and memory is bounded by the entry
    (docs/table-format.md, "Reading one entry"). ``t.axes`` keeps every axis, a fixed one with
    its chosen coordinate alone, and ``t.data`` has length 1 on it; ``t.header`` is the file's
    header. A tensor-train table is reconstructed whole only: with ``entry`` it is refused unless
    ``reconstruct=False``."""
    t = _open_raw(path, max_payload_bytes, entry)
    if reconstruct and t.header["schema"]["name"] == TT_SCHEMA:
        if entry is not None:
            raise TableError(f"{path}: cannot open the entry: a tensor-train table is reconstructed whole (open it without an entry, or with reconstruct=False)")
        return reconstruct_tensor_train(t, str(path), max_payload_bytes)
    return t


def _open_raw(path, max_payload_bytes: int, entry=None) -> Table:
    import os
    import stat

    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            file_len = st.st_size if stat.S_ISREG(st.st_mode) else None
            return _read_table(f, str(path), file_len, max_payload_bytes, None if entry is None else list(entry))
    except OSError as e:
        raise TableError(f"{path}: {e.strerror or e}") from None
    except MemoryError:
        raise TableError(f"{path}: out of memory reading the table") from None
