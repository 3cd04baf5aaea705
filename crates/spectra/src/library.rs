//! The built-in spectral library: lamps, illuminants, eye responses and
//! photocathode quantum efficiencies, each with its provenance.
//!
//! Lamp and illuminant spectra are *relative* spectral power (arbitrary
//! scale); scenes normalise them to a band-integrated value. Tables cover the
//! visible range (380–780 nm) and are extended into the near infrared, where
//! intensified cameras still see, as documented per entry:
//!
//! * Mercury and low-pressure sodium tables are sampled at 5 nm, which smears
//!   their lines over a bin. Their known lines are pulled out of the table as
//!   discrete [`EmissionLine`]s: the bins holding a line are lowered to the
//!   straight baseline between the neighbouring bins and the excess (its
//!   trapezoid area) becomes the line's integrated value, so the total
//!   integral is unchanged while the line now integrates exactly on any grid.
//! * Near-infrared lines (sodium 818.3/819.5 nm and 1138.2/1140.4 nm; mercury
//!   1014.0 and 1128.7 nm) are added with strengths *assumed* relative to the
//!   visible output (stated per entry). They are order-of-magnitude values
//!   from typical lamp spectra, not measurements: normalise to measured NIR
//!   data where the campaign depends on it.
//! * Thermal sources are extended with a Planck continuum at their colour
//!   temperature, matched to the table at 780 nm, out to 1100 nm.

use std::path::Path;
use std::sync::OnceLock;

use crate::csv::parse_csv;
use crate::error::LookupError;
use crate::radiometry::{planck_radiance_w_m2_sr_nm, uniform_grid};
use crate::spectrum::{EmissionLine, Spectrum};

/// What a library entry describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EntryKind {
    /// Relative spectral power of a lamp or standard illuminant.
    Lamp,
    /// A luminous efficiency function (dimensionless, peak 1).
    EyeResponse,
    /// Photocathode quantum efficiency (electrons per photon).
    Photocathode,
}

/// One named spectrum in the library.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LibraryEntry {
    pub name: &'static str,
    pub kind: EntryKind,
    pub description: &'static str,
    pub provenance: &'static str,
}

