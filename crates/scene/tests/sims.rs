//! The shipped sims parse, have the geometry they document, and plan right.

use std::path::{Path, PathBuf};

use glam::DVec3;
use gloam_scene::{Units, load, plan::plan};

fn sim(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../sims")
        .join(name)
        .join("scene.toml")
}

#[test]
fn panel_validation_scene() {
    let s =
        load(&sim("panel-validation"), &gloam_io::ReadLog::off()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.units, Units::Feet);
    assert_eq!(s.meters_per_unit, 0.3048);
    assert!(s.sky.is_none());
    assert!(s.point_sources.is_empty());
    assert_eq!(s.bands.len(), 1);
    assert_eq!(
        (s.bands[0].name.as_str(), s.bands[0].lo_nm, s.bands[0].hi_nm),
        ("vis", 400.0, 700.0)
    );

    let emitting = s.emitting_facets();
    assert_eq!(emitting.len(), 1);
    let panel = &s.facets[emitting[0]];
    assert_eq!(panel.object, "panel");
    assert!((panel.normal() - DVec3::NEG_Z).length() < 1e-15);
    assert!((panel.area() - 8.0).abs() < 1e-12);
    assert!((panel.centroid() - DVec3::new(0.0, 0.0, 9.0)).length() < 1e-12);
    // Long side (4 ft) along x.
    let xs = panel.vertices.iter().map(|v| v.x.abs()).fold(0.0, f64::max);
    let ys = panel.vertices.iter().map(|v| v.y.abs()).fold(0.0, f64::max);
    assert_eq!((xs, ys), (2.0, 1.0));
    let e = s.material_of(panel).emission.as_ref().unwrap();
    assert_eq!(e.shape_exponent, 0.0);
    let l = &e.radiance_w_m2_sr_nm;
    assert!((l.integrate_band(400.0, 700.0) - 15.058).abs() < 1e-12);
    assert!(
        (l.eval(450.0) - l.eval(650.0)).abs() < 1e-15,
        "flat spectrum"
    );

    let floor = s.facets.iter().find(|f| f.object == "floor").unwrap();
    assert!((floor.normal() - DVec3::Z).length() < 1e-15);
    assert!((floor.area() - 1600.0).abs() < 1e-9);
    let rho = &s.material_of(floor).reflectance;
    assert_eq!((rho.eval(400.0), rho.eval(700.0)), (0.9, 0.9));

    // The documented image positions (scene.toml header comment).
    let c = &s.camera;
    let (x, y) = c.project(DVec3::ZERO).unwrap();
    assert!(
        (x - 160.0).abs() < 1e-9 && (y - 211.7).abs() < 0.05,
        "floor point at ({x}, {y})"
    );
    let (x, y) = c.project(DVec3::new(0.0, 0.0, 9.0)).unwrap();
    assert!(
        (x - 160.0).abs() < 1e-9 && (y - 30.8).abs() < 0.05,
        "panel centre at ({x}, {y})"
    );
    assert!(c.frustum_overlaps(&panel.vertices));
    assert!(
        panel.vertices.iter().all(|&v| c.sees_point(v)),
        "the whole panel is in view"
    );

    let p = plan(&s);
    // Interreflection is possible (the scene's materials reflect); the
    // tracer's pilot decides whether it is worth simulating.
    assert_eq!(
        p.enabled(),
        ["area-sources", "interreflection", "direct-view"]
    );
    assert_eq!(
        p.get("area-sources").unwrap().reason,
        "1 emitting facet (panel); Lambertian"
    );
    assert!(p.get("direct-view").unwrap().reason.contains("(panel)"));
}

