//! `gloam probe SCENE --point X,Y,Z --normal X,Y,Z …` or `--pixel COL,ROW`:
//! irradiance at a point (and the radiance its surface reflects), or one
//! pixel's radiance, without rendering the image.

pub use gloam_pipeline::cli::ProbeArgs;
use gloam_trace::Tracer;

use super::output::print_json;

pub fn run(args: ProbeArgs) -> anyhow::Result<()> {
    let scene = gloam_scene::load(&args.scene)?;
    let tracer = Tracer::new(&scene, &args.settings().settings()?)?;
    if let Some((col, row)) = args.pixel()? {
        let b = tracer.band_index(args.band.as_deref())?;
        let vals = tracer.probe_pixel(col, row)?;
        let band = tracer.wavelengths().band_names[b].clone();
        if args.json {
            print_json(&serde_json::json!({
                "band": band,
                "pixel": [col, row],
                "radiance_w_m2_sr": vals[b],
            }))?;
        } else {
            let l = vals[b];
            outln!("pixel ({col}, {row}) band {band}: radiance {l:.6e} W m^-2 sr^-1");
        }
        return Ok(());
    }
    let (point, normal) = args.point_normal()?;
    let r = tracer.probe_point(point, normal, args.band.as_deref(), args.samples)?;
    if args.json {
        print_json(&r)?;
    } else {
        outln!(
            "band {}: irradiance {:.6e} ± {:.2e} W m^-2",
            r.band,
            r.irradiance_w_m2,
            r.std_error_w_m2
        );
        if let Some(i) = r.indirect_irradiance_w_m2 {
            outln!(
                "  direct {:.6e} + interreflection {i:.6e} W m^-2",
                r.direct_irradiance_w_m2
            );
        }
        if let Some(l) = r.radiance_w_m2_sr {
            outln!("reflected radiance {l:.6e} W m^-2 sr^-1");
        }
        outln!("terms: {}", r.terms);
    }
    Ok(())
}
