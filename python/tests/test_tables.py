"""scatterbake.build and scatterbake.open_table against the command line and the pure-Python
reader (python/scatterbake_table.py, an independent implementation of the table format)."""

import json
import subprocess

import numpy as np
import pytest

import scatterbake as sb
from conftest import cli_path

MANIFEST = """
[[table]]
name = "py-mie"
stage = "mie"
[table.params]
radii_um = [1.0, 2.5]
wavelengths_nm = [550.0, 650.0]
angle_step_deg = 1.0
sun_diameter_deg = 0.0
"""


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("build")
    (d / "py.toml").write_text(MANIFEST)
    report = sb.build(d / "py.toml", d / "tables", jobs=1)
    return d, report


def test_build_writes_then_reuses(built):
    d, report = built
    assert report["tables_written"] == ["py-mie"]
    assert report["tasks_computed"] == 4
    again = sb.build([str(d / "py.toml")], str(d / "tables"))
    assert again["tables_up_to_date"] == ["py-mie"] and again["tables_written"] == []
    assert (d / "tables" / "index.json").is_file()


def test_binding_reader_equals_pure_python_reader(built, pure_reader):
    d, _ = built
    path = d / "tables" / "py-mie.sbt"
    t = sb.open_table(path)
    p = pure_reader.open_table(path)
    assert t.schema.startswith("mie-phase/")
    assert t.schema == f"{p.header['schema']['name']}/{p.header['schema']['version']}"
    assert [(a.name, a.unit) for a in t.axes] == [(a.name, a.unit) for a in p.axes]
    for a, b in zip(t.axes, p.axes):
        assert np.array_equal(a.coords, b.coords)
    assert [c.name for c in t.channels] == [c.name for c in p.channels]
    assert t.data.dtype == np.float32 and np.array_equal(t.data, p.data)
    assert np.array_equal(t.channel("phase"), p.channel("phase"))
    assert t.header == p.header
    for coords in ([1.0, 550.0, 0.0], [1.7, 600.0, 137.3], [9.0, 700.0, 180.0]):
        assert np.allclose(t.sample(coords), p.sample(coords), rtol=1e-12, atol=0)
    assert t.sample_channel("phase", [1.7, 600.0, 137.3]) == pytest.approx(
        p.sample([1.7, 600.0, 137.3])[p.channel_index("phase")], rel=1e-12
    )


def test_table_efficiencies_equal_mie(built):
    """The table's f64 Q values ([radius][wavelength]) are those of sb.mie at the table's water
    index (attribute refractive_index_real, one per wavelength)."""
    d, _ = built
    t = sb.open_table(d / "tables" / "py-mie.sbt")
    a = t.attributes
    n = a["refractive_index_real"]
    for i, r in enumerate(t.axis("radius").coords):
        for j, lam in enumerate(t.axis("wavelength").coords):
            s = sb.mie(n[j], radius_um=r, wavelength_nm=lam, angles_deg=[0.0])
            assert a["q_ext"][i][j] == pytest.approx(s.qext, rel=1e-12)
            assert a["q_back"][i][j] == pytest.approx(s.qback, rel=1e-12)
            assert a["g"][i][j] == pytest.approx(s.g, rel=1e-12)
    # the table's phase is the solid-angle average over each 1° bin (no sun disc here): the
    # same average of sb.mie's point values over the interior bins
    centres = t.axis("scattering_angle").coords[1:-1]
    offsets = np.linspace(-0.5, 0.5, 201)
    fine = (centres[:, None] + offsets[None, :]).ravel()
    s = sb.mie(n[0], radius_um=1.0, wavelength_nm=550.0, angles_deg=fine)
    w = np.sin(np.radians(fine)).reshape(len(centres), -1)
    trap = np.full(len(offsets), 1.0)
    trap[[0, -1]] = 0.5
    avg = (s.phase.reshape(len(centres), -1) * w * trap).sum(1) / (w * trap).sum(1)
    ph = t.channel("phase")[0, 0, 1:-1]
    assert np.max(np.abs(ph - avg) / avg) < 1e-4


