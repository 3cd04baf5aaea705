//! Unit tests: every error class names file, line and field; geometry helpers
//! against closed forms; the plan for synthetic scenes.

use std::path::{Path, PathBuf};

use glam::DVec3;

use crate::plan::{Effect, names, plan, plan_with};
use crate::{Facet, SceneError, parse_str};

/// A valid scene; line numbers below are relative to this text.
const BASE: &str = r#"units = "m"

[camera]
position = [0.0, -5.0, 1.5]
look_at = [0.0, 0.0, 1.0]
fov_deg = 60.0
width = 64
height = 48

[bands.vis]
lo_nm = 400
hi_nm = 700

[materials.grey]
reflectance = 0.5

[objects.floor]
material = "grey"
quad = { center = [0.0, 0.0, 0.0], size = [10.0, 10.0], normal = [0.0, 0.0, 1.0] }
"#;

/// Line number of the first line of `extra` when appended to BASE.
fn next_line() -> usize {
    BASE.lines().count() + 1
}

fn scene_path(dir: &Path) -> PathBuf {
    dir.join("scene.toml")
}

fn parse(text: &str) -> Result<crate::Scene, SceneError> {
    parse_str(text, Path::new("dir/scene.toml"))
}

/// Parses `text` and checks the error names `dir/scene.toml`, `line` and
/// `field`, and that the message contains `needle`.
#[track_caller]
fn expect_err(text: &str, line: usize, field: &str, needle: &str) -> String {
    expect_err_at(text, Path::new("dir/scene.toml"), line, field, needle)
}

#[track_caller]
fn expect_err_at(text: &str, path: &Path, line: usize, field: &str, needle: &str) -> String {
    let e = match parse_str(text, path) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    };
    let msg = e.to_string();
    let prefix = format!("{}:{line}: {field}: ", path.display());
    assert!(
        msg.starts_with(&prefix),
        "error\n  {msg}\ndoes not start with\n  {prefix}"
    );
    assert!(
        msg.contains(needle),
        "error\n  {msg}\ndoes not mention '{needle}'"
    );
    assert_eq!(e.line(), line);
    assert_eq!(e.field(), field);
    msg
}

#[test]
fn base_scene_parses() {
    let s = parse(BASE).unwrap();
    assert_eq!(s.units, crate::Units::Meters);
    assert_eq!(s.meters_per_unit, 1.0);
    assert_eq!(s.facets.len(), 1);
    assert_eq!(s.bands[0].name, "vis");
    assert_eq!(s.camera.up, DVec3::Z);
}

// --- syntax, unknown keys, types ---------------------------------------------

#[test]
fn toml_syntax_error_names_line() {
    let text = format!("{BASE}\n[materials.bad\nreflectance = 0.5\n");
    expect_err(&text, next_line() + 1, "(toml syntax)", "");
}

#[test]
fn unknown_key_in_header_table() {
    let text = format!("{BASE}[materials.paint]\nreflectance = 0.5\nshine = 2.0\n");
    expect_err(
        &text,
        next_line() + 2,
        "materials.paint.shine",
        "unknown field `shine`",
    );
}

#[test]
fn unknown_key_in_inline_table() {
    let text = format!(
        "{BASE}[objects.q]\nmaterial = \"grey\"\nquad = {{ center = [0.0, 0.0, 1.0], size = [1.0, 1.0], normal = [0.0, 0.0, 1.0], colour = 3 }}\n"
    );
    expect_err(
        &text,
        next_line() + 2,
        "objects.q.quad.colour",
        "unknown field `colour`",
    );
}

#[test]
fn unknown_top_level_key() {
    let text = BASE.replace("units = \"m\"\n", "units = \"m\"\nlights = 3\n");
    expect_err(&text, 2, "lights", "unknown field `lights`");
    // Appended after a table header, the key belongs to that table.
    let text = format!("{BASE}lights = 3\n");
    expect_err(
        &text,
        next_line(),
        "objects.floor.lights",
        "unknown field `lights`",
    );
}

#[test]
fn wrong_type_names_field() {
    let text = BASE.replace("fov_deg = 60.0", "fov_deg = \"wide\"");
    expect_err(&text, 6, "camera.fov_deg", "");
}

// --- units ---------------------------------------------------------------------

#[test]
fn bad_units() {
    let text = BASE.replace("units = \"m\"", "units = \"yd\"");
    expect_err(&text, 1, "units", "unknown units 'yd'");
}

#[test]
fn feet_units() {
    let s = parse(&BASE.replace("units = \"m\"", "units = \"ft\"")).unwrap();
    assert_eq!(s.units, crate::Units::Feet);
    assert_eq!(s.meters_per_unit, 0.3048);
}

// --- references ----------------------------------------------------------------

#[test]
fn unknown_material() {
    let text = BASE.replace("material = \"grey\"", "material = \"gray\"");
    expect_err(
        &text,
        18,
        "objects.floor.material",
        "unknown material 'gray'",
    );
}

#[test]
fn unknown_spectrum() {
    let text = format!(
        "{BASE}[materials.lamp]\nemission = {{ spectrum = \"sodium-xyz\", shape_exponent = 0 }}\n"
    );
    expect_err(
        &text,
        next_line() + 1,
        "materials.lamp.emission.spectrum",
        "unknown spectrum 'sodium-xyz'",
    );
}

#[test]
fn unknown_reflectance_spectrum() {
    let text = BASE.replace("reflectance = 0.5", "reflectance = \"paint.csv\"");
    expect_err(
        &text,
        15,
        "materials.grey.reflectance",
        "unknown spectrum 'paint.csv'",
    );
}

#[test]
fn csv_spectrum_relative_to_scene_and_its_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("paint.csv"),
        "wavelength_nm,value\n400,0.2\n700,0.4\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("bad.csv"),
        "wavelength_nm,value\n400,0.2\n700,oops\n",
    )
    .unwrap();
    let path = scene_path(dir.path());
    let s = parse_str(
        &BASE.replace("reflectance = 0.5", "reflectance = \"paint.csv\""),
        &path,
    )
    .unwrap();
    assert!((s.materials[0].reflectance.eval(550.0) - 0.3).abs() < 1e-12);
    let msg = expect_err_at(
        &BASE.replace("reflectance = 0.5", "reflectance = \"bad.csv\""),
        &path,
        15,
        "materials.grey.reflectance",
        "bad.csv:3",
    );
    assert!(msg.contains("spectrum file"));
}

// --- geometry ------------------------------------------------------------------

fn inline_object(vertices: &str, faces: &str) -> String {
    format!("{BASE}[objects.thing]\nmaterial = \"grey\"\nvertices = {vertices}\nfaces = {faces}\n")
}

#[test]
fn zero_area_triangle() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]]",
        "[[0, 1, 2]]",
    );
    expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "zero area",
    );
}

#[test]
fn sliver_triangle_reports_its_area_and_the_threshold() {
    // Area 5e-11, longest edge 2: not above 1e-9 × 2² = 4e-9. Not "zero".
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 1e-10, 1.0]]",
        "[[0, 1, 2]]",
    );
    let m = expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "sliver: area 5.000e-11 units² is not above the threshold 4.000e-9 units²",
    );
    assert!(!m.contains("zero area"), "{m}");
    // Just above the threshold it is a facet (beside the base's floor).
    let ok = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 1e-8, 1.0]]",
        "[[0, 1, 2]]",
    );
    assert_eq!(parse(&ok).unwrap().facets.len(), 2);
}

#[test]
fn coincident_vertices() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]",
        "[[0, 1, 2], [0, 1, 1]]",
    );
    expect_err(&text, next_line() + 3, "objects.thing.faces[1]", "coincide");
}

#[test]
fn collinear_quad_vertices() {
    // Vertices 0, 1, 2 lie on a line: a triangle posing as a quad.
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0], [1.0, 1.0, 1.0]]",
        "[[0, 1, 2, 3]]",
    );
    expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "collinear",
    );
}

#[test]
fn non_planar_quad() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.2], [0.0, 1.0, 1.0]]",
        "[[0, 1, 2, 3]]",
    );
    expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "non-planar",
    );
}

#[test]
fn slightly_non_planar_quad_within_tolerance_is_accepted() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.000001], [0.0, 1.0, 1.0]]",
        "[[0, 1, 2, 3]]",
    );
    parse(&text).unwrap();
}

#[test]
fn non_convex_quad() {
    // An arrowhead (dart): vertex 3 pushed inside the triangle 0-1-2.
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [1.0, 2.0, 1.0], [1.0, 0.5, 1.0]]",
        "[[0, 1, 2, 3]]",
    );
    expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "non-convex",
    );
    // A bow-tie (self-intersecting).
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]]",
        "[[0, 1, 2, 3]]",
    );
    expect_err(&text, next_line() + 3, "objects.thing.faces[0]", "");
}

#[test]
fn face_index_out_of_range_and_bad_arity() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]",
        "[[0, 1, 3]]",
    );
    expect_err(
        &text,
        next_line() + 3,
        "objects.thing.faces[0]",
        "out of range",
    );
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]",
        "[[0, 1]]",
    );
    expect_err(&text, next_line() + 3, "objects.thing.faces[0]", "3 or 4");
}

#[test]
fn nan_and_infinite_coordinates() {
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, nan, 1.0], [0.0, 1.0, 1.0]]",
        "[[0, 1, 2]]",
    );
    expect_err(
        &text,
        next_line() + 2,
        "objects.thing.vertices[1][1]",
        "not a finite",
    );
    let text = BASE.replace("position = [0.0, -5.0, 1.5]", "position = [0.0, -inf, 1.5]");
    expect_err(&text, 4, "camera.position[1]", "not a finite");
    let text = BASE.replace("center = [0.0, 0.0, 0.0]", "center = [0.0, 0.0, nan]");
    expect_err(&text, 19, "objects.floor.quad.center[2]", "not a finite");
}

#[test]
fn geometry_kinds_are_exclusive_and_required() {
    let text = format!("{BASE}[objects.none]\nmaterial = \"grey\"\n");
    expect_err(&text, next_line(), "objects.none", "no geometry");
    let text = format!(
        "{BASE}[objects.two]\nmaterial = \"grey\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }}\nobj = \"x.obj\"\n"
    );
    expect_err(&text, next_line(), "objects.two", "more than one kind");
}

