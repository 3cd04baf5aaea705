//! Measured luminaires through the public API: a published road-luminaire
//! EULUMDAT file's total flux against its header, and `photometry = …` in
//! a scene (units, orientation, exclusions, tilt).

use std::path::{Path, PathBuf};

use glam::DVec3;
use gloam_scene::parse_str;
use gloam_scene::photometry::{Photometry, Symmetry};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The published SON-TPP 250 W road luminaire (see tests/data/PROVENANCE.md):
/// 33 200 lm × LORL 84.42 % = 28 027.4 lm in the header. The table's own
/// flux (exact in γ for the piecewise-linear table, trapezoid in C) is
/// 27 933.95 lm, −0.33 %: the file's 10°/5°/2.5° γ steps and 5–15° C steps
/// are all the header's figure was computed from, by whatever quadrature
/// its author used, so agreement to 0.5 % is what the data support.
#[test]
fn published_road_luminaire_flux_matches_its_header() {
    let p = Photometry::read(
        &data("road-luminaire-son-tpp-250w.ldt"),
        &gloam_io::ReadLog::off(),
    )
    .unwrap();
    assert_eq!(p.symmetry, Symmetry::BilateralC90);
    assert_eq!(p.vertical_deg.len(), 25);
    assert_eq!(p.horizontal_deg.len(), 27);
    assert_eq!(
        (p.horizontal_deg[0], *p.horizontal_deg.last().unwrap()),
        (90.0, 270.0)
    );
    let header = p.header_lumens.unwrap();
    assert!((header - 33200.0 * 0.8442).abs() < 1e-6, "{header}");
    let flux = p.flux_lm();
    let rel = (flux - header) / header;
    assert!(
        rel.abs() < 0.005,
        "flux {flux} lm vs header {header} lm ({rel:+.4})"
    );
    assert!((flux - 27933.951).abs() < 0.01, "{flux}");
    // An independent quadrature of the interpolated distribution over the
    // whole sphere (midpoint in cos γ and in C, through the symmetry fold).
    let (ng, nc) = (4000, 720);
    let mut sum = 0.0;
    for i in 0..ng {
        let mu = -1.0 + (i as f64 + 0.5) * 2.0 / ng as f64;
        let g = mu.acos().to_degrees();
        for j in 0..nc {
            sum += p.candela_at(g, (j as f64 + 0.5) * 360.0 / nc as f64);
        }
    }
    let quad = sum * (2.0 / ng as f64) * (2.0 * std::f64::consts::PI / nc as f64);
    assert!(((quad - flux) / flux).abs() < 2e-4, "{quad} vs {flux}");
    // Isym = 3 stores C270 → C0 → C90; its peak, 534 cd/klm at C350,
    // γ = 65°, reappears at C190 by the mirror about C90–C270.
    let klm = 33.2;
    assert!((p.candela_at(65.0, 350.0) - 534.0 * klm).abs() < 1e-9);
    assert!((p.candela_at(65.0, 190.0) - 534.0 * klm).abs() < 1e-9);
    assert!((p.candela_at(60.0, 0.0) - 331.0 * klm).abs() < 1e-9);
    assert!((p.candela_at(60.0, 90.0) - 56.0 * klm).abs() < 1e-9);
    assert!((p.candela_at(60.0, 270.0) - 64.0 * klm).abs() < 1e-9);
    assert!((p.max_candela - 534.0 * klm).abs() < 1e-9);
    assert_eq!(p.candela_at(95.0, 0.0), 0.0);
}

fn scene_with(lamp: &str, dir: &Path) -> Result<gloam_scene::Scene, String> {
    let text = format!(
        r#"
units = "m"
[camera]
position = [0, -10, 5]
look_at = [0, 0, 0]
fov_deg = 60
width = 8
height = 8
[bands.vis]
lo_nm = 400
hi_nm = 700
[point_sources.lamp]
position = [0, 0, 8]
{lamp}
"#
    );
    parse_str(&text, &dir.join("scene.toml")).map_err(|e| e.to_string())
}