def test_mie_equals_the_command_line():
    """`scatterbake mie --format json` and sb.mie give the same sphere (medium and coated)."""
    ang = [0.0, 30.0, 90.0, 138.0, 180.0]
    for args, kw in [
        (["--x", "30", "--index", "1.33+0.05i"], dict(m=1.33 + 0.05j, x=30.0)),
        (["--radius-um", "2", "--wavelength-nm", "633", "--index", "1.5+0.001i",
          "--n-medium", "1.333"],
         dict(m=1.5 + 0.001j, radius_um=2.0, wavelength_nm=633.0, n_medium=1.333)),
        (["--x", "20", "--index", "1.33", "--core-x", "8", "--core-index", "1.95+0.79i"],
         dict(m=1.33, x=20.0, core_x=8.0, core_m=1.95 + 0.79j)),
    ]:
        out = subprocess.run(
            [str(cli_path()), "mie", *args, "--angles-deg", ",".join(map(str, ang)),
             "--format", "json"],
            check=True, capture_output=True, text=True,
        ).stdout
        j = json.loads(out)
        r = sb.mie(angles_deg=ang, **kw)
        assert j["x"] == pytest.approx(r.x, rel=1e-15)
        assert complex(*j["m"]) == pytest.approx(r.m, rel=1e-15)
        for key in ("qext", "qsca", "qback", "qback_per_sr", "g"):
            assert j[key] == pytest.approx(getattr(r, key), rel=1e-12), key
        assert np.allclose(j["s1_sq"], np.abs(r.s1) ** 2, rtol=1e-12, atol=0)
        assert np.allclose(j["s2_sq"], np.abs(r.s2) ** 2, rtol=1e-12, atol=0)
        assert np.allclose(j["phase"], r.phase, rtol=1e-12, atol=0)


def test_table_errors(tmp_path):
    with pytest.raises(OSError):
        sb.open_table(tmp_path / "missing.sbt")
    bad = tmp_path / "bad.sbt"
    bad.write_bytes(b"not a table at all, not a table at all")
    with pytest.raises(sb.TableError, match="not a scatterbake table"):
        sb.open_table(bad)
    m = tmp_path / "bad.toml"
    m.write_text('[[table]]\nname = "x"\nstage = "mie"\n[table.params]\nradii_um = [-1.0]\n'
                 'wavelengths_nm = [550.0]\n')
    with pytest.raises(ValueError, match="bad.toml"):
        sb.build(m, tmp_path / "out")


@pytest.mark.parametrize("name,schema,channel", [
    ("fur-medulla-azimuthal.sbt", "fur-medulla-azimuthal/1", "energy"),
    ("fur-medulla-longitudinal.sbt", "fur-medulla-longitudinal/1", "pdf"),
])
def test_shipped_medulla_assets_reconstruct_like_the_pure_python_reader(name, schema, channel, pure_reader):
    """The shipped tensor-train medulla tables (assets/fur-medulla/) open reconstructed through
    the library (the Rust code) and through the pure-Python reader, which follows the documented
    evaluation order: the same axes and values (measured bit-identical; at most 1 ulp of f32
    allowed where numpy's exp could round differently), and reconstruct=False returns the cores."""
    from conftest import ROOT

    path = ROOT / "assets" / "fur-medulla" / name
    t = sb.open_table(path)
    p = pure_reader.open_table(path)
    assert t.schema == schema
    assert [(a.name, a.unit) for a in t.axes] == [(a.name, a.unit) for a in p.axes]
    for a, b in zip(t.axes, p.axes):
        assert np.array_equal(a.coords, b.coords)
    assert [c.name for c in t.channels] == [channel]
    a = np.asarray(t.data, dtype=np.float32).reshape(-1).view(np.int32).astype(np.int64)
    b = np.asarray(p.data, dtype=np.float32).reshape(-1).view(np.int32).astype(np.int64)
    assert a.shape == b.shape == (64 * 16 * 64 * 720,)
    assert np.max(np.abs(a - b)) <= 1
    raw = sb.open_table(path, reconstruct=False)
    assert raw.schema == "fur-medulla-tt/1"
    assert "tt_payload_sha256" in t.attributes and "reconstruction_error" in raw.attributes


def test_crafted_tensor_train_is_refused_with_a_clear_error(tmp_path, pure_reader):
    """A tensor-train table whose ranks disagree with its dims is refused by both readers,
    naming the rule (the corpus of such files is tested from Rust for all readers)."""
    from conftest import ROOT

    src = ROOT / "assets" / "fur-medulla" / "fur-medulla-azimuthal.sbt"
    t = pure_reader.open_table(src, reconstruct=False)
    header = dict(t.header)
    attrs = dict(header["attributes"])
    attrs["ranks"] = attrs["ranks"][:-1]
    header["attributes"] = attrs
    bad = tmp_path / "bad-ranks.sbt"
    bad.write_bytes(_rewrite(header, t.data.tobytes()))
    with pytest.raises(sb.TableError, match="tensor-train table is not valid: inconsistent ranks/dims"):
        sb.open_table(bad)
    with pytest.raises(pure_reader.TableError, match="tensor-train table is not valid: inconsistent ranks/dims"):
        pure_reader.open_table(bad)
    assert sb.open_table(bad, reconstruct=False).schema == "fur-medulla-tt/1"


