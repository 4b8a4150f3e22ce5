"""Reader for scatterbake tables (``.sbt``), format 1.x. Needs numpy and zstandard.

    import scatterbake_table as sbt
    t = sbt.open_table("tables/mie.sbt")      # verifies every checksum
    t.axes            # list of Axis(name, unit, coords: numpy float64 array)
    t.channels        # list of Channel(name, unit, meaning)
    t.data            # numpy float32 array, shape = axis lengths + (number of channels,)
    t.channel("phase")            # view without the channel dimension
    t.sample([650.0, 500.0, 138.0])  # multilinear lookup of every channel (clamped), like Rust

Byte layout (see docs/table-format.md): magic ``SBTABLE\\0`` (8 bytes), format major and minor
(u16 LE each), flags (u32 LE), header length H (u64 LE), SHA-256 of bytes [0, 24) + header,
the UTF-8 JSON header, then one zstd frame of ``header.payload.compressed_bytes`` bytes holding
the row-major float32 little-endian samples. The reader refuses newer major versions (naming
the version), reads any minor version of format 1 and ignores header fields it does not know
(newer minors only add fields), checks the header checksum, the SHA-256 of the compressed and
of the uncompressed payload, the sizes, and that nothing follows the payload.
"""

from __future__ import annotations

import hashlib
import json
import struct
from dataclasses import dataclass, field

import numpy as np
import zstandard

MAGIC = b"SBTABLE\0"
FORMAT_MAJOR = 1
PREAMBLE = 56


class TableError(Exception):
    """The file is not a valid scatterbake table (corrupt, truncated, newer major, ...)."""


@dataclass
class Axis:
    name: str
    unit: str
    coords: np.ndarray


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
        clamped at the axis ends: the same lookup formula as the Rust ``Table::sample``."""
        if len(coords) != len(self.axes):
            raise ValueError(f"expected {len(self.axes)} coordinates, got {len(coords)}")
        cells = []
        for a, x in zip(self.axes, coords):
            if np.isnan(x):
                raise ValueError(f"coordinate for axis {a.name!r} is NaN")
            g = a.coords
            n = len(g)
            if n < 2 or x <= g[0]:
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


def _axis_coords(points: dict) -> np.ndarray:
    if "values" in points:
        return np.asarray(points["values"], dtype=np.float64)
    u = points["uniform"]
    return u["start"] + u["step"] * np.arange(u["count"], dtype=np.float64)


def read_table_bytes(buf: bytes, name: str = "<bytes>") -> Table:
    """Parse and fully verify a table held in memory."""
    if len(buf) < 8 or buf[:8] != MAGIC:
        raise TableError(f"{name}: not a scatterbake table (bad magic)")
    if len(buf) < PREAMBLE:
        raise TableError(f"{name}: file truncated (shorter than the preamble)")
    major, minor, _flags, hlen = struct.unpack_from("<HHIQ", buf, 8)
    if major > FORMAT_MAJOR:
        raise TableError(f"{name}: table format {major}.{minor} is newer than this reader ({FORMAT_MAJOR}.x)")
    if major == 0:
        raise TableError(f"{name}: format major version 0 does not exist")
    if PREAMBLE + hlen > len(buf):
        raise TableError(f"{name}: file truncated (header)")
    header_bytes = buf[PREAMBLE:PREAMBLE + hlen]
    if hashlib.sha256(buf[:24] + header_bytes).digest() != buf[24:56]:
        raise TableError(f"{name}: header checksum mismatch (file is corrupt)")
    header = json.loads(header_bytes.decode("utf-8"))
    layout, payload = header["layout"], header["payload"]
    if layout["order"] != "row-major" or layout["dtype"] != "f32le" or payload["compression"] != "zstd":
        raise TableError(f"{name}: unsupported layout/compression")
    start = PREAMBLE + hlen
    end = start + payload["compressed_bytes"]
    if len(buf) < end:
        raise TableError(f"{name}: file truncated (payload)")
    if len(buf) > end:
        raise TableError(f"{name}: {len(buf) - end} unexpected bytes after the payload")
    compressed = buf[start:end]
    if hashlib.sha256(compressed).hexdigest() != payload["sha256_compressed"]:
        raise TableError(f"{name}: payload compressed checksum mismatch (file is corrupt)")
    try:
        raw = zstandard.ZstdDecompressor().decompress(compressed, max_output_size=payload["uncompressed_bytes"])
    except zstandard.ZstdError as e:
        raise TableError(f"{name}: payload cannot be decompressed: {e}") from e
    if len(raw) != payload["uncompressed_bytes"]:
        raise TableError(f"{name}: payload decompresses to {len(raw)} bytes, header says {payload['uncompressed_bytes']}")
    if hashlib.sha256(raw).hexdigest() != payload["sha256_uncompressed"]:
        raise TableError(f"{name}: payload uncompressed checksum mismatch (file is corrupt)")
    axes = [Axis(a["name"], a["unit"], _axis_coords(a["points"])) for a in header["axes"]]
    channels = [Channel(c["name"], c["unit"], c["meaning"]) for c in header["channels"]]
    shape = tuple(len(a.coords) for a in axes) + (len(channels),)
    if list(shape) != list(layout["shape"]):
        raise TableError(f"{name}: layout shape {layout['shape']} disagrees with axes/channels {shape}")
    if int(np.prod(shape)) * 4 != len(raw):
        raise TableError(f"{name}: shape {shape} does not match the payload size")
    data = np.frombuffer(raw, dtype="<f4").reshape(shape)
    return Table(header=header, axes=axes, channels=channels, data=data, format_version=(major, minor))


def open_table(path) -> Table:
    """Open and fully verify a ``.sbt`` file."""
    with open(path, "rb") as f:
        return read_table_bytes(f.read(), str(path))
