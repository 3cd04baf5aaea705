//! `gloam sky`: illuminance on the ground from the Moon (direct and
//! sky-scattered) and the night sky at one instant and site, with the
//! spectral irradiance tables written to CSV on request. The checks, the
//! report and the CSV are `gloam_sky::report`.

use std::path::PathBuf;

use clap::Args;
use gloam_sky::Cloud;
use gloam_sky::report::{InputNames, SkyReport, checked_site, parse_instant};

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

pub fn run(args: SkyArgs) -> anyhow::Result<()> {
    let names = InputNames::CLI;
    let site = checked_site(args.lat, args.lon, args.height_m, &names)?;
    let t = parse_instant(names.utc, &args.utc)?;
    let cloud = if args.overcast {
        Cloud::Overcast
    } else {
        Cloud::Clear
    };
    let want_spectra = args.spectra_out.is_some();
    let mut report = SkyReport::at(t, &site, args.visibility_km, cloud, want_spectra, &names)?;
    if let (Some(path), Some(csv)) = (&args.spectra_out, report.spectra_csv()) {
        write_atomic(path, csv.as_bytes())?;
        report.spectra_out = Some(path.display().to_string());
    }
    if report.twilight_not_modelled && !args.json {
        eprintln!(
            "warning: the Sun is at {:.1}° (above −18°): twilight and daylight are NOT included",
            report.sun_elevation_deg
        );
    }
    if args.json {
        return print_json(&report);
    }
    outln!("{report}");
    Ok(())
}