def _rewrite(header: dict, raw: bytes, version=(1, 0)) -> bytes:
    """A table file of format ``version`` with this header and raw f32 payload, every checksum
    recomputed."""
    import hashlib
    import struct

    import zstandard

    comp = zstandard.ZstdCompressor(level=3, write_checksum=True, write_content_size=True).compress(raw)
    header = dict(header)
    header["payload"] = {
        "compression": "zstd",
        "compressed_bytes": len(comp),
        "uncompressed_bytes": len(raw),
        "sha256_compressed": hashlib.sha256(comp).hexdigest(),
        "sha256_uncompressed": hashlib.sha256(raw).hexdigest(),
    }
    hb = json.dumps(header).encode()
    pre = b"SBTABLE\0" + struct.pack("<HHIQ", version[0], version[1], 0, len(hb))
    return pre + hashlib.sha256(pre + hb).digest() + hb + comp


def _bits(v) -> list:
    """The IEEE-754 bit patterns of float64 values."""
    return np.asarray(v, dtype=np.float64).view(np.uint64).tolist()


def test_even_periodic_axis_folds_like_the_pure_reader(built, tmp_path, pure_reader):
    """A format 3.0 table whose azimuth is even and periodic (period 360°, stored 0 … 180°):
    both readers report the symmetry and fold every coordinate to the same bits, so the lookups
    at x, −x, 360° − x and x + 360° are one lookup, the same bits in both readers; a stored
    azimuth returns the stored value from either side; an infinite azimuth is refused; an entry
    that fixes the axis drops its symmetry; the same header in a 2.0 file, where `symmetry` is
    not a field, reads without it (lookups clamp at 180°)."""
    d, _ = built
    header = dict(pure_reader.open_table(d / "tables" / "py-mie.sbt").header)
    header["axes"] = [
        {"name": "wavelength", "unit": "nm", "points": {"values": [450.0, 650.0]}},
        {"name": "outgoing_azimuth", "unit": "deg",
         "points": {"uniform": {"start": 0.0, "step": 22.5, "count": 9}},
         "symmetry": {"kind": "even-periodic", "period": 360}},
    ]
    header["channels"] = [{"name": "phase", "unit": "1/sr", "meaning": "test"}]
    header["layout"] = {"order": "row-major", "axis_order": ["wavelength", "outgoing_azimuth", "channel"],
                        "dtype": "f32le", "shape": [2, 9, 1]}
    values = (1.0 + np.arange(18) ** 1.5).astype("<f4")
    path = tmp_path / "even.sbt"
    path.write_bytes(_rewrite(header, values.tobytes(), version=(3, 0)))
    t, p = sb.open_table(path), pure_reader.open_table(path)
    assert t.axes[1].symmetry == p.axes[1].symmetry == {"kind": "even-periodic", "period": 360.0}
    assert t.axes[0].symmetry is None and p.axes[0].symmetry is None
    for x in [0.1, -0.1, 359.9, 1e-17, -1e-300, 397.25, 1e300, -1e16, 180.0, 540.0]:
        assert _bits(t.axes[1].fold(x)) == _bits(p.axes[1].fold(x)), x
    assert _bits(t.axes[1].fold(-0.1)) == _bits(0.1) and t.axes[0].fold(-0.1) == -0.1
    for x in [0.0, 10.0, 37.25, 100.125, 180.0]:
        at = _bits(t.sample([500.0, x]))
        for y in [x, -x, 360.0 - x, x + 360.0]:
            assert _bits(t.sample([500.0, y])) == at == _bits(p.sample([500.0, y])), (x, y)
    for k in range(9):
        for y in (22.5 * k, -22.5 * k, 360.0 - 22.5 * k):
            assert t.sample_channel("phase", [650.0, y]) == values[9 + k], y
    for reader in (t, p):
        with pytest.raises(ValueError, match="outgoing_azimuth"):
            reader.sample([500.0, float("inf")])
    for e in (sb.open_table(path, entry=[1]), pure_reader.open_table(path, entry=[1])):
        assert e.axes[1].symmetry is not None and e.axes[0].symmetry is None
    for e in (sb.open_table(path, entry=[1, 3]), pure_reader.open_table(path, entry=[1, 3])):
        assert e.axes[1].symmetry is None and _bits(e.sample([0.0, 1e9])) == _bits(t.sample([650.0, 67.5]))
    path.write_bytes(_rewrite(header, values.tobytes(), version=(2, 0)))
    t, p = sb.open_table(path), pure_reader.open_table(path)
    assert t.axes[1].symmetry is None and p.axes[1].symmetry is None
    assert _bits(t.sample([500.0, 270.0])) == _bits(t.sample([500.0, 180.0])) == _bits(p.sample([500.0, 270.0]))


