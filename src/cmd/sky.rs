//! `gloam sky`: illuminance on the ground from the Moon (direct and
//! sky-scattered) and the night sky at one instant and site, with the
//! spectral irradiance tables written to CSV on request. The physics is in
//! `gloam_sky::ground_illuminance`.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use gloam_sky::{Cloud, GroundSpectra, IlluminanceLux, ground_illuminance};
use serde::Serialize;

use super::ephem::{MoonJson, fmt_site, parse_instant, site_from_flags};
use super::output::{print_json, write_atomic};

#[derive(Args, Debug)]
pub struct SkyArgs {
    /// Site latitude, degrees north (−90..90).
    #[arg(long, allow_negative_numbers = true)]
    pub lat: f64,
    /// Site longitude, degrees east positive (−180..360).
    #[arg(long, allow_negative_numbers = true)]
    pub lon: f64,
    /// Site height above sea level, metres.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub height_m: f64,
    /// The instant, ISO 8601 (`2024-12-15T07:20:00Z`; no zone = UTC).
    #[arg(long)]
    pub utc: String,
    /// Meteorological visibility, km (Koschmieder; sets the aerosol load).
    #[arg(long, default_value_t = 23.0, allow_negative_numbers = true)]
    pub visibility_km: f64,
    /// Complete overcast: no direct beam; 10 % of the clear-sky moonlight
    /// and night-sky light passes the cloud deck as a uniform dome.
    #[arg(long)]
    pub overcast: bool,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write the spectral irradiance (W m⁻² nm⁻¹, 300–1100 nm at 5 nm) to
    /// this CSV file.
    #[arg(long, value_name = "FILE.csv")]
    pub spectra_out: Option<PathBuf>,
}

#[derive(Serialize)]
struct ConditionsJson {
    visibility_km: f64,
    cloud: Cloud,
    height_m: f64,
}

#[derive(Serialize)]
struct SkyJson {
    utc: String,
    illuminance_lux: IlluminanceLux,
    moon: MoonJson,
    sun_elevation_deg: f64,
    twilight_not_modelled: bool,
    conditions: ConditionsJson,
    #[serde(skip_serializing_if = "Option::is_none")]
    spectra_out: Option<String>,
}

/// The CSV written by `--spectra-out`: a header comment, a header row and
/// one row per wavelength. Each column after the first loads as a spectrum
/// with `gloam_spectra::read_csv` once the others are dropped.
pub fn spectra_csv(s: &GroundSpectra, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    out.push_str(
        "wavelength_nm,moon_exo_normal_w_m2_nm,moon_direct_horizontal_w_m2_nm,\
         moon_sky_horizontal_w_m2_nm,night_sky_horizontal_w_m2_nm,total_horizontal_w_m2_nm\n",
    );
    let cols = [
        &s.moon_exo_normal_w_m2_nm,
        &s.moon_direct_horizontal_w_m2_nm,
        &s.moon_sky_horizontal_w_m2_nm,
        &s.night_sky_horizontal_w_m2_nm,
        &s.total_horizontal_w_m2_nm,
    ];
    for (i, &(w, _)) in s.total_horizontal_w_m2_nm.iter().enumerate() {
        let _ = write!(out, "{w}");
        for c in cols {
            let v = c.get(i).map_or(0.0, |p| p.1);
            let _ = write!(out, ",{v:.6e}");
        }
        out.push('\n');
    }
    out
}

/// `0`, or four significant figures in scientific notation.
fn fmt_lux(x: f64) -> String {
    if x == 0.0 {
        "0".to_string()
    } else {
        format!("{x:.3e}")
    }
}

pub fn run(args: SkyArgs) -> anyhow::Result<()> {
    let site = site_from_flags(args.lat, args.lon, args.height_m)?;
    let t = parse_instant("--utc", &args.utc)?;
    if !(args.visibility_km.is_finite() && (0.05..=1000.0).contains(&args.visibility_km)) {
        anyhow::bail!(
            "--visibility-km {} is out of range: visibility must be within 0.05..1000 km",
            args.visibility_km
        );
    }
    let cloud = if args.overcast {
        Cloud::Overcast
    } else {
        Cloud::Clear
    };
    let g = ground_illuminance(
        t,
        &site,
        args.visibility_km,
        cloud,
        args.spectra_out.is_some(),
    )?;
    let e = &g.ephemeris;
    if let (Some(path), Some(s)) = (&args.spectra_out, &g.spectra) {
        let header = format!(
            "gloam sky: horizontal spectral irradiance on the ground, W m-2 nm-1\n\
             {} at {}; visibility {} km; {}\n\
             Moon elevation {:.3} deg, azimuth {:.3} deg, illuminated {:.4}, phase angle {:.3} deg",
            t.to_iso8601(),
            fmt_site(&site),
            args.visibility_km,
            if args.overcast { "overcast" } else { "clear" },
            e.moon.elevation_deg,
            e.moon.azimuth_deg,
            e.illuminated_fraction,
            e.phase_angle_deg
        );
        write_atomic(path, spectra_csv(s, &header).as_bytes())?;
    }
    if g.twilight_not_modelled && !args.json {
        eprintln!(
            "warning: the Sun is at {:.1}° (above −18°): twilight and daylight are NOT included",
            e.sun.elevation_deg
        );
    }
    let l = g.illuminance_lux;
    if args.json {
        return print_json(&SkyJson {
            utc: t.to_iso8601(),
            illuminance_lux: l,
            moon: MoonJson::from_ephemeris(e),
            sun_elevation_deg: e.sun.elevation_deg,
            twilight_not_modelled: g.twilight_not_modelled,
            conditions: ConditionsJson {
                visibility_km: args.visibility_km,
                cloud,
                height_m: args.height_m,
            },
            spectra_out: args.spectra_out.as_ref().map(|p| p.display().to_string()),
        });
    }
    outln!(
        "{} at {}; visibility {} km, {}",
        t.to_iso8601(),
        fmt_site(&site),
        args.visibility_km,
        if args.overcast { "overcast" } else { "clear" }
    );
    outln!(
        "moon elevation {:.2}°, azimuth {:.2}°, {:.1} % illuminated; sun {:.2}°",
        e.moon.elevation_deg,
        e.moon.azimuth_deg,
        100.0 * e.illuminated_fraction,
        e.sun.elevation_deg
    );
    outln!("ground illuminance (horizontal):");
    outln!("  moon direct  {} lux", fmt_lux(l.moon_direct));
    outln!("  moon sky     {} lux", fmt_lux(l.moon_sky));
    outln!("  night sky    {} lux", fmt_lux(l.night_sky));
    outln!("  total        {} lux", fmt_lux(l.total));
    if let Some(p) = &args.spectra_out {
        outln!("spectral irradiance written to {}", p.display());
    }
    Ok(())
}
