"""The rest of the API against independent answers: errors as the CLI
words them, Ctrl-C, the GIL, ephemeris and sky against published figures,
calibration flows against the camera's own (preset) truth."""

import math
import os
import re
import signal
import subprocess
import threading
import time

import numpy as np

import pytest

import gloam

BAD = """
units = "m"
[camera]
position = [0, -2, 1]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov_deg = 60
width = 8
height = 6
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.wall]
reflectance = 1.7
[objects.floor]
material = "wall"
quad = { center = [0, 0, 0], size = [2, 2], normal = [0, 0, 1] }
"""


def test_probe_samples_are_bounded_as_the_cli_bounds_them():
    # Python took samples=10**9 (the CLI's --samples stops at 10**6) and
    # probed for hours; 0 is refused too.
    scene = gloam.Scene.from_toml(BAD.replace("reflectance = 1.7", "reflectance = 0.5"))
    for n in (0, 1_000_001, 10**9):
        with pytest.raises(gloam.GloamError, match=r"samples = \d+: from 1 to 1000000"):
            gloam.probe(scene, (0, 0, 1), (0, 0, 1), samples=n)


def test_a_bool_is_not_a_count():
    # spp=True rendered at 1 sample (a bool is an int to Python); every
    # count and seed of render and probe refuses one, naming the argument.
    scene = gloam.Scene.from_toml(BAD.replace("reflectance = 1.7", "reflectance = 0.5"))
    for kw in ("spp", "seed", "threads"):
        with pytest.raises(TypeError, match=r"(?s)True is a bool, not a count.*'" + kw + "'"):
            gloam.render(scene, **{kw: True})
    for kw in ("samples", "seed"):
        with pytest.raises(TypeError, match=r"(?s)False is a bool, not a count.*'" + kw + "'"):
            gloam.probe(scene, (0, 0, 1), (0, 0, 1), **{kw: False})


def test_an_int_out_of_range_is_a_value_error_naming_the_argument(repo, tmp_path):
    # PyO3 raised a bare OverflowError ("can't convert negative int to
    # unsigned", "int too big to convert") for spp=2**70, frames=-1 or
    # seed=2**65 (round 10): every integer argument is a GloamError (a
    # ValueError) with the range, and PyO3's note names the argument.
    def refused(call, kw, value, lo, hi, given=None):
        with pytest.raises(gloam.GloamError) as e:
            call(**{kw: value if given is None else given})
        shown = str(e.value) + " " + " ".join(getattr(e.value, "__notes__", []))
        assert isinstance(e.value, ValueError) and not isinstance(e.value, OverflowError)
        assert f"{value} is out of range: a whole number from {lo} to {hi}" in shown, shown
        assert f"'{kw}'" in shown, shown

    scene = gloam.Scene.from_toml(BAD.replace("reflectance = 1.7", "reflectance = 0.5"))
    u32, u64 = 2**32 - 1, 2**64 - 1
    refused(lambda **k: gloam.render(scene, **k), "spp", 2**70, 0, u32)
    refused(lambda **k: gloam.render(scene, **k), "spp", -1, 0, u32)
    refused(lambda **k: gloam.render(scene, **k), "seed", 2**65, 0, u64)
    refused(lambda **k: gloam.render(scene, **k), "threads", -3, 0, u64)
    refused(lambda **k: gloam.probe(scene, (0, 0, 1), (0, 0, 1), **k), "samples", 2**32, 0, u32)
    s = gloam.Sensor.preset("gen3-gaas-iccd")
    image = np.full((4, 4), 1e-6)
    refused(lambda **k: s.capture(image, **k), "frames", -1, 0, u32)
    refused(lambda **k: s.capture(image, **k), "seed", -1, 0, u64)
    refused(lambda **k: gloam.scope(sensor="gen3-gaas-iccd", **k), "frames", -1, 0, u64)
    refused(lambda **k: gloam.scope(sensor="gen3-gaas-iccd", **k), "seed", 2**64, 0, u64)
    refused(lambda **k: gloam.scope(sensor="gen3-gaas-iccd", **k), "rows", -1, 0, u64, given=[3, -1])
    refused(lambda **k: gloam.scope(sensor="gen3-gaas-iccd", **k), "size", 2**33, 0, u32, given=(2**33, 4))
    refused(lambda **k: gloam.open_grabber("sim:gen3-gaas-iccd?size=4x4", **k), "seed", -5, 0, u64)
    refused(lambda **k: gloam.sweep(tmp_path / "none.toml", tmp_path / "o", **k), "jobs", -1, 0, u64)
    with gloam.open_grabber(CCD) as g:
        refused(lambda **k: gloam.calibrate_radiance(g, repo / SPHERE, gains=[1], **k), "frames", 2**64, 0, u64)
        refused(lambda **k: gloam.photon_transfer(g, repo / SPHERE, **k), "levels", -1, 0, u64)
        refused(lambda **k: gloam.agc_linearity(g, repo / SPHERE, **k), "levels", -2, 0, u64)
        refused(lambda **k: gloam.mtf(g, **k), "frames", -1, 0, u64)
        refused(lambda **k: g.set_bits(**k), "bits", 256, 0, 255)
    # A number too long to print whole is described, not printed.
    with pytest.raises(gloam.GloamError, match="an int that large is out of range"):
        gloam.render(scene, spp=10**5000)


