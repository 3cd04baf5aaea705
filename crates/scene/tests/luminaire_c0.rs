//! `Scene::luminaire_c0`: a measured area luminaire's C0 axis per facet.
//! The material's `c0_direction` is in the scene's frame (the object's
//! own `rotate_z_deg` leaves it); each placement turns it with its
//! geometry, as a point source's (issue 43).

use std::path::Path;

use glam::DVec3;

fn scene(object: &str) -> gloam_scene::Scene {
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
emission = {{ photometry = "road-luminaire-son-tpp-250w.ldt", spectrum = "hps", c0_direction = [1, 0, 0] }}
[materials.wall]
reflectance = 0.5
[objects.wall]
material = "wall"
quad = {{ center = [0, 0, 0], size = [1, 1], normal = [0, 0, 1] }}
[objects.lens]
material = "lens"
quad = {{ center = [0, 0, 8], size = [0.6, 0.3], normal = [0, 0, -1] }}
{object}
"#
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    gloam_scene::parse_str(&text, &dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-15
}

#[test]
fn placements_turn_the_c0_axis_the_objects_own_rotation_does_not() {
    let s = scene(
        "rotate_z_deg = 30\ninstances = [{ translate = [1, 0, 0] }, { rotate_z_deg = 90 }, { rotate_z_deg = 45, scale = [2, 1, 1] }]",
    );
    assert_eq!(s.luminaire_c0(0), None, "not a luminaire");
    assert_eq!(s.facets.len(), 4);
    // The object's own rotation leaves the material's axis: +x.
    assert_eq!(s.luminaire_c0(1), Some(DVec3::X));
    // A placement's turns it: +y.
    assert_eq!(s.luminaire_c0(2), Some(DVec3::Y));
    // Scale (2, 1, 1) keeps x along x, then 45°.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let c = s.luminaire_c0(3).unwrap();
    assert!(close(c, DVec3::new(h, h, 0.0)), "{c}");
    assert_eq!(s.luminaire_c0(4), None, "out of range");
}

/// A tilted facet: the axis is projected into the prototype's plane, then
/// turned, so it stays in the placed facet's plane.
#[test]
fn a_tilted_placed_facet_keeps_its_axis_in_its_plane() {
    let s = scene(
        "[objects.tilted]\nmaterial = \"lens\"\nquad = { center = [0, 0, 4], size = [0.6, 0.3], normal = [1, 0, -1] }\ninstances = [{ rotate_z_deg = 60 }]",
    );
    let i = s.objects[2].first_facet;
    let n = s.facets[i].normal();
    let c = s.luminaire_c0(i).unwrap();
    assert!(
        (c.length() - 1.0).abs() < 1e-15 && c.dot(n).abs() < 1e-15,
        "{c} vs {n}"
    );
    // The unplaced facet's axis, (1, 0, 1)/√2, turned by 60°.
    let (sn, cs) = 60f64.to_radians().sin_cos();
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!(close(c, DVec3::new(h * cs, h * sn, h)), "{c}");
}
