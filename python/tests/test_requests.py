"""The Python bindings and the `gloam` CLI build one request per flow
(gloam-pipeline's `RenderRequest`, gloam-calib's `request.rs`) and refuse a
bad input with one message: for one bad input per flow, the GloamError's
text is the CLI's `error: …` line, word for word."""

import subprocess

import pytest

import gloam

SOURCE = "sims/calibration/sphere.toml"
CAM = "sim:scientific-ccd?size=32x32"


def cli_error(gloam_bin, repo, tmp_path, *args):
    """The CLI's message for ARGS, which it must refuse before any output."""
    out = tmp_path / "out"
    p = subprocess.run([gloam_bin, *map(str, args), "--out", str(out)], cwd=repo,
                       capture_output=True, text=True)
    assert p.returncode != 0, args
    assert not out.exists(), args
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), p.stderr
    return line[len("error: "):]


def python_error(call):
    with pytest.raises(gloam.GloamError) as e:
        call()
    return str(e.value)


def test_each_flow_refuses_a_bad_input_with_the_clis_message(gloam_bin, repo, tmp_path):
    source = repo / SOURCE
    with gloam.open_grabber(CAM) as g:
        cases = [
            (["render", "sims/panel-validation/scene.toml", "--set", "spp=many"],
             lambda: gloam.render(gloam.Scene.load(repo / "sims/panel-validation/scene.toml"),
                                  settings={"spp": "many"})),
            (["calibrate", "radiance", "--grabber", CAM, "--source", SOURCE, "--gains", "1,-2"],
             lambda: gloam.calibrate_radiance(g, source, gains=[1, -2])),
            (["calibrate", "ptc", "--grabber", CAM, "--source", SOURCE, "--gain", "-1"],
             lambda: gloam.photon_transfer(g, source, gain=-1)),
            (["calibrate", "agc", "--grabber", CAM, "--source", SOURCE, "--fixed-gain", "0"],
             lambda: gloam.agc_linearity(g, source, fixed_gain=0)),
            (["calibrate", "mtf", "--target", "sine", "--grabber", CAM, "--frequencies", "0.1,0.7"],
             lambda: gloam.mtf(g, target="sine", frequencies=[0.1, 0.7])),
            (["scope"], lambda: gloam.scope()),
        ]
        for args, call in cases:
            cli = cli_error(gloam_bin, repo, tmp_path, *args)
            assert python_error(call) == cli, args
    # Checked against the values given, not only between the front ends.
    assert cli_error(gloam_bin, repo, tmp_path, *cases[1][0]) == \
        "--gains: -2 is not a gain (each must be a finite number > 0)"