#[test]
fn zero_volume_box_and_zero_size_quad() {
    let text = format!(
        "{BASE}[objects.b]\nmaterial = \"grey\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 0.0, 1.0] }}\n"
    );
    expect_err(&text, next_line() + 2, "objects.b.box.max", "zero-volume");
    let text = BASE.replace("size = [10.0, 10.0]", "size = [10.0, 0.0]");
    expect_err(&text, 19, "objects.floor.quad.size[1]", "zero area");
}

#[test]
fn obj_file_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"missing.obj\"\n");
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "cannot read OBJ file",
    );
    // Line and point elements are reported, not dropped.
    std::fs::write(
        dir.path().join("lines.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nl 1 2\n",
    )
    .unwrap();
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"lines.obj\"\n");
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "line element",
    );
    // A directory or a device is named as such, never read.
    std::fs::create_dir(dir.path().join("adir.obj")).unwrap();
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"adir.obj\"\n");
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "is a directory",
    );
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"/dev/zero\"\n");
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "not a regular file",
    );
    std::fs::write(
        dir.path().join("warped.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"warped.obj\"\n");
    expect_err_at(&text, &path, next_line() + 2, "objects.m.obj", "non-planar");
    std::fs::write(
        dir.path().join("penta.obj"),
        "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\nf 1 2 3 4 5\n",
    )
    .unwrap();
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"penta.obj\"\n");
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "this one has 5",
    );
}

#[test]
fn obj_quads_kept_and_transformed() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    std::fs::write(
        dir.path().join("sq.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n",
    )
    .unwrap();
    let text = format!(
        "{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"sq.obj\"\nscale = 2.0\ntranslate = [10.0, 0.0, 0.0]\n"
    );
    let s = parse_str(&text, &path).unwrap();
    let quads: Vec<&Facet> = s.facets.iter().filter(|f| f.object == "m").collect();
    assert_eq!(quads.len(), 2);
    assert_eq!(quads[0].vertices.len(), 4);
    assert_eq!(quads[0].vertices[2], DVec3::new(12.0, 2.0, 0.0));
    assert!((quads[0].area() - 4.0).abs() < 1e-12);
    assert_eq!(quads[1].vertices.len(), 3);
}

/// A load notes in its log the scene and the files it leads to (here a
/// CSV spectrum and an OBJ mesh), each with the hash of its bytes.
#[test]
fn load_notes_the_scene_and_the_files_it_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n";
    let csv = "wavelength_nm,value\n400,0.2\n700,0.4\n";
    std::fs::write(dir.path().join("t.obj"), obj).unwrap();
    std::fs::write(dir.path().join("paint.csv"), csv).unwrap();
    let text = format!("{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"t.obj\"\n")
        .replace("reflectance = 0.5", "reflectance = \"paint.csv\"");
    std::fs::write(&path, &text).unwrap();
    let log = gloam_io::ReadLog::new();
    crate::load(&path, &log).unwrap();
    let got: Vec<(String, Option<String>)> = log
        .reads()
        .into_iter()
        .map(|r| {
            let name = r.path.file_name().unwrap().to_string_lossy().into_owned();
            (name, r.sha256)
        })
        .collect();
    let sha = |s: &str| Some(gloam_io::sha256_hex(s.as_bytes()));
    assert_eq!(
        got,
        [
            (
                path.file_name().unwrap().to_string_lossy().into_owned(),
                sha(&text)
            ),
            ("paint.csv".into(), sha(csv)),
            ("t.obj".into(), sha(obj)),
        ]
    );
}

// --- radiometry ----------------------------------------------------------------

#[test]
fn negative_reflectance() {
    let text = BASE.replace("reflectance = 0.5", "reflectance = -0.1");
    expect_err(
        &text,
        15,
        "materials.grey.reflectance",
        "negative reflectance",
    );
}

#[test]
fn reflectance_above_one() {
    let text = BASE.replace("reflectance = 0.5", "reflectance = 1.2");
    expect_err(&text, 15, "materials.grey.reflectance", "exceeds 1");
    // A lamp spectrum used as a reflectance has lines and large values.
    let text = BASE.replace("reflectance = 0.5", "reflectance = \"mercury-clear\"");
    expect_err(&text, 15, "materials.grey.reflectance", "emission lines");
}

#[test]
fn transmission_above_one() {
    let text = BASE.replace(
        "reflectance = 0.5",
        "reflectance = 0.0\ntransmission = { value = 0.5, scale = 2.5 }",
    );
    expect_err(
        &text,
        16,
        "materials.grey.transmission",
        "transmission 1.25",
    );
}

#[test]
fn reflectance_plus_transmission_above_one() {
    let text = BASE.replace("reflectance = 0.5", "reflectance = 0.5\ntransmission = 0.6");
    expect_err(&text, 16, "materials.grey.transmission", "exceeds 1");
    // A leaf: ρ + τ ≤ 1 is fine.
    let s =
        parse(&BASE.replace("reflectance = 0.5", "reflectance = 0.4\ntransmission = 0.5")).unwrap();
    assert!(s.materials[0].is_transmissive());
}

#[test]
fn specular_fraction_range() {
    let text = BASE.replace(
        "reflectance = 0.5",
        "reflectance = 0.5\nspecular_fraction = 1.5",
    );
    expect_err(&text, 16, "materials.grey.specular_fraction", "within 0..1");
}

#[test]
fn emission_normalisation_and_errors() {
    let text = format!(
        "{BASE}[materials.panel]\nemission = {{ value = 1.0, normalize = {{ lo_nm = 400, hi_nm = 700, value = 15.058 }}, shape_exponent = 2 }}\n"
    );
    let s = parse(&text).unwrap();
    let (_, m) = s.material_by_name("panel").unwrap();
    let e = m.emission.as_ref().unwrap();
    assert!((e.radiance_w_m2_sr_nm.integrate_band(400.0, 700.0) - 15.058).abs() < 1e-12);
    assert!((e.radiance_w_m2_sr_nm.eval(550.0) - 15.058 / 300.0).abs() < 1e-14);
    assert_eq!(e.shape_exponent, 2.0);
    assert_eq!(m.reflectance.integral(), 0.0);

    // A library spectrum with no power in the band cannot be normalised there.
    let text = format!(
        "{BASE}[materials.panel]\nemission = {{ spectrum = \"lps\", normalize = {{ lo_nm = 300, hi_nm = 380, value = 1.0 }} }}\n"
    );
    expect_err(
        &text,
        next_line() + 1,
        "materials.panel.emission.normalize",
        "integrates to zero",
    );

    let text =
        format!("{BASE}[materials.panel]\nemission = {{ value = 1.0, shape_exponent = -1 }}\n");
    expect_err(
        &text,
        next_line() + 1,
        "materials.panel.emission.shape_exponent",
        "in [0, 10000]",
    );

    let text =
        format!("{BASE}[materials.panel]\nemission = {{ spectrum = \"hps\", value = 1.0 }}\n");
    expect_err(
        &text,
        next_line() + 1,
        "materials.panel.emission.value",
        "not both",
    );
}

#[test]
fn point_source_parsing_and_errors() {
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\ndirection = [0.0, 0.0, -2.0]\nshape_exponent = 4\nspectrum = \"hps\"\nnormalize = {{ lo_nm = 400, hi_nm = 700, value = 100.0 }}\n"
    );
    let s = parse(&text).unwrap();
    let p = &s.point_sources[0];
    assert_eq!(p.direction, DVec3::NEG_Z);
    assert!((p.intensity_w_sr_nm.integrate_band(400.0, 700.0) - 100.0).abs() < 1e-9);
    assert!(p.is_shaped());

    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\ndirection = [0.0, 0.0, 0.0]\nvalue = 1.0\n"
    );
    expect_err(
        &text,
        next_line() + 2,
        "point_sources.lamp.direction",
        "zero vector",
    );
    let text = format!("{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\n");
    expect_err(
        &text,
        next_line(),
        "point_sources.lamp",
        "missing `spectrum`",
    );
}

// --- emission lines ------------------------------------------------------------------

#[test]
fn point_source_lines_integrate_exactly_over_bands() {
    // A user lamp: a coarse CSV continuum (W sr⁻¹ nm⁻¹) with one line row,
    // plus two lines in the scene (W sr⁻¹).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("lamp.csv"),
        "wavelength_nm,value\n400,0.01\n500,0.03\n600,0.02\n700,0.01\nline,589.0,0.2\n",
    )
    .unwrap();
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nspectrum = \"lamp.csv\"\nlines = [\n  [546.07, 0.12],\n  [435.83, 0.05],\n]\n"
    );
    let s = parse_str(&text, &scene_path(dir.path())).unwrap();
    let i = &s.point_sources[0].intensity_w_sr_nm;
    let lines: Vec<(f64, f64)> = i
        .lines()
        .iter()
        .map(|l| (l.wavelength_nm, l.value))
        .collect();
    assert_eq!(lines, [(435.83, 0.05), (546.07, 0.12), (589.0, 0.2)]);
    // Closed forms: the continuum is linear on each 100 nm piece.
    let c = |w: f64| i.eval(w);
    let trap = |a: f64, b: f64| 0.5 * (b - a) * (c(a) + c(b));
    let cases = [
        (540.0, 550.0, trap(540.0, 550.0) + 0.12),
        (540.0, 546.07, trap(540.0, 546.07)), // the line sits on the open upper edge
        (546.07, 600.0, trap(546.07, 600.0) + 0.12 + 0.2),
        (400.0, 700.0, 6.0 + 0.37),
    ];
    for (lo, hi, want) in cases {
        let got = i.integrate_band(lo, hi);
        assert!(
            (got - want).abs() <= 1e-14 * want,
            "{lo}–{hi}: {got} vs {want}"
        );
    }
    // Through a band response: the lines are weighted by the response at
    // their wavelength, the continuum product is integrated exactly.
    let response = gloam_spectra::Spectrum::new(vec![500.0, 600.0], vec![0.2, 0.6]).unwrap();
    let r = |w: f64| response.eval(w);
    // ∫_500^600 c·r dλ for two linear pieces: h/6 (2 c0 r0 + c0 r1 + c1 r0 + 2 c1 r1).
    let cont = 100.0 / 6.0
        * (2.0 * c(500.0) * r(500.0)
            + c(500.0) * r(600.0)
            + c(600.0) * r(500.0)
            + 2.0 * c(600.0) * r(600.0));
    let want = cont + 0.12 * r(546.07) + 0.2 * r(589.0);
    let got = i.integrate_weighted(&response);
    assert!((got - want).abs() <= 1e-14 * want, "{got} vs {want}");
}