def test_errors_carry_the_cli_message(gloam_bin, tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(BAD)
    with pytest.raises(gloam.GloamError) as e:
        gloam.Scene.load(p)
    assert isinstance(e.value, ValueError)
    msg = str(e.value)
    assert "bad.toml:14" in msg and "materials.wall.reflectance" in msg, msg
    cli = subprocess.run([gloam_bin, "plan", str(p)], capture_output=True, text=True)
    assert cli.returncode != 0
    assert f"error: {msg}" in cli.stderr
    # from_toml names the file it was given.
    with pytest.raises(gloam.GloamError, match=r"here\.toml:14: materials\.wall\.reflectance"):
        gloam.Scene.from_toml(BAD, name="here.toml")
    with pytest.raises(gloam.GloamError, match="unknown sensor preset 'nope'"):
        gloam.Sensor.preset("nope")
    with pytest.raises(gloam.GloamError, match="spp"):
        gloam.render(gloam.Scene.from_toml(BAD.replace("1.7", "0.5")), settings={"spp": "many"})


@pytest.mark.parametrize("keywords, flags", [
    (dict(sensor="no-such-sensor"), ["--sensor", "no-such-sensor"]),
    (dict(settings={"spp": "many"}), ["--set", "spp=many"]),
    (dict(spp=3, settings={"spp": 2}), ["--spp", "3", "--set", "spp=2"]),
    (dict(target_error="camera", sensor="none"), ["--target-error", "camera", "--sensor", "none"]),
])
def test_render_refuses_a_bad_input_as_the_cli_does(gloam_bin, repo, tmp_path, keywords, flags):
    # One request type (RenderRequest) and one validate() behind both.
    scene = str(repo / "sims/panel-validation/scene.toml")
    with pytest.raises(gloam.GloamError) as e:
        gloam.render(gloam.Scene.load(scene), **keywords)
    cli = subprocess.run([gloam_bin, "render", scene, "--out", str(tmp_path / "out"), *flags],
                         capture_output=True, text=True)
    assert cli.returncode != 0
    assert f"error: {e.value}\n" in cli.stderr, (str(e.value), cli.stderr)


def test_ctrl_c_stops_a_long_render_with_keyboard_interrupt(repo):
    scene = gloam.Scene.load(repo / "sims/panel-validation/scene.toml")
    # Untouched, this render would take minutes (2000 spp at 320 × 240);
    # the render polls for Ctrl-C before each row of a tile.
    main = threading.main_thread().ident
    # A shell's background job starts with SIGINT ignored, and Python then
    # installs no KeyboardInterrupt handler: install it, as an interactive
    # session has it.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(main, signal.SIGINT))
    t0 = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        gloam.render(scene, spp=2000)
    assert time.monotonic() - t0 < 5
    timer.cancel()


def test_renders_release_the_gil_and_agree_across_threads(repo):
    scene = gloam.Scene.load(repo / "sims/panel-validation/scene.toml")
    kw = dict(spp=4, seed=2, threads=1, settings={"resolution_scale": 0.5})
    ticks = 0
    done = threading.Event()
    results = []

    def work():
        results.append(gloam.render(scene, **kw).radiance)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    # Python keeps running beside the render: the GIL is released.
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    assert ticks > 5
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:
        both = list(pool.map(lambda _: gloam.render(scene, **kw).radiance, range(2)))
    assert np.array_equal(both[0], results[0]) and np.array_equal(both[1], results[0])


def test_ephem_and_sky_match_the_published_full_moon(repo):
    # Rochester NY, full moon (README; ephemeris within 0.008° of PyEphem).
    e = gloam.ephem(43.0844, -77.6749, "2025-10-07T05:00:00Z")
    assert e["moon"]["elevation_deg"] == pytest.approx(54.37, abs=0.01)
    assert e["moon"]["azimuth_deg"] == pytest.approx(181.09, abs=0.01)
    assert e["illuminated_fraction"] == pytest.approx(1.0, abs=0.001)
    assert e["sun"]["elevation_deg"] == pytest.approx(-52.51, abs=0.01)
    s = gloam.sky(43.0844, -77.6749, "2025-10-07T05:00:00Z", height_m=170)
    lux = s["illuminance_lux"]
    assert lux["total"] == pytest.approx(2.977e-1, rel=1e-3)
    assert lux["total"] == pytest.approx(lux["moon_direct"] + lux["moon_sky"] + lux["night_sky"], rel=1e-9)
    with pytest.raises(gloam.GloamError, match="latitude"):
        gloam.ephem(95.0, 0.0, "2025-10-07T05:00:00Z")


SPHERE = "sims/calibration/sphere.toml"
CCD = "sim:scientific-ccd?size=128x128"


def test_photon_transfer_recovers_the_preset_gain_and_read_noise(repo):
    # The preset: 1.6 e⁻/DN (K = 0.625 DN/e⁻), read noise 3 e⁻.
    with gloam.open_grabber(CCD) as g:
        r = gloam.photon_transfer(g, repo / SPHERE, gain=1.0, levels=50, auto_range=1.4)
    assert r["system_gain_dn_per_e"] == pytest.approx(1 / 1.6, rel=0.02)
    assert r["dark_noise_e"] == pytest.approx(3.0, rel=0.05)


def test_a_scene_no_gain_fits_warns_when_the_grabber_opens(repo):
    # As `gloam capture` does: the lamp-lit street through Gen III saturates
    # at every gain; the frame at the least gain is the independent check.
    lamps = repo / "sims/night-new-moon-lamps/scene.toml"
    with pytest.warns(UserWarning, match="saturates this scene at every gain"):
        g = gloam.open_grabber(f"sim:gen3-gaas-iccd?scene={lamps}&size=48x36")
    with g:
        g.set_gain(14.5519)
        f = g.grab()
    at = f.meta["levels"]["saturated_at_dn"]
    assert (f.pixels >= at).mean() > 0.01


def test_radiance_lut_fits_the_levels_and_applies_its_line(repo, tmp_path):
    with gloam.open_grabber(CCD, seed=3) as g:
        lut_dict = gloam.calibrate_radiance(g, repo / SPHERE, gains=[1, 2], levels=10, frames=8, auto_range=0.8)
        g.set_gain(2)
        f = g.grab()
    lut = gloam.Lut.from_dict(lut_dict)
    assert lut.gains == [1.0, 2.0]
    for cal in lut_dict["gains"]:
        assert cal["r_squared"] > 0.9999
        # The fitted line reproduces every fitted level's known radiance.
        for p in cal["levels"]:
            if p["in_fit"] and p["band_radiance_w_m2_sr"] > 0:
                fit = cal["g_w_m2_sr_per_dn"] * p["mean_dn"] + cal["b_w_m2_sr"]
                assert fit == pytest.approx(p["band_radiance_w_m2_sr"], rel=0.01)
    # apply() is L = g·DC + b of the frame's gain (float32).
    got = lut.apply(f)
    assert got.dtype == np.float32 and got.shape == (128, 128)
    cal = lut_dict["gains"][1]
    want = cal["g_w_m2_sr_per_dn"] * f.pixels.astype(np.float64) + cal["b_w_m2_sr"]
    ok = ~np.isnan(got)
    assert ok.mean() > 0.99
    assert np.allclose(got[ok], want[ok], rtol=1e-6, atol=1e-6 * abs(want).max())
    # The same through a file, as `calibrate apply --lut` reads it.
    import json

    (tmp_path / "lut.json").write_text(json.dumps(lut_dict))
    again = gloam.Lut.load(tmp_path / "lut.json").apply(f.pixels, gain=2)
    assert np.array_equal(again, got, equal_nan=True)


def test_lut_from_dict_is_checked_on_construction(repo):
    # As `calibrate apply --lut` checks a file: refused when made, naming
    # the key, not when first applied (issue 46).
    with gloam.open_grabber(CCD, seed=3) as g:
        good = gloam.calibrate_radiance(g, repo / SPHERE, gains=[1, 2], levels=4, frames=2, auto_range=0.8)
    assert gloam.Lut.from_dict(good).gains == [1.0, 2.0]
    import copy

    def broken(edit):
        d = copy.deepcopy(good)
        edit(d)
        return d

    cases = [
        (lambda d: d["gains"][1].update(g_w_m2_sr_per_dn=-d["gains"][1]["g_w_m2_sr_per_dn"]), "gains[1].g_w_m2_sr_per_dn"),
        (lambda d: d["gains"][0].update(g_w_m2_sr_per_dn=1e308), "gains[0].g_w_m2_sr_per_dn"),
        (lambda d: d["gains"][1].update(gain=d["gains"][0]["gain"]), "gains[1].gain"),
        (lambda d: d["gains"][0].update(gain=0.0), "gains[0].gain"),
        (lambda d: d.update(digitizer_max_dn=4095.5), "digitizer_max_dn"),
        (lambda d: d["gains"][1].update(g_w_m2_sr_per_dn=4 * d["gains"][0]["g_w_m2_sr_per_dn"]), "reversed"),
    ]
    for edit, key in cases:
        with pytest.raises(gloam.GloamError, match=r"Lut\.from_dict: .*" + re.escape(key)):
            gloam.Lut.from_dict(broken(edit))


def test_edge_mtf_agrees_with_the_chain_model():
    uri = "sim:gen3-gaas-iccd?size=128x128"
    model = gloam.Sensor.preset("gen3-gaas-iccd").describe(gain=56)["mtf_quarter_nyquist_half"][0]
    with gloam.open_grabber(uri) as g:
        c = gloam.mtf(g, target="edge", gain=56)
    f, m = np.array(c["frequencies_cy_per_px"]), np.array(c["mtf"])
    measured = float(np.interp(0.25, f, m))
    assert measured == pytest.approx(model, abs=0.06), (measured, model)
    assert 0.1 < c["mtf50"] < 0.4


def test_agc_staircase_settles_with_the_published_overshoot(repo):
    # README: overshoot 3.7 %, hysteresis 1.3 % for this run.
    with gloam.open_grabber("sim:gen3-gaas-iccd?size=64x64") as g:
        r = gloam.agc_linearity(g, repo / SPHERE, levels=5, fixed_gain=14.552, auto_range=0.5)
    assert r["all_settled"]
    assert r["max_overshoot_percent"] == pytest.approx(3.7, abs=1.5)
    assert r["hysteresis_gain_percent"] == pytest.approx(1.3, abs=1.0)


def test_compare_ranks_and_rms_by_hand():
    truth = np.arange(64.0).reshape(8, 8)
    synthetic = 2 * truth + 1
    regions = [
        {"name": "a", "x": 0, "y": 0, "width": 2, "height": 2},
        {"name": "b", "x": 4, "y": 4, "width": 4, "height": 4},
        {"name": "c", "x": 0, "y": 6, "width": 8, "height": 2},
    ]
    c = gloam.compare(truth, synthetic, regions)
    means_t = [truth[0:2, 0:2].mean(), truth[4:8, 4:8].mean(), truth[6:8, 0:8].mean()]
    means_s = [2 * m + 1 for m in means_t]
    assert c["spearman_rho"] == pytest.approx(1.0)
    rms = math.sqrt(np.mean([(a - b) ** 2 for a, b in zip(means_t, means_s)]))
    assert c["rms"] == pytest.approx(rms, rel=1e-12)
    assert [r["truth"] for r in c["regions"]] == pytest.approx(means_t)


def test_oversized_captures_raise_instead_of_aborting():
    # A broadcast view costs nothing to pass in; copying it would take
    # 80 GB. Both it and a frame count past the limit are GloamErrors, and
    # the interpreter lives on.
    s = gloam.Sensor.preset("gen3-gaas-iccd")
    with pytest.raises(gloam.GloamError, match="pixels"):
        s.capture(np.broadcast_to(1e-6, (100000, 100000)))
    with pytest.raises(gloam.GloamError, match="frames"):
        s.capture(np.full((4, 4), 1e-6), frames=10**7)
    cap = s.capture(np.full((4, 4), 1e-6), frames=2, gain=30, seed=1)
    assert cap is not None
    # The scope's frame size (round 9): the CLI's --size held it to 1..4096,
    # Python's size= did not, and (100000, 100000) aborted allocating 80 GB.
    for size in [(100000, 100000), (0, 0)]:
        with pytest.raises(gloam.GloamError, match="1 to 4096 pixels"):
            gloam.scope(sensor="gen3-gaas-iccd", size=size)


def test_a_nan_in_a_dict_argument_is_named():
    # JSON has no NaN: json.dumps wrote the token anyway and serde said
    # "expected value at line 1 column 33" (round 9).
    g = gloam.open_grabber("sim:gen3-gaas-iccd?size=4x4")
    with pytest.raises(gloam.GloamError, match="(?s)stimulus.*NaN"):
        g.present({"kind": "uniform", "radiance": float("nan")})