/// All built-in entries, in display order.
pub const ENTRIES: &[LibraryEntry] = &[
    LibraryEntry {
        name: "hps",
        kind: EntryKind::Lamp,
        description: "high-pressure sodium (HPS) street lamp",
        provenance: "NIST CQS lamp set, 380-780 nm at 5 nm; NIR assumed: 819 nm doublet = 10 %, 1138 nm doublet = 4 % of the 380-780 nm output",
    },
    LibraryEntry {
        name: "hps-cie-hp1",
        kind: EntryKind::Lamp,
        description: "CIE HP1 standard high-pressure sodium",
        provenance: "CIE 15:2004 table HP1, 380-780 nm at 5 nm; same NIR assumption as 'hps'",
    },
    LibraryEntry {
        name: "lps",
        kind: EntryKind::Lamp,
        description: "low-pressure sodium (SOX) lamp",
        provenance: "NIST CQS lamp set (a single 590 nm bin), re-expressed as the D doublet 588.995/589.592 nm (2:1); NIR assumed: 818.3/819.5 nm doublet = 15 %, 1138.2/1140.4 nm = 5 % of the D-line power",
    },
    LibraryEntry {
        name: "mercury-clear",
        kind: EntryKind::Lamp,
        description: "clear high-pressure mercury lamp (MB)",
        provenance: "NIST CQS lamp set, 380-780 nm; lines 404.66, 435.83, 546.07, 576.96/579.07 nm extracted from the 5 nm bins; NIR assumed: 1013.98 nm = 30 %, 1128.7 nm = 8 % of the 546.07 nm line",
    },
    LibraryEntry {
        name: "mercury-phosphor",
        kind: EntryKind::Lamp,
        description: "phosphor-coated (deluxe) mercury lamp (MBF)",
        provenance: "Houser et al. lamp set (H38JA-100/DX), 380-780 nm; lines extracted as for 'mercury-clear'; same NIR assumption",
    },
    LibraryEntry {
        name: "fluorescent-f11",
        kind: EntryKind::Lamp,
        description: "three-band fluorescent, CIE F11",
        provenance: "CIE 15:2004 table F11, 380-780 nm at 5 nm, kept as the standard defines it (on its 5 nm grid); NIR: mercury 1013.98 nm line assumed at 0.5 % of the visible output",
    },
    LibraryEntry {
        name: "tungsten-halogen-3200k",
        kind: EntryKind::Lamp,
        description: "tungsten-halogen lamp as a 3200 K Planckian",
        provenance: "Planck's law at 3200 K, 300-1100 nm at 5 nm",
    },
    LibraryEntry {
        name: "planck-2800k",
        kind: EntryKind::Lamp,
        description: "2800 K Planckian radiator",
        provenance: "Planck's law at 2800 K, 300-1100 nm at 5 nm",
    },
    LibraryEntry {
        name: "cie-a",
        kind: EntryKind::Lamp,
        description: "CIE standard illuminant A (2856 K)",
        provenance: "CIE 15:2004 table A, 300-780 nm at 5 nm; extended to 1100 nm by Planck at 2856 K matched at 780 nm (A is defined as that Planckian)",
    },
    LibraryEntry {
        name: "incandescent",
        kind: EntryKind::Lamp,
        description: "household incandescent lamp",
        provenance: "NIST CQS lamp set, 380-780 nm; extended to 1100 nm by a 2800 K Planckian matched at 780 nm (assumed colour temperature)",
    },
    LibraryEntry {
        name: "v-photopic",
        kind: EntryKind::EyeResponse,
        description: "CIE 1924 photopic luminous efficiency V(λ), K_m = 683 lm/W",
        provenance: "CIE 1924 table, 360-830 nm at 1 nm",
    },
    LibraryEntry {
        name: "v-scotopic",
        kind: EntryKind::EyeResponse,
        description: "CIE 1951 scotopic luminous efficiency V'(λ), K'_m = 1700 lm/W",
        provenance: "CIE 1951 table, 380-780 nm at 1 nm",
    },
    LibraryEntry {
        name: "qe-s20",
        kind: EntryKind::Photocathode,
        description: "S-20 multialkali photocathode QE",
        provenance: "tabulated for a Hamamatsu multialkali MCP-PMT, 300-950 nm at 50 nm",
    },
    LibraryEntry {
        name: "qe-s25",
        kind: EntryKind::Photocathode,
        description: "S-25 extended-red multialkali photocathode QE",
        provenance: "typical datasheet shape, approximate (±30 %), 300-950 nm at 50 nm",
    },
    LibraryEntry {
        name: "qe-gen3-gaas",
        kind: EntryKind::Photocathode,
        description: "Gen III GaAs photocathode QE",
        provenance: "typical datasheet shape, approximate (±30 %), 300-950 nm at 50 nm",
    },
    LibraryEntry {
        name: "qe-gaasp",
        kind: EntryKind::Photocathode,
        description: "GaAsP photocathode QE",
        provenance: "typical datasheet shape, approximate (±30 %), 300-950 nm at 50 nm",
    },
];

/// Table bins (nm) that hold a line group, and each line's (wavelength nm, share).
type LineGroup = (&'static [f64], &'static [(f64, f64)]);

/// Mercury's visible lines and the 5 nm bins (table wavelengths) they sit in.
const MERCURY_VISIBLE: &[LineGroup] = &[
    (&[405.0], &[(404.656, 1.0)]),
    (&[435.0], &[(435.833, 1.0)]),
    (&[545.0, 550.0], &[(546.074, 1.0)]),
    // The yellow doublet, roughly equal in high-pressure lamps.
    (&[575.0, 580.0], &[(576.96, 0.5), (579.066, 0.5)]),
];

