//! `gloam probe SCENE --point X,Y,Z --normal X,Y,Z …` or `--pixel COL,ROW`:
//! irradiance at a point (and the radiance its surface reflects), or one
//! pixel's radiance, without rendering the image.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use gloam_trace::{DVec3, Tracer};

use super::output::print_json;

#[derive(Args)]
pub struct ProbeArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// The point, scene units: X,Y,Z.
    #[arg(long, allow_hyphen_values = true, required_unless_present = "pixel")]
    pub point: Option<String>,
    /// The receiver's normal: X,Y,Z (need not be unit length).
    #[arg(long, allow_hyphen_values = true, required_unless_present = "pixel")]
    pub normal: Option<String>,
    /// Instead of a point: the radiance of pixel COL,ROW (as rendered).
    #[arg(long, conflicts_with_all = ["point", "normal"])]
    pub pixel: Option<String>,
    /// Band name (default: the scene's first band).
    #[arg(long)]
    pub band: Option<String>,
    /// Area-source estimator: analytic (default), solid-angle or dirsig2001.
    #[arg(long)]
    pub estimator: Option<String>,
    /// Independent estimates averaged at the point (the standard error
    /// comes from their spread).
    #[arg(long, default_value_t = 16)]
    /// At most 1 000 000 (each is a full estimate at the point).
    #[arg(value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub samples: u32,
    /// Camera samples per pixel for --pixel (default 4, as `render`).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Seed (default 0).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Any render setting, KEY=VALUE (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

fn triple(what: &str, s: &str) -> anyhow::Result<DVec3> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--{what} `{s}`: expected three numbers X,Y,Z"))?;
    anyhow::ensure!(
        v.len() == 3 && v.iter().all(|x| x.is_finite()),
        "--{what} `{s}`: expected three finite numbers X,Y,Z"
    );
    Ok(DVec3::new(v[0], v[1], v[2]))
}

pub fn run(args: ProbeArgs) -> anyhow::Result<()> {
    let scene = gloam_scene::load(&args.scene)?;
    let settings = gloam_pipeline::SettingArgs {
        set: args.set.clone(),
        spp: args.spp,
        seed: args.seed,
        estimator: args.estimator.clone(),
        ..Default::default()
    }
    .settings()?;
    let tracer = Tracer::new(&scene, &settings)?;
    if let Some(px) = &args.pixel {
        let parts: Vec<u32> = px
            .split(',')
            .map(|x| x.trim().parse::<u32>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("--pixel `{px}`: expected COL,ROW"))?;
        anyhow::ensure!(parts.len() == 2, "--pixel `{px}`: expected COL,ROW");
        let b = tracer.band_index(args.band.as_deref())?;
        let vals = tracer.probe_pixel(parts[0], parts[1])?;
        let band = tracer.wavelengths().band_names[b].clone();
        if args.json {
            print_json(&serde_json::json!({
                "band": band,
                "pixel": [parts[0], parts[1]],
                "radiance_w_m2_sr": vals[b],
            }))?;
        } else {
            outln!(
                "pixel ({}, {}) band {band}: radiance {:.6e} W m^-2 sr^-1",
                parts[0],
                parts[1],
                vals[b]
            );
        }
        return Ok(());
    }
    let point = triple("point", args.point.as_deref().unwrap_or_default())?;
    let normal = triple("normal", args.normal.as_deref().unwrap_or_default())?;
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
