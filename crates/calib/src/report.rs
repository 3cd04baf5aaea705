//! Reports: JSON with all figures, a Markdown summary, and the PNG plots,
//! for each flow. File names are part of the CLI contract.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::agc::AgcReport;
use crate::error::CalibError;
use crate::mtf::MtfCurve;
use crate::mtf_flow::MtfDetails;
use crate::plot::{Mark, Series, xy_plot};
use crate::ptc::PtcResult;
use crate::radiance::Lut;

/// Writes `value` as pretty JSON to `path`, atomically (temp file + rename).
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<(), CalibError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| CalibError::file(path, e))?;
    write_text(path, &text)
}

/// Writes text atomically (temp file in the same directory + rename).
pub fn write_text(path: &Path, text: &str) -> Result<(), CalibError> {
    write_bytes(path, text.as_bytes())
}

/// The file `path` names, resolved (links followed, `..` gone) as far as
/// it exists: its own canonical path, or its parent's joined with its name.
fn resolved(path: &Path) -> Option<std::path::PathBuf> {
    if let Ok(p) = std::fs::canonicalize(path) {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(std::fs::canonicalize(parent).ok()?.join(name))
}

/// Whether `a` and `b` are one file: the same resolved path, or (both
/// existing) the same device and inode — a hard link too.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b))
            && (x.dev(), x.ino()) == (y.dev(), y.ino())
        {
            return true;
        }
    }
    matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses an output file (`flag` `output`) that is one of the run's