#[test]
fn lines_alone_with_value_scale_and_normalize() {
    // Lines only (a low-pressure sodium panel), then scaled.
    let text = format!(
        "{BASE}[materials.sox]\nemission = {{ lines = [[588.995, 2.0], [589.592, 1.0]], scale = 0.5 }}\n"
    );
    let s = parse(&text).unwrap();
    let (_, m) = s.material_by_name("sox").unwrap();
    let l = &m.emission.as_ref().unwrap().radiance_w_m2_sr_nm;
    assert!(l.wavelengths_nm().is_empty());
    assert_eq!(l.integral(), 1.5);
    assert_eq!(l.integrate_band(589.0, 590.0), 0.5);
    // A flat continuum plus a line, normalised as a whole: 300 nm × 0.01 + 1 = 4 → 8.
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nvalue = 0.01\nlines = [[546, 1]]\nnormalize = {{ lo_nm = 400, hi_nm = 700, value = 8.0 }}\n"
    );
    let s = parse(&text).unwrap();
    let i = &s.point_sources[0].intensity_w_sr_nm;
    assert!((i.integrate_band(400.0, 700.0) - 8.0).abs() < 1e-12);
    assert!((i.lines()[0].value - 2.0).abs() < 1e-12);
    // A line added to a built-in lamp; an empty list changes nothing.
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nspectrum = \"mercury-clear\"\nlines = [[1200.0, 0.5]]\n"
    );
    let s = parse(&text).unwrap();
    let hg = gloam_spectra::library::get("mercury-clear").unwrap();
    let i = &s.point_sources[0].intensity_w_sr_nm;
    assert_eq!(i.lines().len(), hg.lines().len() + 1);
    assert!((i.integral() - hg.integral() - 0.5).abs() < 1e-9);
    let text = format!("{BASE}[materials.panel]\nemission = {{ value = 1.0, lines = [] }}\n");
    assert!(parse(&text).is_ok());
}

#[test]
fn line_errors_name_file_line_and_field() {
    let n = next_line();
    let src = |lines: &str| {
        format!(
            "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nvalue = 0.01\nlines = {lines}\n"
        )
    };
    let f = "point_sources.lamp.lines";
    // Bad values, then wrong shapes at the element (one number, three
    // numbers, none, no list, a string): the field under `lines` and a
    // part of the message, all on the `lines` line.
    let cases = [
        (
            "[[nan, 1.0]]",
            "[0][0]",
            "wavelength NaN nm must be a finite number in (0, 1e6]",
        ),
        ("[[546.0, 1.0], [-5.0, 1.0]]", "[1][0]", "wavelength -5 nm"),
        ("[[0, 1.0]]", "[0][0]", "wavelength 0 nm"),
        (
            "[[546.0, inf]]",
            "[0][1]",
            "value inf W sr⁻¹ at 546 nm must be a finite number ≥ 0",
        ),
        ("[[546.0, -0.1]]", "[0][1]", "value -0.1 W sr⁻¹"),
        (
            "[[546.0]]",
            "[0]",
            "an emission line is [wavelength_nm, value], found 1 number",
        ),
        ("[[589.0, 1.0], [546.0, 1, 2]]", "[1]", "found 3 numbers"),
        ("[[]]", "[0]", "found 0 numbers"),
        ("[546.0, 0.1]", "[0]", "invalid type"),
        ("[[\"green\", 0.1]]", "[0][0]", "invalid type: string"),
    ];
    for (lines, at, part) in cases {
        expect_err(&src(lines), n + 3, &format!("{f}{at}"), part);
    }
    let msg = expect_err(
        &src("[\n  [546.0, 0.1],\n  [589.0, 0.1],\n  [546.0, 0.2],\n]"),
        n + 6,
        &format!("{f}[2]"),
        "a second emission line at 546 nm",
    );
    assert!(msg.contains(&format!("the first is {f}[0]")), "{msg}");
    // Duplicate of a line the named spectrum already has.
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nspectrum = \"mercury-clear\"\nlines = [[546.074, 0.1]]\n"
    );
    expect_err(
        &text,
        n + 3,
        &format!("{f}[0]"),
        "spectrum 'mercury-clear' already has an emission line at 546.074 nm",
    );
    // Emission units in the message.
    let text = format!("{BASE}[materials.panel]\nemission = {{ lines = [[546.0, -1.0]] }}\n");
    expect_err(
        &text,
        n + 1,
        "materials.panel.emission.lines[0][1]",
        "W m⁻² sr⁻¹",
    );
    // An empty list is not a spectrum.
    let text = format!("{BASE}[point_sources.lamp]\nposition = [0.0, 0.0, 3.0]\nlines = []\n");
    expect_err(
        &text,
        n,
        "point_sources.lamp",
        "or `lines` (emission lines only)",
    );
    // Not for reflectances, transmissions or band responses.
    let text = BASE.replace(
        "reflectance = 0.5",
        "reflectance = { value = 0.5, lines = [[546.0, 0.1]] }",
    );
    expect_err(
        &text,
        15,
        "materials.grey.reflectance.lines",
        "a reflectance has no emission lines",
    );
    let text = BASE.replace(
        "lo_nm = 400\nhi_nm = 700",
        "response = { value = 1.0, lines = [[546.0, 0.1]] }",
    );
    expect_err(
        &text,
        11,
        "bands.vis.response.lines",
        "a response has no emission lines",
    );
}

// --- camera, bands, sky ------------------------------------------------------------

#[test]
fn camera_errors() {
    let text = BASE.replace("fov_deg = 60.0", "fov_deg = 180.0");
    expect_err(&text, 6, "camera.fov_deg", "[0.001, 180)");
    let text = BASE.replace("look_at = [0.0, 0.0, 1.0]", "look_at = [0.0, -5.0, 1.5]");
    expect_err(&text, 5, "camera.look_at", "equals the camera position");
    let text = BASE.replace("width = 64", "width = 0");
    expect_err(&text, 7, "camera.width", "at least 1");
}

#[test]
fn band_errors_and_response_bands() {
    let text = BASE.replace("hi_nm = 700", "hi_nm = 300");
    expect_err(&text, 12, "bands.vis.hi_nm", "lo_nm < hi_nm");
    let text = format!("{BASE}[bands.s20]\nresponse = \"qe-s20\"\nhi_nm = 900\n");
    let s = parse(&text).unwrap();
    let b = s.band("s20").unwrap();
    assert_eq!(b.hi_nm, 900.0);
    assert_eq!(b.response.eval(950.0), 0.0);
    assert!(b.response.eval(500.0) > 0.0);
    let r = s.band("vis").unwrap();
    assert_eq!(r.response.eval(550.0), 1.0);
    assert_eq!(r.response.eval(750.0), 0.0);
    // File order, not alphabetical.
    let text = format!("{BASE}[bands.blue]\nlo_nm = 400\nhi_nm = 500\n");
    let s = parse(&text).unwrap();
    assert_eq!(s.bands[0].name, "vis");
    assert_eq!(s.bands[1].name, "blue");
}

const SKY: &str = "[sky]\nutc = \"2024-03-14T22:30:00Z\"\nlatitude_deg = 32.2\nlongitude_deg = -110.9\nheight_m = 800\n";

#[test]
fn sky_parsing_and_errors() {
    let s = parse(&format!("{BASE}{SKY}")).unwrap();
    let sky = s.sky.unwrap();
    assert!(sky.moon && sky.night_sky && !sky.overcast);
    assert_eq!(sky.visibility_km, 23.0);
    // A native TOML datetime works too.
    let s = parse(&format!(
        "{BASE}{}",
        SKY.replace("\"2024-03-14T22:30:00Z\"", "2024-03-14T22:30:00Z")
    ))
    .unwrap();
    assert_eq!(s.sky.unwrap().utc, "2024-03-14T22:30:00Z");
    let text = format!(
        "{BASE}{}",
        SKY.replace("2024-03-14T22:30:00Z", "14/03/2024 22:30")
    );
    expect_err(&text, next_line() + 1, "sky.utc", "ISO-8601");
    // An impossible calendar date is caught at its line, not at render time.
    let text = format!(
        "{BASE}{}",
        SKY.replace("2024-03-14T22:30:00Z", "2025-02-30T22:30:00Z")
    );
    expect_err(&text, next_line() + 1, "sky.utc", "2025-02-30");
    let text = format!("{BASE}{}", SKY.replace("32.2", "95.0"));
    expect_err(&text, next_line() + 2, "sky.latitude_deg", "-90..90");
}

#[test]
fn file_order_of_materials_and_objects() {
    let text = format!(
        "{BASE}[materials.alpha]\nreflectance = 0.1\n[objects.aardvark]\nmaterial = \"alpha\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }}\n"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.materials[0].name, "grey");
    assert_eq!(s.materials[1].name, "alpha");
    assert_eq!(s.facets[0].object, "floor");
    assert_eq!(s.facets[1].object, "aardvark");
    assert_eq!(s.facets[1].material, 1);
}

#[test]
fn unreadable_file() {
    // The path, no made-up line, and the OS's reason once (as the source,
    // which `{:#}` chains).
    let e = crate::load(
        Path::new("/nonexistent/scene.toml"),
        &gloam_io::ReadLog::off(),
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "/nonexistent/scene.toml: cannot read the scene file"
    );
    let source = std::error::Error::source(&e).map(|s| s.to_string());
    assert!(
        source
            .as_deref()
            .is_some_and(|s| s.contains("No such file")),
        "{source:?}"
    );
}

// --- geometry helpers against closed forms ---------------------------------------