#[test]
fn office_room_scene() {
    let s = load(&sim("office-room"), &gloam_io::ReadLog::off()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.units, Units::Feet);
    assert!(
        s.facets.len() > 50 && s.facets.len() < 500,
        "{} facets",
        s.facets.len()
    );
    assert_eq!(
        s.bands.iter().map(|b| b.name.as_str()).collect::<Vec<_>>(),
        ["vis", "nir"]
    );
    let emitting = s.emitting_facets();
    assert_eq!(emitting.len(), 2);
    for &i in &emitting {
        let f = &s.facets[i];
        assert!((f.normal() - DVec3::NEG_Z).length() < 1e-15);
        assert!((f.area() - 8.0).abs() < 1e-12);
        let e = s.material_of(f).emission.as_ref().unwrap();
        assert!((e.radiance_w_m2_sr_nm.integrate_band(400.0, 700.0) - 15.058).abs() < 1e-9);
        // F11 is a line-rich triphosphor: not flat.
        assert!(e.radiance_w_m2_sr_nm.eval(545.0) > 3.0 * e.radiance_w_m2_sr_nm.eval(500.0));
        // The comment's ≈ 5200 cd/m².
        let lv = gloam_spectra::photopic(&e.radiance_w_m2_sr_nm);
        assert!((5000.0..5500.0).contains(&lv), "{lv} cd/m²");
    }
    // The room faces inward: every wall, floor and ceiling normal points at
    // the room's centre.
    let centre = DVec3::new(10.0, 7.5, 4.5);
    for f in s
        .facets
        .iter()
        .filter(|f| ["room", "floor", "ceiling"].contains(&f.object.as_str()))
    {
        assert!(
            (centre - f.centroid()).dot(f.normal()) > 0.0,
            "{} faces outward",
            f.object
        );
    }
    // The table top is directly below the west panel.
    let west = s
        .facets
        .iter()
        .find(|f| f.object == "panel-west")
        .unwrap()
        .centroid();
    let top = s
        .facets
        .iter()
        .find(|f| f.object == "table-top" && f.normal().z > 0.5)
        .unwrap();
    let c = top.centroid();
    assert!((c.x - west.x).abs() < 1e-9 && (c.y - west.y).abs() < 1e-9 && c.z < west.z);
    check_person(&s);

    let p = plan(&s);
    // Interreflection is possible (the scene's materials reflect); the
    // tracer's pilot decides whether it is worth simulating.
    assert_eq!(
        p.enabled(),
        ["area-sources", "interreflection", "direct-view"]
    );
    assert_eq!(
        p.get("area-sources").unwrap().reason,
        "2 emitting facets (panel-west, panel-east); Lambertian"
    );
    assert!(
        p.get("direct-view")
            .unwrap()
            .reason
            .starts_with("2 emitting facets")
    );
    assert_eq!(
        p.get("moon").unwrap().reason,
        "no [sky] block (indoor scene)"
    );
}

/// The office's person (OBJ): 6 boxes of 6 quads, all facing outward,
/// feet on the floor.
fn check_person(s: &gloam_scene::Scene) {
    let person: Vec<_> = s.facets.iter().filter(|f| f.object == "person").collect();
    assert_eq!(person.len(), 36);
    assert!(person.iter().all(|f| f.vertices.len() == 4));
    let zmin = person
        .iter()
        .flat_map(|f| &f.vertices)
        .map(|v| v.z)
        .fold(f64::MAX, f64::min);
    let zmax = person
        .iter()
        .flat_map(|f| &f.vertices)
        .map(|v| v.z)
        .fold(f64::MIN, f64::max);
    assert!(zmin.abs() < 1e-6 && (zmax - 5.75).abs() < 1e-5);
    // Every box of the person has its faces pointing away from its centre:
    // summed vector area of a closed box is zero and each face points out.
    for chunk in person.chunks(6) {
        let bc: DVec3 = chunk.iter().map(|f| f.centroid()).sum::<DVec3>() / 6.0;
        for f in chunk {
            assert!((f.centroid() - bc).dot(f.normal()) > 0.0);
        }
    }
}

#[test]
fn street_ies_scene_reads_its_luminaire() {
    let s = load(&sim("street-ies"), &gloam_io::ReadLog::off()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.point_sources.len(), 1);
    let p = &s.point_sources[0];
    let lum = p.luminaire.as_ref().expect("a measured luminaire");
    assert_eq!(lum.c0, DVec3::X);
    assert!((lum.table.max_candela - 534.0 * 33.2).abs() < 1e-9);
    // Its luminous intensity is the file's peak, 17 729 cd.
    let cd = gloam_spectra::photopic(&p.intensity_w_sr_nm);
    assert!((cd - 534.0 * 33.2).abs() < 1e-9 * cd, "{cd}");
    let text = plan(&s).to_string();
    assert!(text.contains("shaped"), "{text}");
}