/// The built-in spectrum called `name`.
pub fn get(name: &str) -> Option<Spectrum> {
    let s = match name {
        "hps" => with_sodium_nir(
            table(include_str!("../data/lamp_high_pressure_sodium.csv")),
            0.10,
            0.04,
        ),
        "hps-cie-hp1" => with_sodium_nir(
            table(include_str!("../data/cie_hp1_high_pressure_sodium.csv")),
            0.10,
            0.04,
        ),
        "lps" => low_pressure_sodium(),
        "mercury-clear" => mercury(table(include_str!("../data/lamp_mercury.csv"))),
        "mercury-phosphor" => mercury(table(include_str!(
            "../data/lamp_mercury_phosphor_coated.csv"
        ))),
        "fluorescent-f11" => {
            let t = table(include_str!("../data/cie_f11_fluorescent.csv"));
            let visible = t.integral();
            add_lines(t, &[(1013.98, 0.005 * visible)])
        }
        "tungsten-halogen-3200k" => planck_relative(3200.0),
        "planck-2800k" => planck_relative(2800.0),
        "cie-a" => extend_planck(
            table(include_str!("../data/cie_a_tungsten_2856k.csv")),
            2856.0,
        ),
        "incandescent" => {
            extend_planck(table(include_str!("../data/lamp_incandescent.csv")), 2800.0)
        }
        "v-photopic" => photopic_v().clone(),
        "v-scotopic" => scotopic_v().clone(),
        "qe-s20" => table(include_str!("../data/s20_multialkali.csv")),
        "qe-s25" => table(include_str!("../data/s25_extended_red.csv")),
        "qe-gen3-gaas" => table(include_str!("../data/gaas_gen3.csv")),
        "qe-gaasp" => table(include_str!("../data/gaasp.csv")),
        _ => return None,
    };
    Some(s)
}

/// A built-in name, or else a path to a CSV file (see [`crate::read_csv`]),
/// noted in `reads`.
pub fn lookup(name_or_path: &str, reads: &gloam_io::ReadLog) -> Result<Spectrum, LookupError> {
    if let Some(s) = get(name_or_path) {
        return Ok(s);
    }
    let path = Path::new(name_or_path);
    if path.exists() {
        return Ok(crate::csv::read_csv(path, reads)?);
    }
    Err(LookupError::Unknown {
        name: name_or_path.to_string(),
    })
}

/// CIE 1924 photopic V(λ) (cached).
pub fn photopic_v() -> &'static Spectrum {
    static V: OnceLock<Spectrum> = OnceLock::new();
    V.get_or_init(|| table(include_str!("../data/cie_1924_photopic_v.csv")))
}

/// CIE 1951 scotopic V'(λ) (cached).
pub fn scotopic_v() -> &'static Spectrum {
    static V: OnceLock<Spectrum> = OnceLock::new();
    V.get_or_init(|| table(include_str!("../data/cie_1951_scotopic_v.csv")))
}

/// Parses an embedded table. The tables ship with the crate and are checked by
/// the tests, so a failure here is a build defect; it degrades to an empty
/// spectrum rather than panicking.
fn table(text: &str) -> Spectrum {
    parse_csv(text, Path::new("<built-in>")).unwrap_or_default()
}

fn add_lines(s: Spectrum, lines: &[(f64, f64)]) -> Spectrum {
    let lines = lines
        .iter()
        .map(|&(wavelength_nm, value)| EmissionLine {
            wavelength_nm,
            value,
        })
        .collect();
    s.with_lines(lines).unwrap_or_default()
}

/// Moves the power in `bins_nm` above the straight baseline between their
/// outer neighbours into discrete lines (shares given per line).
fn extract_lines(s: Spectrum, bins_nm: &[f64], lines: &[(f64, f64)]) -> Spectrum {
    let w = s.wavelengths_nm().to_vec();
    let mut v = s.values().to_vec();
    let idx: Vec<usize> = bins_nm
        .iter()
        .filter_map(|b| w.iter().position(|x| (x - b).abs() < 1e-9))
        .collect();
    let (Some(&first), Some(&last)) = (idx.first(), idx.last()) else {
        return s;
    };
    if first == 0 || last + 1 >= w.len() {
        return s;
    }
    let (x0, y0, x1, y1) = (w[first - 1], v[first - 1], w[last + 1], v[last + 1]);
    let mut excess_area = 0.0;
    for &i in &idx {
        let baseline = y0 + (w[i] - x0) / (x1 - x0) * (y1 - y0);
        let excess = (v[i] - baseline).max(0.0);
        // A node's hat function spans half a bin either side: area = excess × mean spacing.
        excess_area += excess * 0.5 * (w[i + 1] - w[i - 1]);
        v[i] -= excess;
    }
    let continuum = Spectrum::new(w, v).unwrap_or_default();
    let new_lines: Vec<(f64, f64)> = lines
        .iter()
        .map(|&(wl, share)| (wl, share * excess_area))
        .collect();
    add_lines(
        continuum.with_lines(s.lines().to_vec()).unwrap_or_default(),
        &new_lines,
    )
}

