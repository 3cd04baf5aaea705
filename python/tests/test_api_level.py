"""The API's level (issue 32): result classes with attributes that stay
dicts, images in any float dtype and layout, progress on renders, captures
and sweeps, Ctrl-C during a render's preparation, the scope and the
voltage-space MTF equal to the CLI's, and a docstring on every public
function."""

import inspect
import json
import subprocess
import time

import numpy as np
import pytest

import gloam


def run(gloam_bin, *args, cwd):
    subprocess.run([gloam_bin, *map(str, args)], cwd=cwd, check=True, capture_output=True)


def test_results_have_attributes_and_stay_dicts():
    e = gloam.ephem(43.0844, -77.6749, "2025-10-07T05:00:00Z")
    assert isinstance(e, gloam.Ephemeris) and isinstance(e, dict)
    assert e.moon.elevation_deg == e["moon"]["elevation_deg"] == pytest.approx(54.37, abs=0.01)
    assert json.loads(json.dumps(e)) == e.to_dict() == e
    assert type(e.to_dict()) is dict and type(e.to_dict()["moon"]) is dict
    assert repr(e).startswith("Ephemeris(") and "illuminated_fraction=0.99" in repr(e)
    with pytest.raises(AttributeError, match="no field 'nope'"):
        e.nope
    assert "illuminated_fraction" in dir(e)
    d = gloam.Sensor.preset("gen3-gaas-iccd").describe(gain=100)
    assert isinstance(d, gloam.SensorDescription) and d.dn_per_photoelectron == d["dn_per_photoelectron"]


def test_float32_and_fortran_images_capture_as_float64():
    cam = gloam.Sensor.preset("gen3-gaas-iccd")
    # Detected radiance giving a few photoelectrons a pixel, a gradient so
    # the layout matters (a transposed copy would differ).
    img = np.linspace(2e5, 8e5, 24 * 32).reshape(24, 32).astype(np.float32)
    want = cam.capture(img.astype(np.float64), frames=2, gain=100, seed=4)
    for variant in (img, np.asfortranarray(img), np.ascontiguousarray(img.T).T):
        got = cam.capture(variant, frames=2, gain=100, seed=4)
        assert np.array_equal(got.frames, want.frames)
        assert got.meta == want.meta
    # A strided view (every other column) is its own image.
    wide = np.repeat(img, 2, axis=1)
    assert np.array_equal(cam.capture(wide[:, ::2], frames=1, gain=100, seed=4).frames[0], want.frames[0])
    with pytest.raises(gloam.GloamError, match="dtype"):
        cam.capture(np.full((4, 4), 1 + 1j))
    with pytest.raises(gloam.GloamError, match="3 dimensions"):
        cam.capture(np.zeros((2, 4, 4)))


def test_progress_is_reported_for_renders_captures_and_sweeps(repo, tmp_path, capsys):
    scene = gloam.Scene.load(repo / "sims/panel-validation/scene.toml")
    seen = []
    r = gloam.render(scene, spp=1, seed=1, settings={"resolution_scale": 0.25},
                     progress=lambda d, t, w: seen.append((d, t, w)))
    tiles = [(d, t) for d, t, w in seen if w == "tiles"]
    # The last report is the whole image: every tile done.
    assert tiles and tiles[-1][0] == tiles[-1][1] > 0
    assert all(t == 0 for d, t, w in seen if w.startswith("prepare: "))
    # The same render without a callback: progress changes nothing.
    assert np.array_equal(r.radiance, gloam.render(scene, spp=1, seed=1, settings={"resolution_scale": 0.25}).radiance)
    frames = []
    cam = gloam.Sensor.preset("gen3-gaas-iccd")
    cam.capture(np.full((8, 8), 1e5), frames=5, gain=100, progress=lambda d, t, w: frames.append((d, t, w)))
    assert frames == [(i, 5, "frames") for i in range(1, 6)]
    # progress=True: tqdm when installed, else lines on stderr.
    cam.capture(np.full((8, 8), 1e5), frames=3, gain=100, progress=True)
    err = capsys.readouterr().err
    assert "3/3" in err, err
    # A callback that raises stops the capture with its exception.

    def boom(d, t, w):
        if d == 2:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        cam.capture(np.full((8, 8), 1e5), frames=50, gain=100, progress=boom)
    tasks = []
    s = gloam.sweep(repo / "tests/sweep/twelve.toml", tmp_path / "sw", progress=lambda d, t, w: tasks.append((d, t, w)))
    assert isinstance(s, gloam.SweepResult)
    assert (s.tasks, s.ran, s.skipped, s.failed) == (12, 12, 0, [])
    assert tasks[-1] == (12, 12, "tasks")
    rows = s.results.rows
    assert len(rows) == 12 and all(row["status"] == "done" for row in rows)
    assert (tmp_path / "sw/results.csv").is_file()
    again = gloam.sweep(repo / "tests/sweep/twelve.toml", tmp_path / "sw")
    assert (again.ran, again.skipped) == (0, 12)


