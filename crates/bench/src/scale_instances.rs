//! `gloam bench scale`'s third family, **instances** `N`: a night car park
//! or orchard of `N` placements of one 49 728-triangle model (a UV sphere
//! of [`TREE_BANDS`] latitude bands, 2 m across, its centre 3 m up) on a
//! 6 m grid, each turned and scaled differently, over a ground quad and
//! under a 3 × 3 grid of shaped point lamps 10 m up. The model is written
//! once (`tree.obj`), its placements as `placements.csv`, and the object
//! says `instancing = "shared"`: the tracer holds one prototype BVH and a
//! top-level BVH over the placements, so `N = 2 012` is 10⁸ placed
//! triangles in a few hundred megabytes. Whole light: interreflection is
//! path-traced (the radiosity cache has no texels on shared instances).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use gloam_trace::DVec3;

use super::BenchError;

/// Latitude bands of the model: `4 b (b − 1)` = 49 728 triangles.
pub const TREE_BANDS: u64 = 112;
/// Triangles of the model.
pub const TREE_TRIANGLES: u64 = 4 * TREE_BANDS * (TREE_BANDS - 1);
/// Most placements a case may ask for (10⁹ placed triangles).
pub const MAX_PLACEMENTS: u64 = 20_000;
const PITCH_M: f64 = 6.0;
const RADIUS_M: f64 = 1.0;
const CENTRE_HEIGHT_M: f64 = 3.0;
const LAMP_HEIGHT_M: f64 = 10.0;
const LAMP_W_SR: f64 = 200.0;

/// Grid side for `n` placements.
fn side(n: u64) -> u64 {
    (n as f64).sqrt().ceil() as u64
}

/// Writes the scene's text into `toml` and its model and placements into
/// `dir` (an empty directory the caller created).
pub fn generate(
    n: u64,
    dir: &Path,
    width: u32,
    height: u32,
    toml: &mut String,
) -> Result<(), BenchError> {
    let side = side(n);
    let half = (side as f64 - 1.0) / 2.0 * PITCH_M;
    let ground = 2.0 * half + 4.0 * PITCH_M;
    let _ = writeln!(
        toml,
        "[camera]   # from a corner, over the placements\nposition = [{cx}, {cy}, 12.0]\nlook_at = [0.0, 0.0, 0.0]\nfov_deg = 60.0\nwidth = {width}\nheight = {height}\n\n\
         [bands.visible]\nlo_nm = 400\nhi_nm = 700\n\n\
         [materials.ground]\nreflectance = 0.3\n[materials.leaf]\nreflectance = 0.45\n\n\
         [objects.ground]\nmaterial = \"ground\"\nquad = {{ center = [0.0, 0.0, 0.0], size = [{ground}, {ground}], normal = [0.0, 0.0, 1.0] }}\n\
         [objects.trees]   # {n} placements of a {TREE_TRIANGLES}-triangle model\nmaterial = \"leaf\"\nobj = \"tree.obj\"\ninstancing = \"shared\"\ninstances_csv = \"placements.csv\"\n",
        cx = -half - PITCH_M,
        cy = -half - PITCH_M,
    );
    for i in 0..9 {
        let (x, y) = ((i % 3) as f64 - 1.0, (i / 3) as f64 - 1.0);
        let _ = writeln!(
            toml,
            "[point_sources.lamp-{i}]\nposition = [{}, {}, {LAMP_HEIGHT_M}]\nshape_exponent = 1.0\nvalue = 1.0\nnormalize = {{ lo_nm = 400, hi_nm = 700, value = {LAMP_W_SR} }}",
            x * (half + 0.5 * PITCH_M),
            y * (half + 0.5 * PITCH_M),
        );
    }
    let tree = dir.join("tree.obj");
    write_tree(&tree).map_err(BenchError::io("writing", &tree))?;
    let csv = dir.join("placements.csv");
    let write_csv = || -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&csv)?);
        writeln!(w, "x,y,z,rotate_z_deg,scale")?;
        for k in 0..n {
            let (r, c) = (k / side, k % side);
            // Deterministic variety: turns and sizes from the index.
            let turn = (k * 37) % 360;
            let scale = 0.8 + 0.4 * ((k * 7919) % 101) as f64 / 100.0;
            writeln!(
                w,
                "{},{},0,{turn},{scale}",
                c as f64 * PITCH_M - half,
                r as f64 * PITCH_M - half
            )?;
        }
        w.flush()
    };
    write_csv().map_err(BenchError::io("writing", &csv))
}

/// The model: a UV sphere of [`TREE_BANDS`] bands.
fn write_tree(path: &Path) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let c = DVec3::new(0.0, 0.0, CENTRE_HEIGHT_M);
    super::scale::write_uv_sphere(&mut w, c, RADIUS_M, TREE_BANDS, 1)?;
    w.flush()
}