fn mercury(t: Spectrum) -> Spectrum {
    let mut s = t;
    for (bins, lines) in MERCURY_VISIBLE {
        s = extract_lines(s, bins, lines);
    }
    let green = s
        .lines()
        .iter()
        .find(|l| (l.wavelength_nm - 546.074).abs() < 1e-6)
        .map_or(0.0, |l| l.value);
    add_lines(s, &[(1013.98, 0.30 * green), (1128.7, 0.08 * green)])
}

fn low_pressure_sodium() -> Spectrum {
    let t = table(include_str!("../data/lamp_low_pressure_sodium.csv"));
    let d_power = t.integral();
    // The whole table is the 590 nm bin: replace it by the D doublet.
    let continuum = t.map_all(|_, _| 0.0);
    add_lines(
        continuum,
        &[
            (588.995, d_power * 2.0 / 3.0),
            (589.592, d_power / 3.0),
            (818.326, 0.15 * d_power * 0.5),
            (819.482, 0.15 * d_power * 0.5),
            (1138.15, 0.05 * d_power * 0.5),
            (1140.38, 0.05 * d_power * 0.5),
        ],
    )
}

fn with_sodium_nir(t: Spectrum, frac_819: f64, frac_1138: f64) -> Spectrum {
    let visible = t.integral();
    add_lines(
        t,
        &[
            (818.326, frac_819 * visible * 0.5),
            (819.482, frac_819 * visible * 0.5),
            (1138.15, frac_1138 * visible * 0.5),
            (1140.38, frac_1138 * visible * 0.5),
        ],
    )
}

/// A Planckian normalised to 1 at 560 nm, 300–1100 nm at 5 nm.
fn planck_relative(temperature_k: f64) -> Spectrum {
    let grid = uniform_grid(300.0, 1100.0, 5.0);
    let norm = planck_radiance_w_m2_sr_nm(560.0, temperature_k);
    let values = grid
        .iter()
        .map(|&w| planck_radiance_w_m2_sr_nm(w, temperature_k) / norm)
        .collect();
    Spectrum::new(grid, values).unwrap_or_default()
}

