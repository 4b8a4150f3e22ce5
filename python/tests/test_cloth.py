"""scatterbake.cloth_brdf against the command line (`scatterbake cloth --format json`, built
from the same checkout): the same record at direction pairs of every fabric preset, and bad
input refused with a clear ValueError."""

import json
import subprocess

import pytest
import scatterbake as sb

from conftest import cli_path

#: (θ_i, φ_i, θ_r, φ_r) in degrees: normal incidence, the specular direction, a back-scatter
#: pair, grazing-ish view, azimuths outside [−180, 180] and negative ones.
PAIRS = [
    (0.0, 0.0, 0.0, 0.0),
    (30.0, 0.0, 30.0, 180.0),
    (45.0, 20.0, 40.0, 20.0),
    (60.0, -135.0, 85.0, 200.0),
    (75.5, 400.0, 12.25, -30.0),
]


def cli_record(fabric, pair, ramp_step_deg=None):
    ti, pi, tr, pr = pair
    cmd = [str(cli_path()), "cloth", "--fabric", fabric, "--theta-i", str(ti), "--phi-i", str(pi),
           "--theta-r", str(tr), "--phi-r", str(pr), "--format", "json"]
    if ramp_step_deg is not None:
        cmd += ["--ramp-step-deg", str(ramp_step_deg)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def test_fabric_presets_are_listed():
    assert sb.CLOTH_FABRICS == ("linen_plain", "silk_crepe_de_chine", "polyester_satin_front",
                                "polyester_satin_back", "silk_shot", "velvet")
    help_text = subprocess.run([str(cli_path()), "cloth", "--help"], check=True,
                               capture_output=True, text=True).stdout
    for name in sb.CLOTH_FABRICS:
        assert name in help_text


@pytest.mark.parametrize("fabric", ["linen_plain", "polyester_satin_front", "velvet", "silk_shot"])
def test_cloth_brdf_is_the_command_line_record(fabric):
    for pair in PAIRS:
        got = sb.cloth_brdf(fabric, *pair)
        ref = cli_record(fabric, pair)
        # One library function writes both records; JSON floats round-trip exactly.
        assert got == ref, (fabric, pair)
        assert got["unit"] == "1/sr"
        assert all(v > 0 for v in got["brdf"]) or fabric == "velvet"
        for c in range(3):
            assert got["brdf"][c] == pytest.approx(got["surface"][c] + got["volume"][c],
                                                   rel=1e-15)


def test_ramp_step_and_the_lobes():
    pair = (30.0, 0.0, 30.0, 180.0)
    coarse = sb.cloth_brdf("polyester_satin_front", *pair, ramp_step_deg=5.0)
    assert coarse == cli_record("polyester_satin_front", pair, 5.0)
    fine = sb.cloth_brdf("polyester_satin_front", *pair)
    assert coarse["ramp_step_deg"] == 5.0 and fine["ramp_step_deg"] == 1.0
    assert coarse["brdf"] != fine["brdf"]
    # The mirror x -> -x of satin (phi -> 180 - phi for both directions) leaves f unchanged.
    mirrored = sb.cloth_brdf("polyester_satin_front", 30.0, 180.0, 30.0, 0.0)
    assert mirrored["brdf"] == pytest.approx(fine["brdf"], rel=1e-12)


def test_bad_input_raises_value_error():
    with pytest.raises(ValueError, match=r"unknown fabric `denim` \(presets: linen_plain, "):
        sb.cloth_brdf("denim", 10.0, 0.0, 10.0, 0.0)
    with pytest.raises(ValueError, match=r"theta_r = 90 must be in \[0, 90\) degrees"):
        sb.cloth_brdf("velvet", 10.0, 0.0, 90.0, 0.0)
    with pytest.raises(ValueError, match=r"theta_i = -1 must be in \[0, 90\)"):
        sb.cloth_brdf("velvet", -1.0, 0.0, 10.0, 0.0)
    with pytest.raises(ValueError, match="phi_r = NaN must be finite"):
        sb.cloth_brdf("velvet", 10.0, 0.0, 10.0, float("nan"))
    with pytest.raises(ValueError, match="ramp_step_deg"):
        sb.cloth_brdf("velvet", 10.0, 0.0, 10.0, 0.0, ramp_step_deg=0.0)
    with pytest.raises(TypeError):
        sb.cloth_brdf("velvet", 10.0, 0.0, 10.0)
