"""Frame files as other tools read them: a FITS frame through astropy
(header values and counts against frames.jsonl and the Python capture of
the same seed), and the PNG frame's sBIT scaling."""

import json
import subprocess

import numpy as np
import pytest

import gloam
from pngread import read_png_u16

fits = pytest.importorskip("astropy.io.fits")
Time = pytest.importorskip("astropy.time").Time


def run(gloam_bin, *args, cwd):
    subprocess.run([gloam_bin, *map(str, args)], cwd=cwd, check=True, capture_output=True)


def jsonl(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


SCENE = "sims/night-new-moon/scene.toml"
COMMON = ["--spp", "1", "--seed", "5", "--set", "resolution_scale=0.25",
          "--sensor", "gen3-gaas-iccd", "--frames", "2", "--gain", "30"]


def test_fits_frames_open_in_astropy_with_the_recorded_header(gloam_bin, repo, tmp_path):
    out = tmp_path / "fits"
    run(gloam_bin, "render", repo / SCENE, "--out", out, *COMMON, "--frame-format", "fits", cwd=tmp_path)
    records = jsonl(out / "frames.jsonl")
    assert len(records) == 2
    # The same frames through the Python package (same seed): the counts
    # the FITS files must hold.
    r = gloam.render(gloam.Scene.load(repo / SCENE), spp=1, seed=5, settings={"resolution_scale": 0.25},
                     sensor="gen3-gaas-iccd")
    cap = gloam.Sensor.preset("gen3-gaas-iccd").capture(r, frames=2, gain=30, seed=5)
    for i, rec in enumerate(records):
        assert rec["file"] == f"frame-{i:06d}.fits"
        assert rec["stored"] == {"format": "fits", "sample_shift": 0}
        with fits.open(out / rec["file"]) as hdul:
            h, data = hdul[0].header, hdul[0].data
            # BITPIX 16 + BZERO 32768: astropy gives unsigned counts.
            assert h["BITPIX"] == 16 and h["BZERO"] == 32768
            assert data.dtype == np.uint16
            assert data.shape == (rec["height"], rec["width"])
            assert np.array_equal(data, cap.frames[i]), f"frame {i}"
            assert float(data.mean()) == pytest.approx(rec["mean_dn"], rel=1e-12)
            # GAIN is e-/DN as astropy/ccdproc read it: 1 / the camera's
            # DN per photoelectron at the frame's gain (independently from
            # Sensor.describe); the tube's linear gain is TUBEGAIN.
            assert h["TUBEGAIN"] == rec["gain"] == 30.0
            dn_per_pe = gloam.Sensor.preset("gen3-gaas-iccd").describe(gain=30)["dn_per_photoelectron"]
            assert h["GAIN"] == pytest.approx(1.0 / dn_per_pe, rel=1e-12)
            assert h["GAIN"] == rec["electrons_per_dn"]
            # DATE-OBS: the scene's [sky] utc + the frame's start at 25 Hz.
            assert h["DATE-OBS"] == ["2025-10-22T04:00:00.000", "2025-10-22T04:00:00.040"][i]
            assert Time(h["DATE-OBS"], scale="utc").unix == pytest.approx(1761105600.0 + 0.04 * i, abs=1e-6)
            assert h["INSTRUME"] == "gen3-gaas-iccd"
            assert h["AGC"] is False
            assert h["BITS"] == rec["bits"] == 12
            assert h["BLACKDN"] == rec["black_dn"]
            assert h["SATDN"] == rec["saturated_at_dn"]
            assert h["GATEDUTY"] == rec["gate_duty"]
            assert h["NDDENS"] == rec["nd_density"]
            assert h["EXPTIME"] == rec["sensor"]["exposure_s"] > 0
            assert h["TSTAMPUS"] == rec["timestamp"]
            assert h["FRAME"] == i and h["SEQ"] == rec["seq"]
            assert h["CAMERA"] == "gen3-gaas-iccd"
            assert h["SEED"] == 5
            assert h["GLOAMVER"].startswith(gloam.__version__)
            # Provenance: the scene file named on the command line, hashed.
            inputs = {h[f"INPUT{k}"]: h[f"ISHA{k}"] for k in range(1, 5) if f"INPUT{k}" in h}
            assert any(p.endswith("night-new-moon/scene.toml") and len(s) == 64 for p, s in inputs.items()), inputs


def test_png_frames_declare_their_bits_and_fill_the_16_bit_range(gloam_bin, repo, tmp_path):
    out = tmp_path / "png"
    run(gloam_bin, "render", repo / SCENE, "--out", out, *COMMON, cwd=tmp_path)
    rec = jsonl(out / "frames.jsonl")[0]
    raw = (out / rec["file"]).read_bytes()
    # The sBIT chunk (length 1, value 12) before the image data.
    k = raw.index(b"\x00\x00\x00\x01sBIT") + 8
    assert raw[k] == 12 and k < raw.index(b"IDAT")
    counts = read_png_u16(out / rec["file"])
    assert float(counts.mean()) == pytest.approx(rec["mean_dn"], rel=1e-12)
    # The contact sheet is there, 8-bit grey.
    sheet = (out / "frames-preview.png").read_bytes()
    assert sheet[:8] == b"\x89PNG\r\n\x1a\n" and sheet[24] == 8


def test_capture_fits_frames_open_in_astropy_with_gain_in_electrons_per_dn(gloam_bin, repo, tmp_path):
    """`gloam capture --frame-format fits`: astropy reads the counts and a
    header whose GAIN is e-/DN (the scientific CCD's 1.6 e-/DN at unit
    analogue gain, halved at gain 2) and whose DATE-OBS is a UTC time
    within the run."""
    out = tmp_path / "cap"
    before = Time.now()
    run(gloam_bin, "capture", "--grabber", "sim:scientific-ccd?size=32x24", "--gain", "2", "--frames", "2",
        "--seed", "4", "--frame-format", "fits", "--out", out, cwd=tmp_path)
    after = Time.now()
    for i, rec in enumerate(jsonl(out / "frames.jsonl")):
        assert rec["file"] == f"frame-{i:06d}.fits"
        with fits.open(out / rec["file"]) as hdul:
            hdul.verify("exception")
            h, data = hdul[0].header, hdul[0].data
            assert data.dtype == np.uint16 and data.shape == (24, 32)
            assert float(data.mean()) == pytest.approx(rec["mean_dn"], rel=1e-12)
            assert h["GAIN"] == pytest.approx(1.6 / 2, rel=1e-12)
            assert h["TUBEGAIN"] == rec["gain"] == 2.0
            assert h["INSTRUME"] == "sim:scientific-ccd"
            t = Time(h["DATE-OBS"], format="isot", scale="utc")
            assert before.unix - 0.01 <= t.unix <= after.unix + 0.01


def test_sequence_fits_frames_open_in_astropy_dated_by_the_scene_time(gloam_bin, repo, tmp_path):
    """`gloam sequence --frame-format fits`: astropy opens every frame and
    verifies it; counts match frames.jsonl, GAIN is e-/DN, and DATE-OBS is
    the scene's [sky] utc plus the frame's start in the sequence."""
    seq = tmp_path / "seq.toml"
    scene = (repo / SCENE).resolve().as_posix()
    seq.write_text(f'scene = "{scene}"\nframe_rate_hz = 25\nframes = 3\n')
    out = tmp_path / "seq-fits"
    run(gloam_bin, "sequence", seq, "--out", out, "--spp", "1", "--seed", "5", "--set", "resolution_scale=0.25",
        "--sensor", "gen3-gaas-iccd", "--gain", "30", "--frame-format", "fits", cwd=tmp_path)
    records = jsonl(out / "frames.jsonl")
    assert len(records) == 3
    for i, rec in enumerate(records):
        assert rec["file"] == f"frame-{i:06d}.fits"
        with fits.open(out / rec["file"]) as hdul:
            hdul.verify("exception")
            h, data = hdul[0].header, hdul[0].data
            assert data.dtype == np.uint16 and data.shape == (rec["height"], rec["width"])
            assert float(data.mean()) == pytest.approx(rec["mean_dn"], rel=1e-12)
            assert h["TUBEGAIN"] == rec["gain"] == 30.0
            assert h["GAIN"] == rec["electrons_per_dn"]
            assert h["INSTRUME"] == "gen3-gaas-iccd"
            t = rec["sequence"]["time_s"]
            assert t == pytest.approx(0.04 * i, abs=1e-12)
            assert Time(h["DATE-OBS"], scale="utc").unix == pytest.approx(1761105600.0 + t, abs=1e-6)