#[test]
fn facet_area_normal_centroid() {
    let f = |v: &[[f64; 3]]| Facet {
        vertices: v.iter().map(|&a| DVec3::from_array(a)).collect(),
        material: 0,
        object: "t".into(),
    };
    // Right triangle with legs 3 and 4 in the xy plane: area 6, normal +z.
    let t = f(&[[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]]);
    assert!((t.area() - 6.0).abs() < 1e-12);
    assert!((t.normal() - DVec3::Z).length() < 1e-15);
    assert!((t.centroid() - DVec3::new(1.0, 4.0 / 3.0, 0.0)).length() < 1e-12);
    // Reversed winding flips the normal.
    let r = f(&[[0.0, 0.0, 0.0], [0.0, 4.0, 0.0], [3.0, 0.0, 0.0]]);
    assert!((r.normal() + DVec3::Z).length() < 1e-15);
    // Tilted parallelogram: a = (2,0,0), b = (1,3,4): area |a×b| = 2·5 = 10.
    let p = f(&[
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 3.0, 4.0],
        [1.0, 3.0, 4.0],
    ]);
    assert!((p.area() - 10.0).abs() < 1e-12);
    assert!((p.normal() - DVec3::new(0.0, -0.8, 0.6)).length() < 1e-12);
    assert!((p.centroid() - DVec3::new(1.5, 1.5, 2.0)).length() < 1e-12);
    // Trapezoid (parallel sides 4 and 2, height 2): area 6; centroid height
    // h(2a+b)/(3(a+b)) above the longer side = 2·(2·2+4)/(3·6)... from the
    // side of length 4: h(a + 2b)/(3(a+b)) with a = 4, b = 2 → 2·8/18.
    let z = f(&[
        [0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
        [3.0, 2.0, 0.0],
        [1.0, 2.0, 0.0],
    ]);
    assert!((z.area() - 6.0).abs() < 1e-12);
    assert!((z.centroid() - DVec3::new(2.0, 16.0 / 18.0, 0.0)).length() < 1e-12);
    // Far from the origin the area stays exact.
    let far = f(&[
        [1e6, 1e6, 5.0],
        [1e6 + 1.0, 1e6, 5.0],
        [1e6, 1e6 + 1.0, 5.0],
    ]);
    assert!((far.area() - 0.5).abs() < 1e-9);
}

#[test]
fn quad_helper_orientation() {
    let text = format!(
        "{BASE}[objects.panel]\nmaterial = \"grey\"\nquad = {{ center = [1.0, 2.0, 3.0], size = [4.0, 2.0], normal = [0.0, 0.0, -1.0] }}\n"
    );
    let s = parse(&text).unwrap();
    let p = s.facets.iter().find(|f| f.object == "panel").unwrap();
    assert!((p.normal() - DVec3::NEG_Z).length() < 1e-15);
    assert!((p.area() - 8.0).abs() < 1e-12);
    assert!((p.centroid() - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
    // Long side along x by default.
    let xs: Vec<f64> = p.vertices.iter().map(|v| v.x).collect();
    let ys: Vec<f64> = p.vertices.iter().map(|v| v.y).collect();
    assert_eq!(xs.iter().cloned().fold(f64::MIN, f64::max), 3.0);
    assert_eq!(ys.iter().cloned().fold(f64::MIN, f64::max), 3.0);
    // A wall facing +x defaults its width along y.
    let text = format!(
        "{BASE}[objects.wall]\nmaterial = \"grey\"\nquad = {{ center = [0.0, 0.0, 1.0], size = [4.0, 2.0], normal = [1.0, 0.0, 0.0] }}\n"
    );
    let s = parse(&text).unwrap();
    let w = s.facets.iter().find(|f| f.object == "wall").unwrap();
    assert!((w.normal() - DVec3::X).length() < 1e-15);
    assert_eq!(w.vertices.iter().map(|v| v.y).fold(f64::MIN, f64::max), 2.0);
}

#[test]
fn box_helper_faces_outward_and_inward() {
    for inward in [false, true] {
        let text = format!(
            "{BASE}[objects.b]\nmaterial = \"grey\"\nbox = {{ min = [1.0, 2.0, 3.0], max = [3.0, 5.0, 7.0], inward = {inward} }}\n"
        );
        let s = parse(&text).unwrap();
        let faces: Vec<&Facet> = s.facets.iter().filter(|f| f.object == "b").collect();
        assert_eq!(faces.len(), 6);
        let centre = DVec3::new(2.0, 3.5, 5.0);
        let total: f64 = faces.iter().map(|f| f.area()).sum();
        assert!((total - 2.0 * (2.0 * 3.0 + 2.0 * 4.0 + 3.0 * 4.0)).abs() < 1e-12);
        for f in faces {
            let out = (f.centroid() - centre).dot(f.normal()) > 0.0;
            assert_eq!(out, !inward);
        }
    }
    let text = format!(
        "{BASE}[objects.b]\nmaterial = \"grey\"\nbox = {{ min = [1.0, 2.0, 3.0], max = [3.0, 5.0, 7.0], omit = [\"bottom\", \"+x\"] }}\n"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.facets.iter().filter(|f| f.object == "b").count(), 4);
    let text = text.replace("\"+x\"", "\"east\"");
    expect_err(
        &text,
        next_line() + 2,
        "objects.b.box.omit[1]",
        "unknown box face 'east'",
    );
}

#[test]
fn camera_projection_round_trip_and_frustum() {
    let s = parse(BASE).unwrap();
    let c = &s.camera;
    // The look-at point is the image centre.
    let (x, y) = c.project(c.look_at).unwrap();
    assert!((x - 32.0).abs() < 1e-9 && (y - 24.0).abs() < 1e-9);
    for (px, py) in [(0.5, 0.5), (63.5, 10.0), (20.0, 47.5)] {
        let p = c.position + 7.0 * c.pixel_direction(px, py);
        let (qx, qy) = c.project(p).unwrap();
        assert!((qx - px).abs() < 1e-9 && (qy - py).abs() < 1e-9);
    }
    // Behind the camera.
    assert!(c.project(DVec3::new(0.0, -10.0, 1.5)).is_none());
    // A polygon straddling the frustum edge, with no vertex inside, overlaps.
    let big = [
        DVec3::new(-100.0, 0.0, -1.0),
        DVec3::new(100.0, 0.0, -1.0),
        DVec3::new(100.0, 0.0, 100.0),
        DVec3::new(-100.0, 0.0, 100.0),
    ];
    assert!(big.iter().all(|&v| !c.sees_point(v)));
    assert!(c.frustum_overlaps(&big));
    // Entirely behind.
    let behind: Vec<DVec3> = big
        .iter()
        .map(|v| *v - DVec3::new(0.0, 20.0, 0.0))
        .collect();
    assert!(!c.frustum_overlaps(&behind));
}

// --- the effect plan -----------------------------------------------------------------

const OUTDOOR: &str = r#"units = "m"
sensor = "gen3-gaas-iccd"

[camera]
position = [0.0, -20.0, 1.7]
look_at = [0.0, 0.0, 3.0]
fov_deg = 40.0
width = 64
height = 48

[bands.vis]
lo_nm = 400
hi_nm = 700

[materials.ground]
reflectance = 0.1

[materials.leaf]
reflectance = 0.3
transmission = 0.4

[materials.glass]
reflectance = 0.08
specular_fraction = 0.9

[materials.unused-mirror]
reflectance = 0.9
specular_fraction = 1.0

[objects.ground]
material = "ground"
quad = { center = [0.0, 0.0, 0.0], size = [100.0, 100.0], normal = [0.0, 0.0, 1.0] }

[objects.hedge]
material = "leaf"
quad = { center = [5.0, 0.0, 1.0], size = [4.0, 2.0], normal = [0.0, -1.0, 0.0] }

[objects.window]
material = "glass"
quad = { center = [-5.0, 5.0, 1.5], size = [2.0, 1.5], normal = [0.0, -1.0, 0.0] }

[point_sources.streetlight]
position = [0.0, 0.0, 6.0]
direction = [0.0, 0.0, -1.0]
shape_exponent = 3
spectrum = "hps"
normalize = { lo_nm = 400, hi_nm = 700, value = 50.0 }

[point_sources.porch]
position = [-5.0, 5.0, 2.5]
value = 0.01

[sky]
utc = "2024-03-14T04:30:00Z"
latitude_deg = 32.2
longitude_deg = -110.9
night_sky = false
"#;

#[test]
fn plan_outdoor_scene() {
    let s = parse(OUTDOOR).unwrap();
    let p = plan(&s);
    let names: Vec<&str> = p.effects.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(
        names,
        [
            names::AREA_SOURCES,
            names::SHAPED_POINT_SOURCES,
            names::POINT_SOURCES,
            names::DISTANT_SOURCES,
            names::TRANSMISSIVE_OCCLUDERS,
            names::SPECULAR_RECURSION,
            names::INTERREFLECTION,
            names::DIRECT_VIEW,
            names::MOON,
            names::NIGHT_SKY,
            names::SUN,
            names::TWILIGHT_SKY,
            names::ATMOSPHERE,
            names::SENSOR,
        ]
    );
    assert!(!p.is_enabled("area-sources"));
    assert_eq!(p.get("area-sources").unwrap().reason, "no emitting facets");
    assert!(p.is_enabled("shaped-point-sources"));
    assert!(
        p.get("shaped-point-sources")
            .unwrap()
            .reason
            .contains("streetlight m = 3")
    );
    assert!(p.is_enabled("point-sources"));
    assert!(p.get("point-sources").unwrap().reason.contains("porch"));
    assert!(p.is_enabled("transmissive-occluders"));
    assert!(
        p.get("transmissive-occluders")
            .unwrap()
            .reason
            .contains("leaf")
    );
    assert!(p.is_enabled("specular-recursion"));
    let spec = &p.get("specular-recursion").unwrap().reason;
    assert!(
        spec.contains("glass 0.9") && !spec.contains("unused-mirror"),
        "{spec}"
    );
    // The porch light (isotropic) is in view; the streetlight points down,
    // away from the camera at 1.7 m... the camera is below it, so it is seen too.
    let dv = &p.get("direct-view").unwrap().reason;
    assert!(p.is_enabled("direct-view"));
    assert!(dv.contains("porch"), "{dv}");
    assert!(p.is_enabled("moon"));
    assert!(!p.is_enabled("night-sky"));
    assert!(p.is_enabled("atmosphere"));
    assert!(p.get("atmosphere").unwrap().reason.contains("23 km"));
    assert!(p.is_enabled("sensor"));
    assert!(p.get("sensor").unwrap().reason.contains("gen3-gaas-iccd"));
    assert!(!p.is_enabled("no-such-effect"));
}

#[test]
fn plan_direct_view_respects_facing_and_frustum() {
    // A down-facing panel seen from below is in view; seen from above it is not.
    let panel = "[materials.lamp]\nemission = { value = 1.0 }\n[objects.panel]\nmaterial = \"lamp\"\nquad = { center = [0.0, 0.0, 2.0], size = [1.0, 1.0], normal = [0.0, 0.0, -1.0] }\n";
    let s = parse(&format!("{BASE}{panel}")).unwrap();
    assert!(plan(&s).is_enabled("direct-view"));
    let above = BASE.replace("position = [0.0, -5.0, 1.5]", "position = [0.0, -5.0, 6.0]");
    let s = parse(&format!("{above}{panel}")).unwrap();
    let p = plan(&s);
    assert!(p.is_enabled("area-sources"));
    assert!(!p.is_enabled("direct-view"), "{}", p);
    // Behind the camera.
    let behind = panel.replace("center = [0.0, 0.0, 2.0]", "center = [0.0, -10.0, 2.0]");
    let s = parse(&format!("{BASE}{behind}")).unwrap();
    assert!(!plan(&s).is_enabled("direct-view"));
    // A shaped point source pointing away from the camera is not seen directly.
    let away = "[point_sources.spot]\nposition = [0.0, 0.0, 1.0]\ndirection = [0.0, 1.0, 0.0]\nshape_exponent = 2\nvalue = 1.0\n";
    let s = parse(&format!("{BASE}{away}")).unwrap();
    assert!(!plan(&s).is_enabled("direct-view"));
    let toward = away.replace(
        "direction = [0.0, 1.0, 0.0]",
        "direction = [0.0, -1.0, 0.0]",
    );
    let s = parse(&format!("{BASE}{toward}")).unwrap();
    assert!(plan(&s).is_enabled("direct-view"));
}

#[test]
fn plan_is_extensible() {
    let s = parse(BASE).unwrap();
    let p = plan_with(
        &s,
        [
            Effect::new("sensor", true, "ICCD preset"),
            Effect::new("mcp-gain", true, "ICCD has an MCP"),
        ],
    );
    assert_eq!(p.effects.len(), 15);
    assert_eq!(p.effects[13].name, "sensor");
    assert_eq!(p.effects[13].reason, "ICCD preset");
    assert_eq!(p.effects[14].name, "mcp-gain");
    assert_eq!(p.enabled(), ["sensor", "mcp-gain"]);
    let table = p.to_string();
    assert!(
        table
            .lines()
            .any(|l| l.starts_with("mcp-gain") && l.contains("yes"))
    );
}

#[test]
fn documented_example_parses_and_enables_every_effect() {
    let doc = include_str!("../../../docs/scene-format.md");
    let start = doc.find("## A complete example").unwrap();
    let body = &doc[start..];
    let open = body.find("```toml\n").unwrap() + "```toml\n".len();
    let close = body[open..].find("```").unwrap();
    let text = &body[open..open + close];
    let s = parse(text).unwrap_or_else(|e| panic!("{e}"));
    // The example names a real camera preset (`gloam sensor list`; the
    // scene crate does not read sensors, so the names are listed here).
    let presets = [
        "gen2-s20-iccd",
        "gen3-gaas-iccd",
        "s25-ebccd",
        "scientific-ccd",
    ];
    assert!(
        presets
            .iter()
            .any(|p| text.contains(&format!("sensor = \"{p}\""))),
        "the complete example's sensor is not a preset"
    );
    let p = plan(&s);
    // Every effect but distant sources (parallel light has no place on
    // a night street; its own section shows one) and the Sun's two (the
    // example is set at night).
    let night_only = [names::DISTANT_SOURCES, names::SUN, names::TWILIGHT_SKY];
    for e in p
        .effects
        .iter()
        .filter(|e| !night_only.contains(&e.name.as_str()))
    {
        assert!(e.enabled, "{}: {}", e.name, e.reason);
    }
    assert!(p.get("area-sources").unwrap().reason.contains("sign m = 1"));
    let dv = &p.get("direct-view").unwrap().reason;
    assert!(
        dv.contains("sign") && dv.contains("streetlight") && dv.contains("porch"),
        "{dv}"
    );
}

/// The fenced block of `lang` that follows `heading` in `doc`.
fn doc_block<'a>(doc: &'a str, heading: &str, lang: &str) -> &'a str {
    let body = &doc[doc.find(heading).expect("heading")..];
    let fence = format!("```{lang}\n");
    let open = body.find(&fence).expect("block") + fence.len();
    let close = body[open..].find("```").expect("closing fence");
    &body[open..open + close]
}

