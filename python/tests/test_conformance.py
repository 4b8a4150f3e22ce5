"""The Python package's reader on the conformance corpus: the crafted files and the header
mutants that `cargo test` (tests/conformance.rs) writes under target/tmp/conformance-corpus/
with the Rust reader's verdicts. The package reads through the Rust reader, so it must give
the same samples (by SHA-256) or raise `TableError` (nothing else) with the same message and
causes. Like `cli_path()`, this needs `cargo test` to have run first (.ci/run does); a missing
corpus fails the test."""

import hashlib
import json
import os
import pathlib

import numpy as np
import pytest
import scatterbake as sb
from conftest import ROOT


def corpus(set_name: str) -> tuple[pathlib.Path, list]:
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    d = target / "tmp" / "conformance-corpus" / set_name
    assert (d / "verdicts.json").is_file(), (
        f"the conformance corpus is needed at {d} (run `cargo test --test conformance` first)"
    )
    return d, json.loads((d / "verdicts.json").read_text())


@pytest.mark.parametrize("set_name", ["crafted", "mutants"])
def test_package_reader_agrees_with_the_rust_reader(set_name):
    d, verdicts = corpus(set_name)
    wrong = []
    for v in verdicts:
        path = d / v["file"]
        try:
            t = sb.open_table(path)
        except sb.TableError as e:
            said = str(e).replace(str(path), "FILE")
            if "error" not in v or said != v["error"]:
                wrong.append(f"{v['name']}: raised `{said}`, Rust: {v.get('error', 'reads it')}")
            continue
        got = hashlib.sha256(np.ascontiguousarray(t.data, dtype="<f4").tobytes()).hexdigest()
        if got != v.get("sha256"):
            wrong.append(f"{v['name']}: read it, Rust: {v.get('error', 'other samples')}")
    assert len(verdicts) > 80
    assert not wrong, "\n".join(wrong)