def test_one_entry_equals_the_pure_reader_and_the_whole_table(built, pure_reader):
    d, _ = built
    path = d / "tables" / "py-mie.sbt"
    whole = sb.open_table(path)
    for entry in ([0], [1], [1, 0], [0, 1], []):
        t = sb.open_table(path, entry=entry)
        p = pure_reader.open_table(path, entry=entry)
        bits = t.data.reshape(-1).view(np.uint32)
        assert np.array_equal(bits, p.data.reshape(-1).view(np.uint32)), entry
        assert np.array_equal(bits, whole.data[tuple(entry)].reshape(-1).view(np.uint32)), entry
        lens = [1] * len(entry) + [len(a.coords) for a in whole.axes[len(entry):]]
        assert [len(a.coords) for a in t.axes] == lens == [len(a.coords) for a in p.axes]
        assert t.data.shape == tuple(lens) + (len(whole.channels),)
        for k, (a, b) in enumerate(zip(t.axes, p.axes)):
            assert a.name == b.name == whole.axes[k].name
            assert np.array_equal(a.coords, b.coords)
        coords = [whole.axes[k].coords[i] for k, i in enumerate(entry)] + [1.7, 600.0, 137.3][len(entry):]
        assert np.array_equal(t.sample(coords), whole.sample(coords)), entry
    name = whole.axes[0].name
    with pytest.raises(sb.TableError, match=f"index 2 of axis `{name}`"):
        sb.open_table(path, entry=[2])
    with pytest.raises(pure_reader.TableError, match=f"index 2 of axis `{name}`"):
        pure_reader.open_table(path, entry=[2])


COMPACT_TOP16 = """
[[table]]
name = "py-compact-top16"
stage = "raytrace"
[table.params]
shape = "beard-chuang"
radii_um = [400.0]
wavelengths_nm = [650.0]
sun_elevation_deg = [10.0, 30.0]
rays = 300
polar_step_deg = 0.05
azimuth_step_deg = 5.0
diagnostic_channels = false
compression = { kind = "sun-disc-resampled", tolerance = 0.02, norm = "rms", values = "top16" }
"""


def test_16_bit_compact_table_reads_like_the_pure_reader(tmp_path, pure_reader):
    """A compact ray-traced table stored as 16-bit values (derived phase and dolp; format 3.0,
    since its mirror symmetric entries store 0°–180° of azimuth on an even-periodic axis)
    through the package's reader (the Rust one) and the pure-Python reader: the same decoded
    values bit for bit, whole and per entry, the same folded lookups beyond 180°, and the
    derived channels by their definition."""
    (tmp_path / "c.toml").write_text(COMPACT_TOP16)
    sb.build(tmp_path / "c.toml", tmp_path / "tables", jobs=1)
    path = tmp_path / "tables" / "py-compact-top16.sbt"
    t = sb.open_table(path)
    p = pure_reader.open_table(path)
    assert p.format_version == (3, 0)
    azimuth = t.axes[-1]
    assert azimuth.symmetry == {"kind": "even-periodic", "period": 360.0} and azimuth.coords[-1] == 180.0
    for phi in (200.0, 287.5, 359.0):
        coords = [400.0, 650.0, 30.0, 137.3, phi]
        assert np.array_equal(t.sample(coords), t.sample(coords[:-1] + [360.0 - phi]))
        assert np.array_equal(t.sample(coords), p.sample(coords))
    assert t.header == p.header and t.header["layout"]["dtype"] == "f32-top16le"
    assert np.array_equal(t.data.view(np.uint32), p.data.view(np.uint32))
    ip, iq = (t.channel(c).astype(np.float64) for c in ("i_perp", "i_par"))
    assert np.array_equal(t.channel("phase"), (0.5 * (ip + iq)).astype(np.float32))
    for e in range(2):
        entry = [0, 0, e]
        a = sb.open_table(path, entry=entry).data.view(np.uint32)
        b = pure_reader.open_table(path, entry=entry).data.view(np.uint32)
        assert np.array_equal(a, b) and np.array_equal(a, t.data[0:1, 0:1, e:e + 1].view(np.uint32))


def test_data_is_a_read_only_view_of_the_table(built):
    """`Table.data` is the table's own samples, not a copy per access: two reads share memory,
    writing is refused, and the view outlives the table object that made it."""
    d, _ = built
    t = sb.open_table(d / "tables" / "py-mie.sbt")
    a, b = t.data, t.data
    assert np.shares_memory(a, b) and not a.flags.writeable
    with pytest.raises(ValueError):
        a[(0,) * a.ndim] = 1.0
    expected = a.copy()
    del t, b
    import gc

    gc.collect()
    assert np.array_equal(a, expected)
