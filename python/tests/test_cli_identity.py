"""Python results are bit-identical to the `gloam` CLI's files for the same
seed: radiance.npy (panel and office room), a render's captured frames
and frames.jsonl, and a grabber capture."""

import json
import subprocess

import numpy as np
import pytest

import gloam
from pngread import read_png_u16


def run(gloam_bin, *args, cwd):
    subprocess.run([gloam_bin, *map(str, args)], cwd=cwd, check=True, capture_output=True)


def untimed(v):
    """A report value without its timings (`seconds`, `*_seconds`)."""
    if isinstance(v, dict):
        return {k: untimed(x) for k, x in v.items() if not (k == "seconds" or k.endswith("_seconds"))}
    return v


def jsonl(path):
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_render_radiance_is_bit_identical_to_the_cli(gloam_bin, repo, tmp_path):
    cases = [
        ("sims/panel-validation/scene.toml", ["--spp", "2", "--seed", "7", "--set", "resolution_scale=0.5"],
         dict(spp=2, seed=7, settings={"resolution_scale": 0.5})),
        # The office room exercises the radiosity cache and the pilot.
        ("sims/office-room/scene.toml", ["--spp", "1", "--seed", "4", "--set", "resolution_scale=0.25"],
         dict(spp=1, seed=4, settings={"resolution_scale": 0.25})),
    ]
    for i, (scene, flags, kwargs) in enumerate(cases):
        out = tmp_path / f"cli-{i}"
        run(gloam_bin, "render", repo / scene, "--out", out, *flags, cwd=tmp_path)
        py = gloam.render(gloam.Scene.load(repo / scene), **kwargs)
        cli = np.load(out / "radiance.npy")
        assert cli.dtype == py.radiance.dtype == np.float64
        assert np.array_equal(cli, py.radiance), scene
        assert np.array_equal(np.load(out / "stderr.npy"), py.std_error), scene
        assert np.array_equal(np.load(out / "spp.npy"), py.spp), scene
        report = json.loads((out / "report.json").read_text())
        for key in ["image", "settings", "effect_plan", "rays", "bands", "error", "interreflection"]:
            assert untimed(py.report[key]) == untimed(report[key]), (scene, key)
        # The same keys as report.json, no more and no fewer.
        assert set(py.report) == set(report)


def test_captured_frames_are_bit_identical_to_render_sensor(gloam_bin, repo, tmp_path):
    # A new-moon street at gain 30: in range (no pixel at the rail), so the
    # frames' noise shows. (The panel seen directly fills an 80 x 60 frame
    # with its halo and saturates every pixel at any gain.)
    scene = repo / "sims/night-new-moon/scene.toml"
    out = tmp_path / "cam"
    run(gloam_bin, "render", scene, "--out", out, "--spp", "1", "--seed", "5",
        "--set", "resolution_scale=0.25", "--sensor", "gen3-gaas-iccd", "--frames", "3", "--gain", "30",
        cwd=tmp_path)
    r = gloam.render(gloam.Scene.load(scene), spp=1, seed=5, settings={"resolution_scale": 0.25},
                     sensor="gen3-gaas-iccd")
    assert np.array_equal(np.load(out / "radiance.npy"), r.radiance)
    assert r.detected is not None and r.detected.shape == r.radiance.shape[1:]
    cap = gloam.Sensor.preset("gen3-gaas-iccd").capture(r, frames=3, gain=30, seed=5)
    assert cap.frames.shape == (3,) + r.radiance.shape[1:]
    records = jsonl(out / "frames.jsonl")
    assert len(records) == 3
    for i, rec in enumerate(records):
        png = read_png_u16(out / rec["file"])
        assert np.array_equal(png, cap.frames[i]), f"frame {i}"
        # The file's storage is the writer's: 12-bit counts scaled to 16
        # bits with sBIT 12 (count = sample >> 4); the rest is the record.
        stored = rec.pop("stored")
        assert stored == {"format": "png", "sample_shift": 4}, stored
        assert cap.meta[i] == rec, f"frames.jsonl line {i}"
    # The frames are not all alike (the noise is there).
    assert not np.array_equal(cap.frames[0], cap.frames[1])


