"""Test driver for scatterbake_table.py, run by tests/python_reader.rs:

    python3 python/test_reader.py TABLE.sbt DUMP.bin [--entry I,J,...] [COORD ...]

Prints one JSON object (format version, axes with coordinates and symmetry, channels, shape, the
sample at COORDs and each COORD folded by its axis; floats as IEEE-754 f64 bit patterns) and writes the payload as raw float32 little-endian to DUMP.bin, so the Rust side can
compare bit for bit. With ``--entry`` only that entry is opened (``open_table(entry=...)``).
Exit code 3 with the message on stderr when the table is rejected.
"""

import json
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
try:
    import numpy as np  # noqa: E402
    import scatterbake_table as sbt  # noqa: E402
except ImportError as e:
    print(f"missing Python module {e.name!r}: python3 -m pip install numpy zstandard", file=sys.stderr)
    sys.exit(2)


def bits(x) -> int:
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def main() -> int:
    path, dump = sys.argv[1], sys.argv[2]
    rest = sys.argv[3:]
    entry = None
    if rest[:1] == ["--entry"]:
        entry = [int(i) for i in rest[1].split(",") if i]
        rest = rest[2:]
    coords = [float(x) for x in rest]
    try:
        t = sbt.open_table(path, entry=entry)
    except sbt.TableError as e:
        print(str(e), file=sys.stderr)
        return 3
    # No copy when the samples are float32 little-endian already.
    np.asarray(t.data, dtype="<f4").tofile(dump)
    out = {
        "format_version": list(t.format_version),
        # f64 values as their IEEE bit patterns (u64) so JSON cannot round them.
        "axes": [{"name": a.name, "unit": a.unit, "coords_bits": [bits(c) for c in a.coords], "symmetry": a.symmetry} for a in t.axes],
        "channels": [c.name for c in t.channels],
        "shape": list(t.data.shape),
        "schema": t.header["schema"],
    }
    if coords:
        out["fold_bits"] = [bits(a.fold(x)) for a, x in zip(t.axes, coords)]
        out["sample_bits"] = [bits(v) for v in t.sample(coords)]
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