#[test]
fn documented_emission_lines_parse_and_hold_the_stated_power() {
    let doc = include_str!("../../../docs/scene-format.md");
    let heading = "### Emission lines";
    let toml = doc_block(doc, heading, "toml");
    let csv = doc_block(doc, heading, "csv");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("yard-lamp.csv"), csv).unwrap();
    let s = parse_str(&format!("{BASE}{toml}"), &scene_path(dir.path()))
        .unwrap_or_else(|e| panic!("{e}"));
    let lamp = &s.point_sources[0].intensity_w_sr_nm;
    let lines: f64 = lamp.lines().iter().map(|l| l.value).sum();
    assert!((lamp.integrate_band(400.0, 700.0) - 6.37).abs() < 1e-12);
    assert!((lines - 0.37).abs() < 1e-12);
    let (_, m) = s.material_by_name("sox_panel").unwrap();
    let l = &m.emission.as_ref().unwrap().radiance_w_m2_sr_nm;
    assert_eq!(l.integral(), 1.5);
    assert_eq!(l.integrate_band(589.0, 590.0), 0.5);

    // The documented error is what the scene reader says.
    let section = &doc[doc.find(heading).unwrap()..];
    let quoted = section
        .split('`')
        .find(|q| q.starts_with("scene.toml:"))
        .expect("a documented error");
    let (_, field_and_message) = quoted.split_once(": ").unwrap();
    let bad = toml.replace("[546.07, 0.12]", "[546.07, -0.12]");
    let e = parse_str(&format!("{BASE}{bad}"), &scene_path(dir.path())).unwrap_err();
    assert_eq!(
        format!("{}: {}", e.field(), message_of(&e)),
        field_and_message
    );
}

fn message_of(e: &SceneError) -> &str {
    match e {
        SceneError::Invalid { message, .. } => message,
        SceneError::Io { .. } => "",
    }
}

// --- instancing ----------------------------------------------------------------

/// An inline triangle object `t` with vertices (0,0,0), (1,0,0), (1,2,0)
/// (area 1) and the given extra keys.
fn triangle_object(extra: &str) -> String {
    format!(
        "{BASE}[objects.t]\nmaterial = \"grey\"\nvertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]\nfaces = [[0, 1, 2]]\n{extra}"
    )
}

#[test]
fn instanced_facet_count_is_prototype_facets_times_placements() {
    // A box without its bottom: 5 facets, placed 3 times inline.
    let text = format!(
        "{BASE}[objects.crate]\nmaterial = \"grey\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0], omit = [\"bottom\"] }}\ninstances = [\n  {{ translate = [2.0, 0.0, 0.0] }},\n  {{ translate = [4.0, 0.0, 0.0], rotate_z_deg = 45.0 }},\n  {{ translate = [6.0, 0.0, 0.0], scale = 0.5 }},\n]\n"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.facets.len(), 1 + 5 * 3);
    let c = s.counts();
    assert_eq!(
        (
            c.objects,
            c.instanced_objects,
            c.instances,
            c.prototype_facets,
            c.facets
        ),
        (2, 1, 1 + 3, 1 + 5, 16)
    );
    let o = &s.objects[1];
    assert_eq!(
        (o.name.as_str(), o.prototype_facets, o.instances),
        ("crate", 5, 3)
    );
    assert_eq!(o.facets(), 1..16);
    assert_eq!(o.instance_facets(2), 11..16);
    assert!(s.facets[1..].iter().all(|f| f.object == "crate"));
    // Provenance by facet index, independent of the stored ranges' use.
    assert_eq!(
        s.facet_origin(0),
        Some(crate::FacetOrigin {
            object: 0,
            instance: 0,
            prototype_facet: 0
        })
    );
    assert_eq!(
        s.facet_origin(1 + 5 + 3),
        Some(crate::FacetOrigin {
            object: 1,
            instance: 1,
            prototype_facet: 3
        })
    );
    assert_eq!(s.facet_origin(16), None);

    // 1 000 placements from a CSV file: 5 000 facets.
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("x,y,z,rotate_z_deg,scale\n");
    for i in 0..1000 {
        csv.push_str(&format!(
            "{},{},0,{},1\n",
            2 * (i % 40),
            2 * (i / 40),
            i % 360
        ));
    }
    std::fs::write(dir.path().join("crates.csv"), csv).unwrap();
    let text = format!(
        "{BASE}[objects.crate]\nmaterial = \"grey\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0], omit = [\"bottom\"] }}\ninstances_csv = \"crates.csv\"\n"
    );
    let s = parse_str(&text, &scene_path(dir.path())).unwrap();
    assert_eq!(s.facets.len(), 1 + 5 * 1000);
    assert_eq!(s.counts().instances, 1 + 1000);
}