def test_camera_target_matches_render_target_error_camera(gloam_bin, repo, tmp_path):
    # target_error="camera" (issue 45): each pixel to the camera's own noise
    # at its preset gain, as `gloam render --target-error camera`.
    scene = repo / "sims/night-new-moon/scene.toml"
    out = tmp_path / "camtarget"
    run(gloam_bin, "render", scene, "--out", out, "--seed", "5", "--set", "resolution_scale=0.25",
        "--sensor", "gen3-gaas-iccd", "--target-error", "camera", cwd=tmp_path)
    r = gloam.render(gloam.Scene.load(scene), seed=5, settings={"resolution_scale": 0.25},
                     sensor="gen3-gaas-iccd", target_error="camera")
    assert np.array_equal(np.load(out / "radiance.npy"), r.radiance)
    report = json.loads((out / "report.json").read_text())
    cli, py = report["camera_target"], r.report["camera_target"]
    for key in ["k", "gain", "added_variance_fraction_median", "added_variance_fraction_p99", "mean_spp"]:
        assert cli[key] == py[key], key
    assert py["k"] == 0.3 and py["added_variance_fraction_p99"] <= 0.09 * 1.25
    with pytest.raises(gloam.GloamError, match="camera:K"):
        gloam.render(gloam.Scene.load(scene), sensor="gen3-gaas-iccd", target_error="camera:2")


def test_grabber_frames_are_bit_identical_to_gloam_capture(gloam_bin, tmp_path):
    uri = "sim:gen3-gaas-iccd?size=64x48"
    out = tmp_path / "cap"
    run(gloam_bin, "capture", "--grabber", uri, "--frames", "4", "--gain", "100", "--seed", "9",
        "--out", out, cwd=tmp_path)
    records = jsonl(out / "frames.jsonl")
    with gloam.open_grabber(uri, seed=9) as g:
        assert g.frame_size == (64, 48)
        assert g.set_gain(100) == 100
        frames = list(g.stream(4))
    assert len(frames) == 4
    for f, rec in zip(frames, records):
        assert f.pixels.shape == (48, 64) and f.pixels.dtype == np.uint16
        assert np.array_equal(f.pixels, read_png_u16(out / rec["file"]))
        assert f.meta["pixels_crc32c"] == rec["pixels_crc32c"]
        assert f.gain == rec["gain"]


def test_camera_target_sweep_matches_render_target_error_camera(gloam_bin, repo, tmp_path):
    # A sweep task with target_error = "camera" (issue 45) renders as
    # `gloam render --target-error camera` at the same gain and seed:
    # gloam.sweep goes through the sweep's one executor, so its radiance,
    # samples and camera_target figures are the CLI's, bit for bit.
    scene = repo / "sims/night-new-moon-lamps/scene.toml"
    sweep = tmp_path / "cam.toml"
    sweep.write_text(
        f'[base]\nscene = "{scene}"\nsensor = "gen3-gaas-iccd"\nresolution_scale = 0.07\n'
        'seed = 3\nframes = 1\ngain = 300\ntarget_error = "camera:0.5"\n')
    s = gloam.sweep(sweep, tmp_path / "sw")
    assert s.failed == [] and s.ran == 1
    task = tmp_path / "sw" / "tasks" / "00000"
    out = tmp_path / "cli"
    run(gloam_bin, "render", scene, "--out", out, "--seed", "3", "--set", "resolution_scale=0.07",
        "--sensor", "gen3-gaas-iccd", "--gain", "300", "--target-error", "camera:0.5", cwd=tmp_path)
    for f in ["radiance.npy", "spp.npy"]:
        assert (out / f).read_bytes() == (task / f).read_bytes(), f
    cli = json.loads((out / "report.json").read_text())["camera_target"]
    py = json.loads((task / "camera_target.json").read_text())
    for key in ["k", "gain", "added_variance_fraction_median", "added_variance_fraction_p99", "mean_spp"]:
        assert cli[key] == py[key], key
    assert py["k"] == 0.5 and py["gain"] == 300