#[test]
fn a_scene_lamp_carries_the_files_candela_in_its_spectrum() {
    let dir = data("");
    let s = scene_with(
        "photometry = \"road-luminaire-son-tpp-250w.ldt\"\nspectrum = \"hps\"\nc0_direction = [0, 1, 0]\nscale = 0.5",
        &dir,
    )
    .unwrap();
    let p = &s.point_sources[0];
    assert!(p.is_shaped());
    let lum = p.luminaire.as_ref().unwrap();
    // 683 ∫ V I_s dλ = I_max × scale, in candela.
    let cd = gloam_spectra::photopic(&p.intensity_w_sr_nm);
    assert!((cd - 0.5 * 534.0 * 33.2).abs() < 1e-9 * cd, "{cd}");
    assert_eq!(lum.c0, DVec3::Y);
    // C90 = −direction × C0 = z × y = −x; the peak is at C350, γ = 65°.
    let dir_c = |c: f64, g: f64| {
        let (c, g) = (c.to_radians(), g.to_radians());
        g.sin() * (c.cos() * DVec3::Y - c.sin() * DVec3::X) - g.cos() * DVec3::Z
    };
    assert!((lum.relative_toward(p.direction, dir_c(350.0, 65.0)) - 1.0).abs() < 1e-9);
    for (c, g) in [(0.0, 60.0), (90.0, 60.0), (270.0, 60.0), (123.0, 33.0)] {
        let want = lum.table.candela_at(g, c) / lum.table.max_candela;
        let got = lum.relative_toward(p.direction, dir_c(c, g));
        assert!((got - want).abs() < 1e-9, "C{c} γ{g}: {got} vs {want}");
    }
    // Default C0: +x projected.
    let s = scene_with(
        "photometry = \"road-luminaire-son-tpp-250w.ldt\"\nspectrum = \"hps\"",
        &dir,
    )
    .unwrap();
    assert_eq!(s.point_sources[0].luminaire.as_ref().unwrap().c0, DVec3::X);
}

#[test]
fn photometry_excludes_the_keys_that_would_contradict_it() {
    let dir = data("");
    let f = "photometry = \"road-luminaire-son-tpp-250w.ldt\"\n";
    for (extra, want) in [
        (
            "spectrum = \"hps\"\nshape_exponent = 2",
            "point_sources.lamp.shape_exponent: `shape_exponent` and `photometry` exclude each other",
        ),
        (
            "value = 1.0",
            "point_sources.lamp.value: `value` and `photometry` exclude each other",
        ),
        (
            "spectrum = \"hps\"\nnormalize = { lo_nm = 400, hi_nm = 700, value = 1 }",
            "`normalize` and `photometry` exclude each other",
        ),
        ("", "needs its spectral shape"),
        (
            "spectrum = \"hps\"\nc0_direction = [0, 0, 2]",
            "point_sources.lamp.c0_direction: c0_direction is parallel to direction",
        ),
        (
            "spectrum = \"hps\"\nscale = -1",
            "point_sources.lamp.scale: scale -1 must be",
        ),
    ] {
        let e = scene_with(&format!("{f}{extra}"), &dir).unwrap_err();
        assert!(e.contains(want), "{e}\n  should contain: {want}");
        assert!(e.contains("scene.toml:"), "{e}");
    }
    let e = scene_with("value = 1\nc0_direction = [1, 0, 0]", &dir).unwrap_err();
    assert!(
        e.contains("point_sources.lamp.c0_direction: `c0_direction` orients a measured luminaire"),
        "{e}"
    );
    let e = scene_with("photometry = \"missing.ies\"\nspectrum = \"hps\"", &dir).unwrap_err();
    assert!(
        e.contains("point_sources.lamp.photometry: photometry file:") && e.contains("missing.ies"),
        "{e}"
    );
    let e = scene_with("photometry = \"PROVENANCE.md\"\nspectrum = \"hps\"", &dir).unwrap_err();
    assert!(e.contains("unknown photometric format"), "{e}");
}

/// TILT=INCLUDE: the multiplier at the nadir's angle from straight down,
/// for each placement.
#[test]
fn tilt_table_scales_each_placement_by_its_tilt() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tilt.ies"),
        "IESNA:LM-63-2002\nTILT=INCLUDE\n1\n3\n0 45 90\n1.0 0.8 0.5\n1 -1 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 100\n",
    )
    .unwrap();
    let s = scene_with(
        "photometry = \"tilt.ies\"\nspectrum = \"cie-a\"\ndirection = [0, 0, -1]\ninstances = [{ translate = [0, 0, 0] }, { rotate_z_deg = 90, translate = [1, 0, 0] }]",
        dir.path(),
    )
    .unwrap();
    for p in &s.point_sources {
        let cd = gloam_spectra::photopic(&p.intensity_w_sr_nm);
        assert!((cd - 100.0).abs() < 1e-9, "{cd}");
    }
    let s = scene_with(
        "photometry = \"tilt.ies\"\nspectrum = \"cie-a\"\ndirection = [1, 0, -1]",
        dir.path(),
    )
    .unwrap();
    let cd = gloam_spectra::photopic(&s.point_sources[0].intensity_w_sr_nm);
    assert!((cd - 80.0).abs() < 1e-9, "tilted 45°: {cd}");
}

fn area_scene_with(emission: &str, dir: &Path) -> Result<gloam_scene::Scene, String> {
    let text = format!(
        r#"
units = "m"
[camera]
position = [0, -10, 5]
look_at = [0, 0, 0]
fov_deg = 60
width = 8
height = 8
[bands.vis]
lo_nm = 400
hi_nm = 700
[materials.lens]
emission = {{ {emission} }}
[objects.lens]
material = "lens"
quad = {{ center = [0, 0, 8], size = [0.6, 0.3], normal = [0, 0, -1] }}
"#
    );
    parse_str(&text, &dir.join("scene.toml")).map_err(|e| e.to_string())
}

