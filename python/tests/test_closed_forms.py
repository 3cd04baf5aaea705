"""Python results against independent answers: the panel's closed form,
the furnace, and the camera chain's analytic transfer worked by hand."""

import math

import numpy as np
import pytest

import gloam

# sims/panel-validation: a 4 × 2 ft Lambertian panel of 15.058 W m⁻² sr⁻¹
# over 400–700 nm, 9 ft above a ρ = 0.9 floor.
L_PANEL, A_FT, B_FT, H_FT, RHO = 15.058, 4.0, 2.0, 9.0, 0.9


def rectangle_centre_irradiance(L, a, b, h):
    """E under the centre of an a × b Lambertian rectangle at height h:
    four corner configuration factors (Hottel's parallel-rectangle form),
    E = 2L Σ [X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))]."""
    x, y = a / 2 / h, b / 2 / h
    sx, sy = math.sqrt(1 + x * x), math.sqrt(1 + y * y)
    return 2 * L * (x / sx * math.atan(y / sx) + y / sy * math.atan(x / sy))


def test_the_closed_form_is_the_readme_figure():
    assert rectangle_centre_irradiance(L_PANEL, A_FT, B_FT, H_FT) == pytest.approx(1.428783, rel=1e-6)


def test_probe_under_the_panel_is_the_closed_form(repo):
    scene = gloam.Scene.load(repo / "sims/panel-validation/scene.toml")
    r = gloam.probe(scene, (0, 0, 0), (0, 0, 1), samples=4)
    want = rectangle_centre_irradiance(L_PANEL, A_FT, B_FT, H_FT)
    assert r["band"] == "vis"
    assert r["irradiance_w_m2"] == pytest.approx(want, rel=1e-9)
    # The floor reflects ρE/π (Lambertian).
    assert r["radiance_w_m2_sr"] == pytest.approx(RHO * want / math.pi, rel=1e-9)


def test_rendered_floor_pixel_is_rho_e_over_pi(repo):
    scene = gloam.Scene.load(repo / "sims/panel-validation/scene.toml")
    out = gloam.render(scene, spp=1, seed=3)
    assert out.radiance.dtype == np.float64
    assert out.radiance.shape == (1, 240, 320)
    want = RHO * rectangle_centre_irradiance(L_PANEL, A_FT, B_FT, H_FT) / math.pi
    # Pixel (160, 211) sees the floor point below the panel centre; its
    # footprint shifts the value by ~5e-5 (README, Results).
    assert out.radiance[0, 211, 160] == pytest.approx(want, rel=5e-4)
    # The panel seen directly reads its own radiance.
    assert out.radiance[0, 30, 160] == pytest.approx(L_PANEL, rel=1e-9)
    assert out.bands[0]["name"] == "vis"
    assert (out.bands[0]["lo_nm"], out.bands[0]["hi_nm"]) == (400.0, 700.0)
    assert out.report["image"] == {"width": 320, "height": 240, "bands": ["vis"]}


FURNACE = """
units = "m"
[camera]
position = [0.6, 0.6, 0.5]
look_at = [2.0, 1.5, 0.3]
up = [0, 0, 1]
fov_deg = 60
width = 16
height = 12
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.wall]
reflectance = 0.5
emission = { value = 1.0, normalize = { lo_nm = 400, hi_nm = 700, value = 1.0 } }
[objects.box]
material = "wall"
box = { min = [0, 0, 0], max = [2.0, 1.5, 1.0], inward = true }
"""


def test_furnace_radiance_is_le_over_one_minus_rho():
    # Any closed enclosure whose walls emit Le and reflect ρ has
    # L = Le/(1−ρ) everywhere (crates/trace/tests/interreflection.rs).
    scene = gloam.Scene.from_toml(FURNACE)
    plan = {e["name"]: e for e in scene.plan()}
    assert plan["interreflection"]["enabled"], plan
    out = gloam.render(scene)
    assert out.radiance.mean() == pytest.approx(1.0 / (1 - 0.5), rel=0.005)
    assert out.report["interreflection"]["method"] == "cache"


def scientific_ccd_without_fixed_pattern(tmp_path, repo):
    text = (repo / "sims/sensors/scientific-ccd.toml").read_text()
    text = text.replace("prnu = 0.005", "prnu = 0.0").replace("dsnu_e = 0.5", "dsnu_e = 0.0")
    p = tmp_path / "ccd.toml"
    p.write_text(text)
    return gloam.Sensor.from_toml(p)


def test_sensor_mean_and_variance_match_the_transfer_by_hand(tmp_path, repo):
    # sims/sensors/scientific-ccd.toml: offset 500 DN, 1.6 e⁻/DN, read
    # noise 3 e⁻, dark 0.001 e⁻/s over 1 s; gain 1. By hand:
    #   mean DN = 500 + (pe + 0.001)/1.6,
    #   temporal variance = (pe + 0.001 + 3²)/1.6² + 1/12 DN² (quantisation).
    cam = scientific_ccd_without_fixed_pattern(tmp_path, repo)
    pe = 20_000.0
    field = np.full((200, 200), pe)
    cap = cam.capture(field, frames=32, gain=1.0, seed=11, input="photoelectrons")
    f = cap.frames.astype(np.float64)[:, 12:-12, 12:-12]
    want_mean = 500 + (pe + 0.001) / 1.6
    assert (f.mean() - want_mean) / (want_mean - 500) == pytest.approx(0, abs=0.005)
    # Photon-transfer style: var(A − B)/2 over frame pairs.
    var = np.mean([np.var(f[i] - f[i + 1], ddof=1) / 2 for i in range(0, 32, 2)])
    want_var = (pe + 0.001 + 9.0) / 1.6**2 + 1 / 12
    assert var / want_var - 1 == pytest.approx(0, abs=0.03)
    # describe() gives the same transfer.
    d = cam.describe(gain=1.0)
    assert d["dn_per_photoelectron"] == pytest.approx(1 / 1.6, rel=1e-9)
    assert cap.meta[0]["gain"] == 1.0
    assert len(cap.meta) == 32 and cap.frames.dtype == np.uint16