/// `inputs` (`(flag, path)`), however it is spelled: through a symbolic
/// link, `..`, or a hard link. Writing there would replace the input the
/// run reads.
pub fn refuse_output_over_inputs(
    flag: &'static str,
    output: &Path,
    inputs: &[(&'static str, &Path)],
) -> Result<(), CalibError> {
    for &(input_flag, input) in inputs {
        if same_file(output, input) {
            return Err(CalibError::OutputIsInput {
                flag,
                output: output.to_path_buf(),
                input_flag,
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Refuses an output directory (`--out`) that holds one of the run's
/// `inputs`: replacing the set there (`--force`) would delete an input.
pub fn refuse_out_dir_holding_inputs(
    out: &Path,
    inputs: &[(&'static str, &Path)],
) -> Result<(), CalibError> {
    let Ok(out_dir) = std::fs::canonicalize(out) else {
        return Ok(()); // Not there yet: it holds nothing.
    };
    for &(flag, input) in inputs {
        if let Some(p) = resolved(input)
            && p.starts_with(&out_dir)
        {
            return Err(CalibError::Usage(format!(
                "--out {}: holds {flag} {}, an input of this run; the output set there would replace it — write the output elsewhere",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// Writes bytes atomically ([`gloam_io::write_atomic`]: a uniquely named
/// temporary file beside `path`, flushed to disk, then renamed over it).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), CalibError> {
    Ok(gloam_io::write_atomic(path, bytes)?)
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |x| format!("{x:.digits$}"))
}

/// `lut.json`, `radiance.md`, `linearity_residuals.png`, `radiance_fit.png`.
pub fn write_radiance_report(dir: &Path, lut: &Lut) -> Result<(), CalibError> {
    write_json(&dir.join("lut.json"), lut)?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Radiance calibration\n\n- grabber: {}\n- source: {}\n- band: {:.0}–{:.0} nm\n",
        lut.grabber, lut.source, lut.band_nm[0], lut.band_nm[1]
    );
    let _ = writeln!(
        md,
        "| gain | g (W m⁻² sr⁻¹/DN) | b (W m⁻² sr⁻¹) | R² | fit range (DN) | saturation (DN) | max residual (%) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|");
    for g in &lut.gains {
        let _ = writeln!(
            md,
            "| {} | {:.6e} | {:.6e} | {:.6} | {:.1}–{:.1} | {} | {:.3} |",
            g.gain,
            g.g_w_m2_sr_per_dn,
            g.b_w_m2_sr,
            g.r_squared,
            g.fit_range_dn[0],
            g.fit_range_dn[1],
            opt(g.saturation_dn, 1),
            g.max_abs_residual_percent
        );
    }
    for g in &lut.gains {
        for w in &g.warnings {
            let _ = writeln!(md, "\n> gain {}: {w}", g.gain);
        }
    }
    let _ = writeln!(
        md,
        "\n![fit](radiance_fit.png)\n![residuals](linearity_residuals.png)"
    );
    write_text(&dir.join("radiance.md"), &md)?;
    let fit: Vec<Series> = lut
        .gains
        .iter()
        .map(|g| {
            Series::new(
                &format!("gain {}", g.gain),
                g.levels
                    .iter()
                    .map(|p| (p.mean_dn, p.band_radiance_w_m2_sr))
                    .collect(),
                Mark::LinePoints,
            )
        })
        .collect();
    xy_plot(
        &dir.join("radiance_fit.png"),
        "Radiance vs digital count",
        "mean DC (DN)",
        "band radiance (W m^-2 sr^-1)",
        &fit,
    )?;
    let res: Vec<Series> = lut
        .gains
        .iter()
        .map(|g| {
            let lmax = g
                .levels
                .iter()
                .map(|p| p.band_radiance_w_m2_sr)
                .fold(0.0, f64::max)
                .max(1e-300);
            Series::new(
                &format!("gain {}", g.gain),
                g.levels
                    .iter()
                    .filter_map(|p| p.residual_w_m2_sr.map(|r| (p.mean_dn, 100.0 * r / lmax)))
                    .collect(),
                Mark::LinePoints,
            )
        })
        .collect();
    xy_plot(
        &dir.join("linearity_residuals.png"),
        "Linearity residuals",
        "mean DC (DN)",
        "residual (% of max radiance)",
        &res,
    )
}

/// `ptc.json`, `ptc.md`, `photon_transfer.png`, `ptc_linearity.png`.
pub fn write_ptc_report(dir: &Path, r: &PtcResult) -> Result<(), CalibError> {
    write_json(&dir.join("ptc.json"), r)?;
    write_text(&dir.join("ptc.md"), &ptc_markdown(r))?;
    write_ptc_plots(dir, r)
}

/// `ptc.md`: the EMVA 1288 figures, the excess-noise relation and the
/// warnings.
fn ptc_markdown(r: &PtcResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Photon transfer (EMVA 1288 Release 4.0, linear module)\n"
    );
    let _ = writeln!(md, "| quantity | value |\n|---|---|");
    let rows: Vec<(&str, String)> = vec![
        ("gain setting", format!("{}", r.gain)),
        (
            "system gain K = K_eff (DN/e⁻, excess noise included)",
            format!("{:.5}", r.system_gain_dn_per_e),
        ),
        (
            "quantum efficiency η (EMVA, R/K)",
            opt(r.quantum_efficiency, 4),
        ),
        (
            "excess noise factor F (declared)",
            opt(r.excess_noise_factor, 4),
        ),
        (
            "pixel noise factor F_pix = K_eff/g",
            opt(r.pixel_noise_factor, 4),
        ),
        (
            "conversion gain g = K_eff/F_pix (DN/photoelectron)",
            opt(r.conversion_gain_dn_per_pe, 5),
        ),
        (
            "QE from the conversion gain, R/g",
            opt(r.quantum_efficiency_from_conversion_gain, 4),
        ),
        ("temporal dark noise (e⁻)", format!("{:.3}", r.dark_noise_e)),
        (
            "saturation capacity (e⁻)",
            format!("{:.1}", r.saturation_capacity_e),
        ),
        ("SNR max (dB)", format!("{:.2}", r.snr_max_db)),
        (
            "absolute sensitivity threshold (e⁻)",
            format!("{:.3}", r.absolute_sensitivity_threshold_e),
        ),
        ("dynamic range (dB)", format!("{:.2}", r.dynamic_range_db)),
        ("linearity error (%)", opt(r.linearity_error_percent, 3)),
        ("DSNU (e⁻)", format!("{:.3}", r.dsnu_e)),
        ("PRNU (%)", format!("{:.3}", r.prnu_percent)),
    ];
    for (k, v) in rows {
        let _ = writeln!(md, "| {k} | {v} |");
    }
    // The relation is among the warnings on an intensified camera; on a CCD
    // it is a plain statement.
    if let Some(rel) = &r.excess_noise_relation
        && !r.warnings.contains(rel)
    {
        let _ = writeln!(md, "\n{rel}");
    }
    for w in &r.warnings {
        let _ = writeln!(md, "\n> {w}");
    }
    let _ = writeln!(
        md,
        "\nThe EMVA 1288 dataset (descriptor + images) is in `emva1288/`.\n\n![PTC](photon_transfer.png)\n![linearity](ptc_linearity.png)"
    );
    md
}

/// `photon_transfer.png` (variance against signal, with the K fit) and,
/// with a rig, `ptc_linearity.png`.
fn write_ptc_plots(dir: &Path, r: &PtcResult) -> Result<(), CalibError> {
    let pts: Vec<(f64, f64)> = r
        .points
        .iter()
        .map(|p| (p.mean_dn - r.dark_mean_dn, p.temporal_var_dn2))
        .collect();
    let smax = r.saturation_dn - r.dark_mean_dn;
    let fit = vec![
        (0.0, r.dark_noise_dn.powi(2)),
        (
            0.7 * smax,
            r.dark_noise_dn.powi(2) + 0.7 * smax * r.system_gain_dn_per_e,
        ),
    ];
    xy_plot(
        &dir.join("photon_transfer.png"),
        "Photon transfer curve",
        "mean signal above dark (DN)",
        "temporal variance (DN^2)",
        &[
            Series::new("measured", pts, Mark::Points),
            Series::new("K fit", fit, Mark::Line),
        ],
    )?;
    if !r.linearity_residuals_percent.is_empty() {
        xy_plot(
            &dir.join("ptc_linearity.png"),
            "Linearity deviation",
            "photons per pixel",
            "deviation (%)",
            &[Series::new(
                "δ",
                r.linearity_residuals_percent.clone(),
                Mark::LinePoints,
            )],
        )?;
    }
    Ok(())
}

/// `mtf.json`'s document: the first curve's values at the top (what a
/// reader of one MTF wants), every curve under `curves`, and how they were
/// measured under `details`. Python's `calibrate.mtf` returns the same.
#[derive(Clone, Debug, Serialize)]
pub struct MtfDocument<'a> {
    pub method: &'a str,
    pub frequencies_cy_per_px: &'a [f64],
    pub mtf: &'a [f64],
    pub mtf50: Option<f64>,
    pub mtf10: Option<f64>,
    pub curves: &'a [MtfCurve],
    pub details: &'a MtfDetails,
}

impl<'a> MtfDocument<'a> {
    /// The document of `curves` (the first leads); refused without one.
    pub fn new(curves: &'a [MtfCurve], details: &'a MtfDetails) -> Result<Self, CalibError> {
        let first = curves
            .first()
            .ok_or_else(|| CalibError::InsufficientData("no MTF curve".into()))?;
        Ok(MtfDocument {
            method: &first.method,
            frequencies_cy_per_px: &first.frequencies_cy_per_px,
            mtf: &first.mtf,
            mtf50: first.mtf50,
            mtf10: first.mtf10,
            curves,
            details,
        })
    }
}

/// `mtf.json` (frequencies, MTF values, mtf50, mtf10), `mtf.md`, `mtf.png`.
pub fn write_mtf_report(
    dir: &Path,
    curves: &[MtfCurve],
    details: &MtfDetails,
) -> Result<(), CalibError> {
    write_json(&dir.join("mtf.json"), &MtfDocument::new(curves, details)?)?;
    let mut md =
        String::from("# MTF\n\n| method | MTF50 (cy/px) | MTF10 (cy/px) |\n|---|---|---|\n");
    for c in curves {
        let _ = writeln!(
            md,
            "| {} | {} | {} |",
            c.method,
            opt(c.mtf50, 4),
            opt(c.mtf10, 4)
        );
    }
    let _ = writeln!(md, "\n![MTF](mtf.png)");
    write_text(&dir.join("mtf.md"), &md)?;
    let series: Vec<Series> = curves
        .iter()
        .map(|c| {
            Series::new(
                &c.method,
                c.frequencies_cy_per_px
                    .iter()
                    .copied()
                    .zip(c.mtf.iter().copied())
                    .collect(),
                Mark::LinePoints,
            )
        })
        .collect();
    xy_plot(
        &dir.join("mtf.png"),
        "MTF",
        "spatial frequency (cycles/pixel)",
        "MTF",
        &series,
    )
}

/// `agc.json`, `agc.md`, `agc_step.png`, `agc_hysteresis.png`.
pub fn write_agc_report(dir: &Path, r: &AgcReport) -> Result<(), CalibError> {
    write_json(&dir.join("agc.json"), r)?;
    write_text(&dir.join("agc.md"), &agc_markdown(r))?;
    write_agc_step_plot(dir, r)?;
    write_agc_hysteresis_plot(dir, r)
}

/// `agc.md`: settling, overshoot, hysteresis and linearity figures.
fn agc_markdown(r: &AgcReport) -> String {
    let mut md = String::from("# AGC linearisation\n\n| quantity | value |\n|---|---|\n");
    let _ = writeln!(md, "| all steps settled | {} |", r.all_settled);
    let _ = writeln!(
        md,
        "| max settling time 10–90 % (µs) | {} |",
        opt(r.max_settling_time_us, 0)
    );
    let _ = writeln!(
        md,
        "| max overshoot (%) | {} |",
        opt(r.max_overshoot_percent, 2)
    );
    let _ = writeln!(
        md,
        "| hysteresis, AGC gain (%) | {:.3} |",
        r.hysteresis_gain_percent
    );
    let _ = writeln!(
        md,
        "| hysteresis, overridden output (%) | {:.3} |",
        r.hysteresis_dn_percent
    );
    let _ = writeln!(
        md,
        "| linearity error, overridden (%) | {:.3} |",
        r.linearity_error_percent
    );
    let _ = writeln!(
        md,
        "| linearised AGC RMS error (%) | {} |",
        opt(r.linearised_rms_error_percent, 3)
    );
    let _ = writeln!(
        md,
        "| linearised AGC max error (%) | {} |",
        opt(r.linearised_max_error_percent, 3)
    );
    let _ = writeln!(
        md,
        "\n![step](agc_step.png)\n![hysteresis](agc_hysteresis.png)"
    );
    md
}

/// `agc_step.png`: radiance, AGC gain and output over the staircase, each
/// normalised to its maximum.
fn write_agc_step_plot(dir: &Path, r: &AgcReport) -> Result<(), CalibError> {
    let idx =
        |v: &[crate::agc::AgcSample], f: fn(&crate::agc::AgcSample) -> f64| -> Vec<(f64, f64)> {
            v.iter()
                .enumerate()
                .map(|(i, s)| (i as f64, f(s)))
                .collect()
        };
    let gmax = r
        .agc_series
        .iter()
        .map(|s| s.gain)
        .fold(0.0, f64::max)
        .max(1e-300);
    let dmax = r
        .agc_series
        .iter()
        .map(|s| s.mean_dn)
        .fold(0.0, f64::max)
        .max(1e-300);
    let lmax = r
        .agc_series
        .iter()
        .map(|s| s.band_radiance_w_m2_sr)
        .fold(0.0, f64::max)
        .max(1e-300);
    let norm =
        |v: Vec<(f64, f64)>, m: f64| v.into_iter().map(|(x, y)| (x, y / m)).collect::<Vec<_>>();
    xy_plot(
        &dir.join("agc_step.png"),
        "AGC staircase (normalised)",
        "frame",
        "relative value",
        &[
            Series::new(
                "radiance",
                norm(idx(&r.agc_series, |s| s.band_radiance_w_m2_sr), lmax),
                Mark::Line,
            ),
            Series::new(
                "AGC gain",
                norm(idx(&r.agc_series, |s| s.gain), gmax),
                Mark::Line,
            ),
            Series::new(
                "output DN",
                norm(idx(&r.agc_series, |s| s.mean_dn), dmax),
                Mark::Line,
            ),
        ],
    )
}

/// `agc_hysteresis.png`: the settled gain going up the staircase and down.
fn write_agc_hysteresis_plot(dir: &Path, r: &AgcReport) -> Result<(), CalibError> {
    let n = r.steps.len().div_ceil(2);
    let up: Vec<(f64, f64)> = r.steps[..n]
        .iter()
        .map(|s| (s.band_radiance_w_m2_sr, s.final_gain))
        .collect();
    let down: Vec<(f64, f64)> = r.steps[n - 1..]
        .iter()
        .map(|s| (s.band_radiance_w_m2_sr, s.final_gain))
        .collect();
    xy_plot(
        &dir.join("agc_hysteresis.png"),
        "AGC hysteresis loop",
        "band radiance (W m^-2 sr^-1)",
        "settled gain",
        &[
            Series::new("up", up, Mark::LinePoints),
            Series::new("down", down, Mark::LinePoints),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn only_regular_files_are_replaced() {
        // A FIFO, a link and a directory at the output path: refused, and
        // still what they were (a device behaves as the FIFO: not regular).
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        let target = dir.path().join("t.csv");
        std::fs::write(&target, b"mine").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let mut cases = vec![(link.clone(), "symbolic link"), (sub.clone(), "directory")];
        if made.is_ok_and(|s| s.success()) {
            cases.push((fifo.clone(), "not a regular file"));
        }
        for (p, what) in cases {
            let err = write_bytes(&p, b"new").unwrap_err().to_string();
            assert!(err.contains(what), "{}: {err}", p.display());
        }
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&target).unwrap(), b"mine");
        assert!(sub.is_dir());
        // A regular file is replaced, atomically.
        write_bytes(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }

    #[test]
    fn concurrent_writers_never_collide_or_tear() {
        // Two writers racing on one path (a fixed temporary name made them
        // truncate each other's file): every write succeeds, and the file
        // always ends whole, as one writer's bytes.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("report.md");
        let (a, b) = (vec![b'a'; 1 << 16], vec![b'b'; 1 << 16]);
        std::thread::scope(|s| {
            for bytes in [&a, &b] {
                let path = &path;
                s.spawn(move || {
                    for _ in 0..50 {
                        write_bytes(path, bytes).unwrap();
                    }
                });
            }
        });
        let got = std::fs::read(&path).unwrap();
        assert!(got == a || got == b);
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