#[test]
fn instance_vertices_are_the_transformed_prototype() {
    // Scale 2, then 90° counter-clockwise about +z: (x, y, z) ↦ (−2y, 2x, 2z),
    // then translate (10, 20, 30). Multiples of 90° are exact.
    let text = triangle_object(
        "instances = [{ translate = [10.0, 20.0, 30.0], rotate_z_deg = 90.0, scale = 2.0 }]\n",
    );
    let s = parse(&text).unwrap();
    let v = &s.facets[1].vertices;
    assert_eq!(v[0], DVec3::new(10.0, 20.0, 30.0));
    assert_eq!(v[1], DVec3::new(10.0, 22.0, 30.0));
    assert_eq!(v[2], DVec3::new(6.0, 22.0, 30.0));
    // The front side still faces +z (a rotation about z keeps it).
    assert_eq!(s.facets[1].normal(), DVec3::Z);

    // An arbitrary angle: (1, 0, 0) ↦ (cos 30°, sin 30°, 0); the object's
    // own transform (translate x by 1, then) applies before the placement's.
    let text = triangle_object(
        "translate = [1.0, 0.0, 0.0]\ninstances = [{ rotate_z_deg = 30.0 }, { rotate_z_deg = -90.0, translate = [0.0, 0.0, 5.0] }]\n",
    );
    let s = parse(&text).unwrap();
    let (c, h) = (3f64.sqrt() / 2.0, 0.5);
    let a = &s.facets[1].vertices;
    assert!((a[0] - DVec3::new(c, h, 0.0)).length() < 1e-15, "{}", a[0]);
    assert!((a[1] - DVec3::new(2.0 * c, 2.0 * h, 0.0)).length() < 1e-15);
    // (2, 2, 0) rotated by 30°: (2c − 2h, 2h + 2c, 0).
    assert!((a[2] - DVec3::new(2.0 * c - 1.0, 1.0 + 2.0 * c, 0.0)).length() < 1e-14);
    // −90°: (x, y, z) ↦ (y, −x, z), exactly.
    let b = &s.facets[2].vertices;
    assert_eq!(b[0], DVec3::new(0.0, -1.0, 5.0));
    assert_eq!(b[2], DVec3::new(2.0, -2.0, 5.0));

    // An object-level rotation is the same transform as a single placement.
    let own = parse(&triangle_object(
        "scale = 2.0\nrotate_z_deg = 90.0\ntranslate = [10.0, 20.0, 30.0]\n",
    ))
    .unwrap();
    assert_eq!(own.facets[1].vertices, s_first(&parse(&triangle_object(
        "instances = [{ translate = [10.0, 20.0, 30.0], rotate_z_deg = 90.0, scale = 2.0 }]\n",
    ))
    .unwrap()));
    assert!(!own.objects[1].instanced);
}

fn s_first(s: &crate::Scene) -> Vec<DVec3> {
    s.facets[1].vertices.clone()
}

#[test]
fn instance_area_scales_as_scale_squared() {
    let text = triangle_object(
        "instances = [{ scale = 1.0 }, { scale = 3.0, rotate_z_deg = 17.0 }, { scale = 0.25 }, { scale = [2.0, 5.0, 7.0] }]\n",
    );
    let s = parse(&text).unwrap();
    let areas: Vec<f64> = s.facets[1..].iter().map(Facet::area).collect();
    // The prototype's area is 1 (base 1, height 2); a per-axis scale of a
    // facet in the xy-plane multiplies it by sx·sy.
    for (a, want) in areas.iter().zip([1.0, 9.0, 0.0625, 10.0]) {
        assert!((a - want).abs() < 1e-12 * want, "{a} vs {want}");
    }
}

/// Bad inline placements: the object's extra line, the field under
/// `objects.t` and a part of the message. Finite but past ±1e6°, an angle
/// would keep no bit of its turn.
const BAD_PLACEMENTS: [(&str, &str, &str); 7] = [
    (
        "instances = [{ scale = 1.0 }, { scale = -2.0 }]\n",
        "instances[1].scale",
        "must be finite and > 0",
    ),
    (
        "instances = [{ rotate = 90.0 }]\n",
        "instances[0].rotate",
        "unknown field `rotate`",
    ),
    ("instances = []\n", "instances", "no placements"),
    (
        "instances = [{ translate = [1.0, 2.0] }]\n",
        "instances[0].translate",
        "3 numbers",
    ),
    (
        "instances = [{ rotate_z_deg = nan }]\n",
        "instances[0].rotate_z_deg",
        "not a finite number",
    ),
    (
        "instances = [{ rotate_z_deg = 1e300 }]\n",
        "instances[0].rotate_z_deg",
        "1e300 degrees is past the limit of ±1e6",
    ),
    (
        "rotate_z_deg = -1000001.0\n",
        "rotate_z_deg",
        "-1000001 degrees is past the limit of ±1e6",
    ),
];

#[test]
fn placement_errors_name_file_line_and_field() {
    // Inline: the entry and its key.
    let l = next_line() + 4;
    for (object, field, part) in BAD_PLACEMENTS {
        expect_err(
            &triangle_object(object),
            l,
            &format!("objects.t.{field}"),
            part,
        );
    }
    // The limit itself is a rotation (2 777 turns and 280°): the base's
    // floor and the triangle.
    let s = parse(&triangle_object("rotate_z_deg = 1e6\n")).unwrap();
    assert_eq!(s.facets.len(), 2);

    // CSV: the scene line of `instances_csv`, and the file and its line.
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    let csv_err = |csv: &str, needle: &str| {
        std::fs::write(dir.path().join("p.csv"), csv).unwrap();
        expect_err_at(
            &triangle_object("instances_csv = \"p.csv\"\n"),
            &path,
            l,
            "objects.t.instances_csv",
            needle,
        )
    };
    let m = csv_err(
        "x,y,z,rotate_z_deg,scale\n# a comment\n1,2,3,0,1\n4,5,6,0,-1\n",
        "p.csv:4: scale = -1 must be finite and > 0",
    );
    assert!(m.contains("placements file"), "{m}");
    csv_err("1,2,3,0,1\n1,2,3,0\n", "p.csv:2: expected 5 columns");
    csv_err("1,2,3,0,1\n1,2,x,0,1\n", "p.csv:2: expected five numbers");
    csv_err(
        "x,y,z,scale,rotate_z_deg\n1,2,3,0,1\n",
        "p.csv:1: expected five numbers",
    );
    csv_err(
        "\n1,2,inf,0,1\n",
        "p.csv:2: z = inf must be a finite number",
    );
    csv_err("x,y,z,rotate_z_deg,scale\n", "no placements");
    csv_err("1,2,3,1e400,1\n", "p.csv:1: rotate_z_deg = inf");
    csv_err(
        "1,2,3,0,1\n1,2,3,-1e300,1\n",
        "p.csv:2: rotate_z_deg = -1e300 must be a finite number with |rotate_z_deg| ≤ 1e6 degrees",
    );
    // Spaces or tabs separate columns too; a header is optional.
    std::fs::write(dir.path().join("p.csv"), "1 2 3 0 1\n4\t5\t6\t90\t2\n").unwrap();
    let s = parse_str(&triangle_object("instances_csv = \"p.csv\"\n"), &path).unwrap();
    assert_eq!(s.facets.len(), 3);
    assert_eq!(s.facets[2].vertices[1], DVec3::new(4.0, 7.0, 6.0));

    // A placement the facets cannot take (a per-axis scale flattening a
    // facet is checked like any facet) names the placement.
    expect_err(
        &triangle_object("instances = [{ scale = 1.0 }, { scale = [1.0, 1e-300, 1.0] }]\n"),
        l,
        "objects.t.instances[1]",
        "facet 0 of the prototype",
    );
    std::fs::write(dir.path().join("p.csv"), "0,0,0,0,1\n0,0,0,0,1e300\n").unwrap();
    // The object's own scale 1e10, then 1e300: beyond f64.
    expect_err_at(
        &triangle_object("scale = 1e10\ninstances_csv = \"p.csv\"\n"),
        &path,
        l + 1,
        "objects.t.instances_csv",
        "placement on line 2 of the placements file: facet 0 of the prototype: a vertex is not finite",
    );
}

#[test]
fn missing_or_unreadable_placements_and_objects() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    let l = next_line() + 4;
    expect_err_at(
        &triangle_object("instances_csv = \"missing.csv\"\n"),
        &path,
        l,
        "objects.t.instances_csv",
        "missing.csv: cannot read",
    );
    expect_err_at(
        &triangle_object("instances_csv = \"/dev/zero\"\n"),
        &path,
        l,
        "objects.t.instances_csv",
        "not a regular file",
    );
    // A FIFO is refused without being opened (opening one would wait for
    // a writer forever).
    let fifo = dir.path().join("f.csv");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        expect_err_at(
            &triangle_object("instances_csv = \"f.csv\"\n"),
            &path,
            l,
            "objects.t.instances_csv",
            "not a regular file",
        );
    }
    std::fs::create_dir(dir.path().join("d.csv")).unwrap();
    expect_err_at(
        &triangle_object("instances_csv = \"d.csv\"\n"),
        &path,
        l,
        "objects.t.instances_csv",
        "is a directory",
    );
    std::fs::write(dir.path().join("p.csv"), "0,0,0,0,1\n").unwrap();
    expect_err_at(
        &triangle_object("instances = [{}]\ninstances_csv = \"p.csv\"\n"),
        &path,
        l + 1,
        "objects.t.instances_csv",
        "not both",
    );
    // An instanced object whose OBJ file is missing, or that has no
    // geometry at all.
    let text = format!(
        "{BASE}[objects.lamp]\nmaterial = \"grey\"\nobj = \"lamp.obj\"\ninstances = [{{}}]\n"
    );
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.lamp.obj",
        "cannot read OBJ file",
    );
    let text = format!("{BASE}[objects.lamp]\nmaterial = \"grey\"\ninstances = [{{}}]\n");
    expect_err(&text, next_line(), "objects.lamp", "no geometry");
}

#[test]
fn over_limit_instance_counts_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_path(dir.path());
    // 100 faces × 200 001 placements = 20 000 100 facets > MAX_FACETS. The
    // OBJ's faces point at vertices it does not have: the count is refused
    // from the face lines alone, before the file is parsed.
    assert_eq!(crate::MAX_FACETS, 20_000_000);
    std::fs::write(dir.path().join("m.obj"), "f 1 2 3\n".repeat(100)).unwrap();
    std::fs::write(dir.path().join("p.csv"), "0,0,0,0,1\n".repeat(200_001)).unwrap();
    let text = format!(
        "{BASE}[objects.m]\nmaterial = \"grey\"\nobj = \"m.obj\"\ninstances_csv = \"p.csv\"\ninstancing = \"expand\"\n"
    );
    let m = expect_err_at(
        &text,
        &path,
        next_line() + 3,
        "objects.m.instances_csv",
        "200001 placements × 100 facets: 20000100 facets here plus 1 before it would exceed the limit of 20000000 facets",
    );
    assert!(!m.contains("out of bounds"), "{m}");
    // Fewer placements fit, and the file is read: the bad indices are
    // found, with their line.
    std::fs::write(dir.path().join("p.csv"), "0,0,0,0,1\n".repeat(1000)).unwrap();
    expect_err_at(
        &text,
        &path,
        next_line() + 2,
        "objects.m.obj",
        "m.obj:1: the face's vertex index 1 refers past the 0 vertices",
    );
}