def test_ctrl_c_during_preparation_returns_at_once(repo):
    # The office room's preparation (pilot, radiosity cache) takes about a
    # second; without interruption the call would wait for all of it.
    scene = gloam.Scene.load(repo / "sims/office-room/scene.toml")
    kw = dict(spp=1, seed=2, settings={"resolution_scale": 0.25})
    prepare_s = gloam.render(scene, **kw).report["timings_s"]["prepare"]
    raised_at = []

    def interrupt(d, t, what):
        if what.startswith("prepare") and not raised_at:
            raised_at.append(time.monotonic())
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        gloam.render(scene, progress=interrupt, **kw)
    waited = time.monotonic() - raised_at[0]
    assert waited < 0.2 and waited < prepare_s / 2, (waited, prepare_s)


def test_voltage_mtf_and_scope_equal_the_cli(gloam_bin, tmp_path):
    uri = "sim:gen2-s20-iccd?size=128x96"
    run(gloam_bin, "calibrate", "mtf", "--grabber", uri, "--target", "sine", "--space", "voltage",
        "--frequencies", "0.1,0.2", "--frames", "2", "--out", tmp_path / "mtf", cwd=tmp_path)
    cli = json.loads((tmp_path / "mtf/mtf.json").read_text())
    with gloam.open_grabber(uri) as g:
        m = gloam.mtf(g, target="sine", space="voltage", frequencies=[0.1, 0.2], frames=2)
    assert isinstance(m, gloam.Mtf)
    # The same curves and scope points, to rounding (the extension and the
    # CLI are compiled apart: an ulp may differ).
    assert [c.method for c in m.curves] == [c["method"] for c in cli["curves"]]
    for ours, theirs in zip(m.curves, cli["curves"]):
        assert ours.mtf == pytest.approx(theirs["mtf"], rel=1e-12)
    assert len(m.details.voltage_points) == len(cli["details"]["voltage_points"]) == 2
    for ours, theirs in zip(m.details.voltage_points, cli["details"]["voltage_points"]):
        assert ours.v_max == pytest.approx(theirs["v_max"], rel=1e-12)
        assert ours.v_min == pytest.approx(theirs["v_min"], rel=1e-12)
    assert m.method.startswith("voltage")
    with pytest.raises(gloam.GloamError, match="--space voltage reads sine patterns: use --target sine"):
        with gloam.open_grabber(uri) as g:
            gloam.mtf(g, space="voltage")
    run(gloam_bin, "scope", "--grabber", uri, "--rows", "10,48", "--out", tmp_path / "scope", cwd=tmp_path)
    cli = json.loads((tmp_path / "scope/scope.json").read_text())
    s = gloam.scope(grabber=uri, rows=[10, 48])
    assert isinstance(s, gloam.Scope)
    assert [r[0] for r in s.readouts] == [r[0] for r in cli["readouts"]] == [10, 48]
    for (_, ours), (_, theirs) in zip(s.readouts, cli["readouts"]):
        assert ours == pytest.approx(theirs, rel=1e-12)
    assert s.pixel_clock_hz == pytest.approx(cli["pixel_clock_hz"], rel=1e-12)
    # The traces are the CSV's columns.
    assert [l["row"] for l in s.lines] == [10, 48]
    assert s.lines[0]["time_s"].shape == s.lines[0]["volts"].shape
    # Sync tip, blanking: the readouts are levels of the trace itself.
    v = s.lines[1]["volts"]
    assert v.min() == pytest.approx(s.readouts[1][1]["sync_tip_v"], abs=0.02)


def public_callables():
    for name in gloam.__all__:
        obj = getattr(gloam, name)
        if name.startswith("_") or not callable(obj):
            continue
        yield name, obj
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if attr.startswith("_") or attr in vars(dict):
                    continue
                yield f"{name}.{attr}", member


def test_every_public_function_has_a_docstring():
    missing = []
    count = 0
    for name, obj in public_callables():
        count += 1
        doc = inspect.getdoc(obj) if not isinstance(obj, (staticmethod, classmethod)) else inspect.getdoc(obj.__func__)
        # A signature line alone (PyO3's text_signature) is not a docstring.
        text = (doc or "").strip()
        if len(text) < 15:
            missing.append(name)
    assert count > 60, count
    assert not missing, f"no docstring: {missing}"
    # The functions that take a URI name every grabber kind.
    assert "genicam:" in gloam.open_grabber.__doc__
    for f in (gloam.render, gloam.Sensor.capture, gloam.sweep):
        assert "progress" in f.__doc__
