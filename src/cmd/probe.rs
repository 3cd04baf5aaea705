//! `gloam probe SCENE --point X,Y,Z --normal X,Y,Z …` or `--pixel COL,ROW`:
//! irradiance at a point (and the radiance its surface reflects), or one
//! pixel's radiance, without rendering the image.

pub use gloam_pipeline::cli::ProbeArgs;
use gloam_trace::Tracer;

use super::print_json;

pub fn run(args: ProbeArgs) -> anyhow::Result<()> {
    let scene = gloam_scene::load(&args.scene, &gloam_io::ReadLog::off())?;
    let tracer = Tracer::new(&scene, &args.settings().settings()?)?;
    if let Some((col, row)) = args.pixel()? {
        let b = tracer.band_index(args.band.as_deref())?;
        let l = tracer.probe_pixel(col, row)?[b];
        let band = tracer.wavelengths().band_names[b].clone();
        if args.json {
            let v = serde_json::json!({"band": band, "pixel": [col, row], "radiance_w_m2_sr": l});
            return print_json(&v);
        }
        outln!("pixel ({col}, {row}) band {band}: radiance {l:.6e} W m^-2 sr^-1");
        return Ok(());
    }
    let (point, normal) = args.point_normal()?;
    let r = tracer.probe_point(point, normal, args.band.as_deref(), args.samples)?;
    if args.json {
        return print_json(&r);
    }
    for line in gloam_pipeline::cli::print::probe_lines(&r) {
        outln!("{line}");
    }
    Ok(())
}