#[test]
fn placements_csv_refuses_an_empty_column_by_number() {
    let parse = |t: &str| {
        crate::instance::parse_placements_csv(t, Path::new("p.csv"), 1e12, 10)
            .map(|v| v.len())
            .map_err(|e| e.to_string())
    };
    for (text, want) in [
        ("0,0,0,0,1\n1,0,0,0,1,\n", "p.csv:2: column 6 is empty"),
        ("1,,0,0,1\n", "p.csv:1: column 2 is empty"),
        (",1,0,0,0,1\n", "p.csv:1: column 1 is empty"),
        ("1 ; ;0 0 1\n", "p.csv:1: column 2 is empty"),
    ] {
        let e = parse(text).unwrap_err();
        assert!(e.starts_with(want), "{e}\n  should start: {want}");
    }
    assert!(parse("1,,0,0,1\n").unwrap_err().ends_with("found 5"));
    assert!(parse("1,0,0,0,1,\n").unwrap_err().ends_with("found 6"));
    // Spaces and tabs around or between columns are not empty columns.
    assert_eq!(parse("1, 0 ,0,\t0,1\n2 0  0\t0 1\n"), Ok(2));
}

#[test]
fn size_budget_counts_items_and_memory() {
    use crate::instance::check_budget;
    assert!(check_budget(0, 10, 10, 100, Some(1000), "facets").is_ok());
    let e = check_budget(5, 6, 10, 1, None, "facets")
        .unwrap_err()
        .to_string();
    assert!(e.contains("6 facets here plus 5 before it"), "{e}");
    let e = check_budget(0, 11, 100, 100, Some(1000), "facets")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("more than the") && e.contains("memory available"),
        "{e}"
    );
    // Placements past the limit are refused at the first row over.
    let e = crate::instance::parse_placements_csv(
        "# three\n0,0,0,0,1\n1,0,0,0,1\n2,0,0,0,1\n",
        Path::new("p.csv"),
        1e12,
        2,
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "p.csv:4: more than 2 placements (the limit per object or point source)"
    );
    // The documented estimate.
    assert_eq!(crate::instance::facet_bytes("street_lamp"), 256);
    // No overflow however large the product.
    assert!(check_budget(usize::MAX, u128::MAX / 2, usize::MAX, usize::MAX, None, "x").is_err());
}

#[test]
fn point_sources_can_be_instanced() {
    let text = format!(
        "{BASE}[point_sources.lamp]\nposition = [1.0, 0.0, 6.0]\ndirection = [1.0, 0.0, -1.0]\nshape_exponent = 2\nvalue = 0.5\ninstances = [{{ translate = [0.0, 0.0, 0.0] }}, {{ translate = [10.0, 0.0, 0.0], rotate_z_deg = 90.0 }}, {{ translate = [0.0, 5.0, 0.0], scale = 2.0 }}]\n\n[point_sources.porch]\nposition = [0.0, 0.0, 3.0]\nvalue = 0.1\n"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.point_sources.len(), 4);
    let p = &s.point_sources;
    let r = std::f64::consts::FRAC_1_SQRT_2;
    assert_eq!(p[0].position, DVec3::new(1.0, 0.0, 6.0));
    assert_eq!(p[1].position, DVec3::new(10.0, 1.0, 6.0));
    assert!((p[1].direction - DVec3::new(0.0, r, -r)).length() < 1e-15);
    assert_eq!(p[2].position, DVec3::new(2.0, 5.0, 12.0));
    assert!((p[2].direction - DVec3::new(r, 0.0, -r)).length() < 1e-15);
    // The intensity is the prototype's: placing a lamp does not change it.
    assert!(p[..3].iter().all(|q| q.name == "lamp"
        && q.intensity_w_sr_nm.integral() == p[0].intensity_w_sr_nm.integral()
        && q.shape_exponent == 2.0));
    assert_eq!(s.point_source_origin(2), Some((0, 2)));
    assert_eq!(s.point_source_origin(3), Some((1, 0)));
    assert_eq!(s.point_source_origin(4), None);
    let c = s.counts();
    assert_eq!((c.point_source_prototypes, c.point_sources), (2, 4));
    // The plan lists a placed lamp once, with its count.
    let pl = plan(&s);
    let shaped = &pl.get("shaped-point-sources").unwrap().reason;
    assert!(
        shaped.starts_with("3 point sources with m > 0 (lamp ×3 m = 2)"),
        "{shaped}"
    );
}

#[test]
fn documented_instances_parse_and_place_what_they_say() {
    let doc = include_str!("../../../docs/scene-format.md");
    let heading = "### Instances";
    let toml = doc_block(doc, heading, "toml");
    let csv = doc_block(doc, heading, "csv");
    let dir = tempfile::tempdir().unwrap();
    // A 2-facet car model in cm.
    std::fs::write(
        dir.path().join("car.obj"),
        "v 0 0 0\nv 400 0 0\nv 400 180 0\nv 0 180 0\nv 0 0 150\nf 1 2 3 4\nf 1 2 5\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("cars.csv"), csv).unwrap();
    let materials =
        "[materials.wall]\nreflectance = 0.5\n\n[materials.paint]\nreflectance = 0.3\n\n";
    let text = format!("{BASE}{materials}{toml}");
    let s = parse_str(&text, &scene_path(dir.path())).unwrap_or_else(|e| panic!("{e}"));
    let c = s.counts();
    assert_eq!((c.instanced_objects, c.instances), (2, 1 + 3 + 3));
    assert_eq!(s.facets.len(), 1 + 5 * 3 + 2 * 3);
    // The third car: (4, 1.8, 0) m after the model's scale 0.01, scaled 1.1,
    // turned 270° ((x, y) ↦ (y, −x)) and moved to (30, −3.5, 0).
    let car = &s.objects[2];
    let third = &s.facets[car.instance_facets(2)][0];
    assert!((third.vertices[2] - DVec3::new(30.0 + 1.98, -3.5 - 4.4, 0.0)).length() < 1e-12);

    // The documented errors are what the reader says.
    let section = &doc[doc.find(heading).unwrap()..doc.find("## Point sources").unwrap()];
    let quoted: Vec<&str> = section
        .split('`')
        .filter(|q| q.starts_with("scene.toml:"))
        .collect();
    assert_eq!(quoted.len(), 2);
    std::fs::write(
        dir.path().join("cars.csv"),
        csv.replace("30.0,-3.5,0.0,270,1.1", "30.0,-3.5,0.0,270,-1"),
    )
    .unwrap();
    let e = parse_str(&text, &scene_path(dir.path())).unwrap_err();
    let (_, doc_msg) = quoted[1].split_once(": ").unwrap();
    let (field, rest) = doc_msg.split_once(": placements file cars.csv").unwrap();
    assert_eq!(e.field(), field);
    assert!(
        message_of(&e).ends_with(&format!("cars.csv{rest}")),
        "{e}\nvs\n{doc_msg}"
    );
    let (_, doc_msg) = quoted[0].split_once(": ").unwrap();
    let (field, msg) = doc_msg.split_once(": ").unwrap();
    assert_eq!(field, "objects.tree.instances_csv");
    assert!(msg.contains("200001 placements × 100 facets: 20000100 facets here plus 1 before it would exceed the limit of 20000000 facets per scene"));
}

#[test]
fn documented_lamp_model_places_housing_and_source_together() {
    let doc = include_str!("../../../docs/scene-format.md");
    let section = &doc[doc.find("## Point sources").unwrap()..];
    let open = section.find("```toml\n[objects.street_lamp]").unwrap() + "```toml\n".len();
    let close = section[open..].find("```").unwrap();
    let toml = &section[open..open + close];
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("street-lamp.obj"),
        "v -0.2 -0.2 5.9\nv 0.2 -0.2 5.9\nv 0.2 0.2 5.9\nv -0.2 0.2 5.9\nf 4 3 2 1\n",
    )
    .unwrap();
    let mut csv = String::new();
    for i in 0..1000 {
        csv.push_str(&format!("{},0,0,{},1\n", 30 * i, 180 * (i % 2)));
    }
    std::fs::write(dir.path().join("lamps.csv"), csv).unwrap();
    let mat = "[materials.sodium_globe]\nemission = { spectrum = \"hps\", normalize = { lo_nm = 400, hi_nm = 700, value = 10.0 } }\n\n";
    let s = parse_str(&format!("{BASE}{mat}{toml}"), &scene_path(dir.path()))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.point_sources.len(), 1000);
    assert_eq!(s.emitting_facets().len(), 1000);
    // Lamp k sits 6 m above its placement, its globe around it, and the
    // turned ones (180°) aim the other way along x.
    for k in [0, 1, 999] {
        let p = &s.point_sources[k];
        let globe = s.facets[s.objects[1].instance_facets(k)][0].centroid();
        assert!((p.position - DVec3::new(30.0 * k as f64, 0.0, 6.0)).length() < 1e-12);
        // (OBJ coordinates are single precision.)
        assert!((globe - (p.position - DVec3::new(0.0, 0.0, 0.1))).length() < 1e-6);
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        assert!((p.direction - DVec3::new(0.3 * sign, 0.0, -1.0).normalize()).length() < 1e-12);
    }
    let pl = plan(&s);
    let r = &pl.get("shaped-point-sources").unwrap().reason;
    assert!(r.contains("street_lamp ×1000 m = 3"), "{r}");
}

// --- coincident facets (issue 46: a stack made every ray test all of it) -------

#[test]
fn coincident_facets_are_refused_naming_both() {
    // Two objects on the same triangle, the second's vertices in another
    // order (its other side out): refused at the second, naming the first.
    let tri = |name: &str, v: &str| {
        format!("[objects.{name}]\nmaterial = \"grey\"\nvertices = {v}\nfaces = [[0, 1, 2]]\n")
    };
    let text = format!(
        "{BASE}{}{}",
        tri("a", "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]"),
        tri("b", "[[0.0, 1.0, 1.0], [1.0, -0.0, 1.0], [0.0, 0.0, 1.0]]")
    );
    let m = expect_err(&text, next_line() + 4, "objects.b", "lies exactly on");
    assert!(
        m.contains("objects.b facet 0 lies exactly on objects.a facet 0 (the same 3 vertices)"),
        "{m}"
    );
    // One part in 1e15 apart is another facet (accepted, not a stack).
    let apart = format!(
        "{BASE}{}{}",
        tri("a", "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]"),
        tri(
            "b",
            "[[0.0, 0.0, 1.000000000000001], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]"
        )
    );
    assert_eq!(parse(&apart).unwrap().facets.len(), 3);
    // Two placements of an instanced object at the same place.
    let text = triangle_object(
        "instances = [{ translate = [0, 0, 1] }, { translate = [0, 0, 2] }, { translate = [0, 0, 1] }]\n",
    );
    let m = expect_err(&text, next_line(), "objects.t", "facet 0 of placement 2");
    assert!(
        m.contains("lies exactly on objects.t facet 0 of placement 0"),
        "{m}"
    );
    // A quad repeated inside one object's faces.
    let text = inline_object(
        "[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]]",
        "[[0, 1, 2, 3], [2, 3, 0, 1]]",
    );
    let m = expect_err(
        &text,
        next_line(),
        "objects.thing",
        "objects.thing facet 1 lies exactly on objects.thing facet 0",
    );
    assert!(m.contains("same 4 vertices"), "{m}");
}