/// Appends a Planck continuum at `temperature_k`, scaled to the table's last
/// node, every 5 nm out to 1100 nm.
fn extend_planck(t: Spectrum, temperature_k: f64) -> Spectrum {
    let (Some(&last_w), Some(&last_v)) = (t.wavelengths_nm().last(), t.values().last()) else {
        return t;
    };
    let scale = last_v / planck_radiance_w_m2_sr_nm(last_w, temperature_k);
    let mut w = t.wavelengths_nm().to_vec();
    let mut v = t.values().to_vec();
    for x in uniform_grid(last_w, 1100.0, 5.0).into_iter().skip(1) {
        w.push(x);
        v.push(scale * planck_radiance_w_m2_sr_nm(x, temperature_k));
    }
    Spectrum::new(w, v)
        .and_then(|s| s.with_lines(t.lines().to_vec()))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn every_entry_loads_non_empty() {
        for e in ENTRIES {
            let s = get(e.name).unwrap_or_else(|| panic!("{} missing", e.name));
            assert!(s.integral() > 0.0, "{} integrates to zero", e.name);
        }
        assert!(get("no-such-lamp").is_none());
    }

    #[test]
    fn line_extraction_conserves_visible_power() {
        let raw = table(include_str!("../data/lamp_mercury.csv"));
        let s = get("mercury-clear").unwrap();
        // Visible output is unchanged by moving bin excess into lines.
        assert_relative_eq!(
            s.integrate_band(380.0, 781.0),
            raw.integral(),
            max_relative = 1e-12
        );
        let green = s
            .lines()
            .iter()
            .find(|l| (l.wavelength_nm - 546.074).abs() < 1e-6)
            .unwrap();
        assert!(green.value > 0.0);
        // The green line is the strongest visible feature of a clear mercury lamp.
        assert!(
            s.lines()
                .iter()
                .filter(|l| l.wavelength_nm < 780.0)
                .all(|l| l.value <= green.value * 1.5)
        );
    }

    #[test]
    fn mercury_green_line_integrates_exactly_on_any_grid() {
        let s = get("mercury-clear").unwrap();
        let green = s
            .lines()
            .iter()
            .find(|l| (l.wavelength_nm - 546.074).abs() < 1e-6)
            .unwrap()
            .value;
        // A narrow band around the line holds the line plus a sliver of continuum.
        let narrow = s.integrate_band(546.0, 546.2);
        assert!(narrow >= green && narrow < green * 1.01);
        // Resampling the continuum coarsely never moves the line.
        let coarse = s.resampled(&uniform_grid(380.0, 780.0, 20.0)).unwrap();
        let line_in = |sp: &Spectrum| {
            sp.lines()
                .iter()
                .filter(|l| l.wavelength_nm >= 540.0 && l.wavelength_nm < 550.0)
                .map(|l| l.value)
                .sum::<f64>()
        };
        assert_eq!(line_in(&coarse), line_in(&s));
    }

    #[test]
    fn lamps_reach_the_near_infrared() {
        for name in [
            "hps",
            "lps",
            "mercury-clear",
            "mercury-phosphor",
            "cie-a",
            "incandescent",
            "tungsten-halogen-3200k",
        ] {
            let s = get(name).unwrap();
            assert!(s.integrate_band(800.0, 1200.0) > 0.0, "{name} has no NIR");
        }
    }

    #[test]
    fn cie_a_extension_follows_planck() {
        let a = get("cie-a").unwrap();
        // Continuity at 780 nm and the Planck ratio at 900/780 nm.
        let ratio = a.eval(900.0) / a.eval(780.0);
        let exact =
            planck_radiance_w_m2_sr_nm(900.0, 2856.0) / planck_radiance_w_m2_sr_nm(780.0, 2856.0);
        assert_relative_eq!(ratio, exact, max_relative = 1e-12);
        // The CIE table itself is Planck at 2856 K (normalised to 100 at 560 nm):
        let table_ratio = a.eval(700.0) / a.eval(560.0);
        let planck_ratio =
            planck_radiance_w_m2_sr_nm(700.0, 2856.0) / planck_radiance_w_m2_sr_nm(560.0, 2856.0);
        assert_relative_eq!(table_ratio, planck_ratio, max_relative = 2e-3);
    }

    #[test]
    fn equal_energy_spectrum_has_published_v_integral() {
        // ∫ V(λ) dλ over the CIE 1924 table is 106.86 nm (published sum of
        // the 1 nm table), so 1 W/nm flat gives 683 × 106.86 lm.
        let flat = Spectrum::constant(300.0, 900.0, 1.0).unwrap();
        let lm = crate::photopic(&flat);
        assert_relative_eq!(lm / 683.0, 106.86, max_relative = 1e-3);
    }

    #[test]
    fn lookup_falls_back_to_files_and_reports_unknown() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.csv");
        std::fs::write(&p, "400,1\n500,1\n").unwrap();
        let log = gloam_io::ReadLog::new();
        assert_eq!(lookup(p.to_str().unwrap(), &log).unwrap().integral(), 100.0);
        assert_eq!(log.reads().len(), 1);
        let e = lookup("nope", &log).unwrap_err().to_string();
        assert!(e.contains("unknown spectrum 'nope'"), "{e}");
    }
}
