//! `gloam sensor list|describe`.

use clap::{Args, Subcommand};
use gloam_sensor::{Chain, SensorConfig, presets};
use serde::Serialize;

use super::output::print_json;

#[derive(Subcommand)]
pub enum SensorCommand {
    /// List the built-in sensor presets.
    List {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Derived figures of a preset or sensor TOML file at a gain.
    Describe(DescribeArgs),
}

#[derive(Args)]
pub struct DescribeArgs {
    /// A built-in preset (see `gloam sensor list`) or a sensor TOML file.
    pub sensor: String,
    /// Tube gain (MCP gain, EB gain, or analogue gain for a plain CCD);
    /// default: the configured fixed gain.
    #[arg(long)]
    pub gain: Option<f64>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct PresetRow {
    name: &'static str,
    kind: gloam_sensor::SensorKind,
    description: String,
    sources: Vec<String>,
}

pub fn run(cmd: SensorCommand) -> anyhow::Result<()> {
    match cmd {
        SensorCommand::List { json } => {
            let rows: Vec<PresetRow> = presets()
                .into_iter()
                .filter_map(|(name, _)| {
                    let c = SensorConfig::preset(name)?.ok()?;
                    Some(PresetRow {
                        name,
                        kind: c.kind,
                        description: c.description,
                        sources: c.sources,
                    })
                })
                .collect();
            if json {
                print_json(&rows)?;
            } else {
                for r in rows {
                    outln!(
                        "{:<16} {:<6} {}",
                        r.name,
                        format!("{:?}", r.kind),
                        r.description
                    );
                }
            }
            Ok(())
        }
        SensorCommand::Describe(a) => {
            let cfg = SensorConfig::load_preset_or_file(&a.sensor)?;
            let chain = Chain::new(&cfg)?;
            let g = a.gain.unwrap_or(chain.reference_gain);
            if !(g.is_finite()
                && g >= chain.gain_min * (1.0 - 1e-9)
                && g <= chain.gain_max * (1.0 + 1e-9))
            {
                anyhow::bail!(
                    "--gain {g} is outside {}'s range {:.4}–{:.4}",
                    cfg.name,
                    chain.gain_min,
                    chain.gain_max
                );
            }
            let d = chain.describe(g);
            if a.json {
                print_json(&d)?;
            } else {
                outln!("{} ({:?}) at gain {:.4}", d.name, d.kind, d.gain);
                if let Some(v) = d.control_voltage_v {
                    outln!("  control voltage        {v:.1} V");
                }
                outln!(
                    "  gain range             {:.4} – {:.4}",
                    d.gain_min,
                    d.gain_max
                );
                outln!("  DN per photoelectron   {:.6}", d.dn_per_photoelectron);
                outln!("  excess noise factor    {:.4}", d.excess_noise_factor);
                outln!("  read noise             {:.3} DN", d.read_noise_dn);
                outln!("  black level            {:.2} DN", d.black_dn);
                outln!(
                    "  saturation             {:.0} DN ({:.4} photoelectrons)",
                    d.saturation_dn,
                    d.saturation_photoelectrons
                );
                outln!("  bit depth              {}", d.bit_depth);
                outln!(
                    "  EBI                    {:.3e} photoelectrons/pixel/frame",
                    d.ebi_photoelectrons_per_pixel
                );
                if let Some(s) = d.cathode_luminous_sensitivity_ua_lm {
                    outln!("  cathode sensitivity    {s:.0} µA/lm (2856 K)");
                }
                outln!(
                    "  MTF at 0.25 / 0.5 cy/px {:.3} / {:.3}",
                    d.mtf_quarter_nyquist_half[0],
                    d.mtf_quarter_nyquist_half[1]
                );
            }
            Ok(())
        }
    }
}