/// An area luminaire's flux: with `L = I_max·scale/A × I(γ, C)/(I_max cos γ)`
/// the object emits `∫_A ∫_hemisphere L cos γ dω dA = scale × ∫ I dω` —
/// the published road luminaire's 27 933.95 lm (all below γ = 90°),
/// halved by `scale = 0.5`. Quadrature (midpoint in cos γ and C) of the
/// profile the tracer evaluates, times the luminance the spectrum carries.
#[test]
fn an_area_luminaire_emits_the_files_flux() {
    let dir = data("");
    let s = area_scene_with(
        "photometry = \"road-luminaire-son-tpp-250w.ldt\", spectrum = \"hps\", c0_direction = [0, 1, 0], scale = 0.5",
        &dir,
    )
    .unwrap();
    let e = s.materials[s.objects[0].material]
        .emission
        .as_ref()
        .unwrap();
    let lum = e.luminaire.as_ref().unwrap();
    assert_eq!(e.shape_exponent, 0.0);
    // The 1 m² radiance: I_max × scale in candela, per m².
    let i_max = gloam_spectra::photopic(&e.radiance_w_m2_sr_nm);
    assert!((i_max - 0.5 * 534.0 * 33.2).abs() < 1e-9 * i_max, "{i_max}");
    let n = DVec3::NEG_Z;
    let c0 = lum.c0_for(n);
    assert_eq!(c0, DVec3::Y);
    let c90 = -n.cross(c0);
    let (ng, nc) = (4000, 720);
    let mut sum = 0.0;
    for i in 0..ng {
        let mu = (i as f64 + 0.5) / ng as f64;
        let sin = (1.0 - mu * mu).sqrt();
        for j in 0..nc {
            let c = ((j as f64 + 0.5) * 360.0 / nc as f64).to_radians();
            let w = mu * n + sin * (c.cos() * c0 + c.sin() * c90);
            sum += lum.relative_radiance(n, c0, w) * mu;
        }
    }
    // A cancels: L·A = I_max·scale × profile.
    let flux = i_max * sum / ng as f64 * (2.0 * std::f64::consts::PI / nc as f64);
    let want = 0.5 * lum.table.flux_lm();
    assert!((want - 0.5 * 27933.951).abs() < 0.01, "{want}");
    assert!(((flux - want) / want).abs() < 2e-4, "{flux} vs {want}");
    // Orientation: the peak (C350, γ = 65°) with C90 = −n × C0 = −x.
    let (g, c) = (65f64.to_radians(), 350f64.to_radians());
    let w = g.cos() * n + g.sin() * (c.cos() * c0 + c.sin() * c90);
    let peak = 1.0 / g.cos();
    assert!((lum.relative_radiance(n, c0, w) - peak).abs() < 1e-9 * peak);
    // Behind the facet: nothing; at the horizon: bounded.
    assert_eq!(lum.relative_radiance(n, c0, -n), 0.0);
    let grazing = lum.relative_radiance(n, c0, (c0 + 1e-9 * n).normalize());
    assert!(grazing.is_finite() && grazing <= 1.0 / gloam_scene::AreaLuminaire::MIN_COS_GAMMA);
    eprintln!("area luminaire flux {flux:.3} lm vs file × scale {want:.3} lm");
}

#[test]
fn area_photometry_excludes_the_keys_that_would_contradict_it() {
    let dir = data("");
    let f = "photometry = \"road-luminaire-son-tpp-250w.ldt\"";
    for (extra, want) in [
        (
            ", spectrum = \"hps\", shape_exponent = 2",
            "materials.lens.emission.shape_exponent: `shape_exponent` and `photometry` exclude each other",
        ),
        (
            ", value = 1.0",
            "materials.lens.emission.value: `value` and `photometry` exclude each other",
        ),
        (
            "",
            "materials.lens.emission: a measured luminaire needs its spectral shape",
        ),
        (
            ", spectrum = \"hps\", c0_direction = [0, 0, 0]",
            "materials.lens.emission.c0_direction: c0_direction is a zero vector",
        ),
        (
            ", spectrum = \"hps\", scale = -1",
            "materials.lens.emission.scale: scale -1 must be",
        ),
    ] {
        let e = area_scene_with(&format!("{f}{extra}"), &dir).unwrap_err();
        assert!(e.contains(want), "{e}\n  should contain: {want}");
        assert!(e.contains("scene.toml:"), "{e}");
    }
    let e = area_scene_with("value = 1, c0_direction = [1, 0, 0]", &dir).unwrap_err();
    assert!(
        e.contains(
            "materials.lens.emission.c0_direction: `c0_direction` orients a measured luminaire"
        ),
        "{e}"
    );
    let e = area_scene_with("photometry = \"missing.ldt\", spectrum = \"hps\"", &dir).unwrap_err();
    assert!(
        e.contains("materials.lens.emission.photometry: photometry file:")
            && e.contains("missing.ldt"),
        "{e}"
    );
}