#[test]
fn a_stack_of_ten_thousand_coincident_triangles_is_refused_at_its_first_repeat() {
    // 10 000 one-triangle objects on one spot (issue 46: 82 s in the cache)
    // and one apart: the error names the first repeat, t1 on t0.
    let mut text = BASE.to_string();
    for i in 0..10_000 {
        text.push_str(&format!(
            "[objects.t{i:05}]\nmaterial = \"grey\"\nvertices = [[0, 0, 3], [0.2, 0, 3], [0, 0.2, 3]]\nfaces = [[0, 1, 2]]\n"
        ));
    }
    let m = expect_err(&text, next_line() + 4, "objects.t00001", "lies exactly on");
    assert!(
        m.contains("objects.t00001 facet 0 lies exactly on objects.t00000 facet 0"),
        "{m}"
    );
    // The same count spread out is accepted: 10 001 facets.
    let mut text = BASE.to_string();
    for i in 0..10_000 {
        let (x, y) = ((i % 100) as f64 * 0.3 - 15.0, (i / 100) as f64 * 0.3 - 15.0);
        text.push_str(&format!(
            "[objects.t{i:05}]\nmaterial = \"grey\"\nvertices = [[{x}, {y}, 3], [{}, {y}, 3], [{x}, {}, 3]]\nfaces = [[0, 1, 2]]\n",
            x + 0.2,
            y + 0.2
        ));
    }
    assert_eq!(parse(&text).unwrap().facets.len(), 10_001);
}

#[test]
fn shared_placements_map_the_prototype_onto_the_expanded_copies() {
    let text = |how: &str| {
        triangle_object(&format!(
            "translate = [0.5, 0.0, 0.0]\ninstancing = \"{how}\"\ninstances = [{{ translate = [10.0, 20.0, 30.0], rotate_z_deg = 90.0, scale = 2.0 }}, {{ scale = [2.0, 5.0, 7.0], rotate_z_deg = 33.0 }}]\n"
        ))
    };
    let copies = parse(&text("expand")).unwrap();
    let shared = parse(&text("shared")).unwrap();
    assert_eq!(shared.facets.len(), 1, "only the floor is a flat facet");
    let sh = &shared.shared[0];
    assert_eq!(
        (sh.object, sh.prototype.len(), sh.placements.len()),
        (1, 1, 2)
    );
    for (k, a) in sh.placements.iter().enumerate() {
        let want = &copies.facets[copies.objects[1].instance_facets(k)][0].vertices;
        for (v, w) in sh.prototype[0].vertices.iter().zip(want) {
            let got = a.transform_point3(*v);
            assert!(
                (got - *w).length() < 1e-12 * (1.0 + w.length()),
                "{got} vs {w}"
            );
        }
    }
    // The facet list's bookkeeping skips the shared object.
    let o = &shared.objects[1];
    assert!(o.shared && o.facets().is_empty() && o.instance_facets(1).is_empty());
    assert_eq!(shared.facet_origin(0).map(|f| f.object), Some(0));
    assert_eq!(shared.facet_origin(1), None);
    assert_eq!(shared.counts().shared_facets, 2);
}

#[test]
fn auto_instancing_shares_only_above_the_threshold() {
    // A box of 6 facets: 200 000 placements (1.2 M facets) are shared,
    // 100 000 (0.6 M) copied; an emitter is always copied.
    let dir = tempfile::tempdir().unwrap();
    for (n, shared) in [(200_000usize, true), (100_000, false)] {
        let mut csv = String::from("x,y,z,rotate_z_deg,scale\n");
        for k in 0..n {
            csv.push_str(&format!("{},{},0,0,1\n", (k % 1000) * 2, (k / 1000) * 2));
        }
        std::fs::write(dir.path().join("p.csv"), csv).unwrap();
        let text = format!(
            "{BASE}[objects.crate]\nmaterial = \"grey\"\nbox = {{ min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }}\ninstances_csv = \"p.csv\"\n"
        );
        let s = parse_str(&text, &scene_path(dir.path())).unwrap();
        assert_eq!(s.objects[1].shared, shared, "{n} placements");
        assert_eq!(s.facets.len(), 1 + if shared { 0 } else { 6 * n });
        assert_eq!(
            s.counts().shared_facets,
            if shared { 6 * n as u64 } else { 0 }
        );
    }
}

#[test]
fn shared_instancing_errors_name_the_field() {
    let l = next_line() + 4;
    expect_err(
        &triangle_object("instancing = \"copy\"\ninstances = [{ scale = 1.0 }]\n"),
        l,
        "objects.t.instancing",
        "use \"auto\", \"expand\" or \"shared\"",
    );
    expect_err(
        &triangle_object("instancing = \"shared\"\n"),
        l,
        "objects.t.instancing",
        "needs placements",
    );
    let lamp = format!(
        "{BASE}[materials.lamp]\nreflectance = 0.0\nemission = {{ value = 1.0 }}\n[objects.t]\nmaterial = \"lamp\"\nquad = {{ center = [0.0, 0.0, 3.0], size = [1.0, 1.0], normal = [0.0, 0.0, -1.0] }}\ninstancing = \"shared\"\ninstances = [{{ scale = 1.0 }}]\n"
    );
    expect_err(&lamp, l + 2, "objects.t.instancing", "emits");
    expect_err(
        &triangle_object(
            "instancing = \"shared\"\ninstances = [{ translate = [1.0, 0.0, 0.0] }, { translate = [1.0, 0.0, 0.0] }]\n",
        ),
        l + 1,
        "objects.t.instances[1]",
        "the same placement as placement 0",
    );
    expect_err(
        &triangle_object(
            "instancing = \"shared\"\ninstances = [{ translate = [9.9e11, 0.0, 0.0], scale = 1e11 }]\n",
        ),
        l + 1,
        "objects.t.instances[0]",
        "out of range",
    );
}

#[test]
fn the_plan_sees_the_materials_of_shared_instances() {
    // Glass placed as shared instances only: the plan must still turn on
    // transmissive occluders and specular recursion (it read the flat
    // facets alone before).
    let text = format!(
        "{BASE}[materials.glass]\nreflectance = 0.1\nspecular_fraction = 1.0\ntransmission = 0.8\n[objects.pane]\nmaterial = \"glass\"\nquad = {{ center = [0.0, 0.0, 1.0], size = [1.0, 1.0], normal = [0.0, 1.0, 0.0] }}\ninstancing = \"shared\"\ninstances = [{{ translate = [1.0, 0.0, 0.0] }}, {{ translate = [-1.0, 0.0, 0.0] }}]\n"
    );
    let s = parse(&text).unwrap();
    assert_eq!(s.shared.len(), 1);
    let plan = crate::plan::plan(&s);
    assert!(
        plan.is_enabled(crate::plan::names::TRANSMISSIVE_OCCLUDERS),
        "{plan}"
    );
    assert!(
        plan.is_enabled(crate::plan::names::SPECULAR_RECURSION),
        "{plan}"
    );
}

/// Issue 46 round 12: counts that made preparation quadratic or a render
/// hours long have limits, named with the count and the limit.
#[test]
fn bands_distant_sources_and_lines_have_limits() {
    let mut t = BASE.to_string();
    for i in 0..=crate::MAX_BANDS {
        t.push_str(&format!("[bands.b{i}]\nlo_nm = 500\nhi_nm = 600\n"));
    }
    let e = parse(&t).unwrap_err().to_string();
    assert!(e.contains("bands: at most 512"), "{e}");

    let mut t = BASE.to_string();
    for i in 0..=crate::MAX_DISTANT_SOURCES {
        t.push_str(&format!(
            "[distant_sources.d{i}]\ndirection = [0.0, 0.0, -1.0]\nvalue = 1e-3\n"
        ));
    }
    let e = parse(&t).unwrap_err().to_string();
    assert!(e.contains("1001 distant sources: at most 1000"), "{e}");

    let lines: Vec<String> = (0..=gloam_spectra::MAX_LINES)
        .map(|i| format!("[{}, 1e-6]", 400.0 + i as f64 * 1e-3))
        .collect();
    let t = format!(
        "{BASE}\n[point_sources.p]\nposition = [0.0, 0.0, 3.0]\nlines = [{}]\n",
        lines.join(", ")
    );
    let e = parse(&t).unwrap_err().to_string();
    assert!(e.contains("10001 emission lines: at most 10000"), "{e}");
}

/// A placement's scale that shrinks a facet below MIN_FACET_SIZE is
/// refused as the object's own scale is, and a tiny square is called too
/// small, not collinear.
#[test]
fn placement_scale_below_the_smallest_facet_is_refused() {
    let quad = "[objects.t]\nmaterial = \"grey\"\nquad = { center = [0.0, 0.0, 0.0], size = [1e-58, 1e-58], normal = [0.0, 0.0, 1.0] }\n";
    for inst in ["", "instancing = \"shared\"\n"] {
        let t = format!("{BASE}{quad}instances = [ {{ scale = 1e-6 }} ]\n{inst}");
        let e = parse(&t).unwrap_err().to_string();
        assert!(
            e.contains("degenerate") && e.contains("below the 1e-60"),
            "{e}"
        );
    }
    let t = format!("{BASE}{quad}scale = [1e-6, 1e-6, 1e-6]\n");
    let e = parse(&t).unwrap_err().to_string();
    assert!(e.contains("degenerate") && !e.contains("collinear"), "{e}");
    assert!(parse(&format!("{BASE}{quad}")).is_ok());
}
