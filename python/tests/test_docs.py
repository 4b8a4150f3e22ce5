"""Every ```python block of docs/python.md runs (in a directory holding a small
`tables/rainbow-mie.sbt` built with the default Mie table's stage and a copy of the shipped
`assets/fur-medulla/`) and prints what it says."""

import os
import pathlib
import re
import subprocess
import sys

import scatterbake as sb
from conftest import ROOT

FIXTURE = """
[[table]]
name = "rainbow-mie"
stage = "mie"
[table.params]
radii_um = [400.0, 500.0]
wavelengths_nm = [550.0, 650.0, 700.0]
angle_step_deg = 0.5
sun_diameter_deg = 0.5
"""


def blocks():
    text = (ROOT / "docs" / "python.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, re.S)


def test_python_md_examples_run(tmp_path):
    found = blocks()
    assert found, "docs/python.md has no python example"
    (tmp_path / "fixture.toml").write_text(FIXTURE)
    sb.build(tmp_path / "fixture.toml", tmp_path / "tables")
    # The shipped compressed medulla tables, at the path the examples name.
    import shutil

    shutil.copytree(ROOT / "assets" / "fur-medulla", tmp_path / "assets" / "fur-medulla")
    for code in found:
        o = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                           text=True, env=dict(os.environ))
        assert o.returncode == 0, f"example failed:\n{code}\n{o.stderr}"
        assert o.stdout.strip(), f"example printed nothing:\n{code}"
