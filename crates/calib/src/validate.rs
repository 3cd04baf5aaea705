//! Validation metrics: Spearman rank correlation and RMS radiance difference
//! over ground-control regions, and the no-imaging sanity check.

use gloam_spectra::Spectrum;
use serde::{Deserialize, Serialize};

use crate::error::CalibError;
use crate::stats::{rms_difference, spearman_rho};

/// A rectangular ground-control region, pixel coordinates (x = column).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    #[serde(default)]
    pub name: String,
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

/// Reads ground-control regions: a JSON array of
/// `{"name", "x", "y", "width", "height"}` objects (`.json`), or TOML with
/// `[[region]]` tables of the same keys (any other extension); `reads`
/// notes the file.
pub fn load_regions(
    path: &std::path::Path,
    reads: &gloam_io::ReadLog,
) -> Result<Vec<Region>, CalibError> {
    let text = gloam_io::read_text(path, gloam_io::MAX_TEXT_FILE_BYTES, reads)
        .map_err(|e| CalibError::file(path, e))?;
    let is_json = path.extension().and_then(|e| e.to_str()) == Some("json");
    let regions: Vec<Region> = if is_json {
        // A BOM, as an editor may save one: taken, as TOML and CSV take it
        // (it was "expected value at line 1 column 1").
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        serde_json::from_str(text).map_err(|e| CalibError::file(path, e))?
    } else {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct File {
            region: Vec<Region>,
        }
        toml::from_str::<File>(&text)
            .map_err(|e| CalibError::toml(path.display(), &text, &e))?
            .region
    };
    check_distinct(&regions).map_err(|e| CalibError::file(path, e))?;
    Ok(regions)
}

/// The comparison's figures (the `gloam compare --json` contract).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    pub spearman_rho: f64,
    pub rms: f64,
    pub regions: Vec<RegionValues>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegionValues {
    pub name: String,
    pub truth: f64,
    pub synthetic: f64,
}

/// The most pixels a comparison sums over all its regions (2³⁰, about a
/// second): 10⁵ regions of half a 2048 × 2048 image ran for hours.
pub const MAX_REGION_PIXELS: u64 = 1 << 30;

/// Refuses a region that is empty or leaves the `w × h` image.
fn check_inside(w: usize, h: usize, r: &Region) -> Result<(), CalibError> {
    // Checked sums: a region at x = usize::MAX must not wrap (or panic).
    let inside = |o: usize, n: usize, lim: usize| o.checked_add(n).is_some_and(|e| e <= lim);
    if r.width == 0 || r.height == 0 || !inside(r.x, r.width, w) || !inside(r.y, r.height, h) {
        return Err(CalibError::Invalid(format!(
            "region '{}' ({}+{}, {}+{}) is empty or leaves the {w}×{h} image",
            r.name, r.x, r.width, r.y, r.height
        )));
    }
    Ok(())
}

/// Refuses regions that would be ranked twice: a name or a rectangle
/// given twice (both were taken, the rectangle then counting twice in the
/// rank correlation).
fn check_distinct(regions: &[Region]) -> Result<(), String> {
    let mut names = std::collections::HashMap::new();
    let mut rects = std::collections::HashMap::new();
    for (i, r) in regions.iter().enumerate() {
        if !r.name.is_empty() {
            if let Some(first) = names.insert(r.name.as_str(), i) {
                return Err(format!(
                    "regions {} and {} are both named '{}'",
                    first + 1,
                    i + 1,
                    r.name
                ));
            }
        }
        if let Some(first) = rects.insert((r.x, r.y, r.width, r.height), i) {
            return Err(format!(
                "regions {} and {} are the same rectangle ({}+{}, {}+{}): it would count twice in the rank correlation",
                first + 1,
                i + 1,
                r.x,
                r.width,
                r.y,
                r.height
            ));
        }
    }
    Ok(())
}

/// Refuses regions given twice ([`check_distinct`]) or outside the image,
/// and regions whose pixels add up past [`MAX_REGION_PIXELS`], before any
/// is summed.
fn check_regions(w: usize, h: usize, regions: &[Region]) -> Result<(), CalibError> {
    check_distinct(regions).map_err(CalibError::Invalid)?;
    let mut pixels = 0u64;
    for r in regions {
        check_inside(w, h, r)?;
        // Inside the image, so the area is at most w × h.
        pixels = pixels.saturating_add((r.width * r.height) as u64);
    }
    if pixels > MAX_REGION_PIXELS {
        return Err(CalibError::Invalid(format!(
            "the {} regions cover {pixels} pixels in all: at most {MAX_REGION_PIXELS} (2^30) are summed",
            regions.len()
        )));
    }
    Ok(())
}

/// Mean of a region of a row-major `w × h` image, ignoring NaN pixels.
pub fn region_mean(img: &[f64], w: usize, h: usize, r: &Region) -> Result<f64, CalibError> {
    check_inside(w, h, r)?;
    let (mut s, mut n) = (0.0, 0usize);
    for row in r.y..r.y + r.height {
        for v in &img[row * w + r.x..row * w + r.x + r.width] {
            if v.is_finite() {
                s += v;
                n += 1;
            }
        }
    }
    if n == 0 {
        return Err(CalibError::InsufficientData(format!(
            "region '{}' holds no finite pixel",
            r.name
        )));
    }
    Ok(s / n as f64)
}

/// `e` said of one of the two images compared, and of region `r`'s
/// rectangle.
fn in_image(e: CalibError, image: &str, r: &Region) -> CalibError {
    match e {
        CalibError::InsufficientData(m) => CalibError::InsufficientData(format!(
            "{image}: {m} (x {}, width {}, y {}, height {})",
            r.x, r.width, r.y, r.height
        )),
        e => e,
    }
}

/// Compares two equally sized images over regions: Spearman ρ of the region
/// means (ties get average ranks) and the RMS of their differences.
pub fn compare_images(
    truth: &[f64],
    synthetic: &[f64],
    w: usize,
    h: usize,
    regions: &[Region],
) -> Result<Comparison, CalibError> {
    if truth.len() != w * h || synthetic.len() != w * h {
        return Err(CalibError::Invalid("the two images differ in size".into()));
    }
    if regions.len() < 2 {
        return Err(CalibError::InsufficientData(
            "rank correlation needs at least 2 regions".into(),
        ));
    }
    check_regions(w, h, regions)?;
    let mut rv = Vec::new();
    for (i, r) in regions.iter().enumerate() {
        rv.push(RegionValues {
            name: if r.name.is_empty() {
                format!("region {}", i + 1)
            } else {
                r.name.clone()
            },
            // Which image and where: "region 'd' holds no finite pixel"
            // did not say which of the two.
            truth: region_mean(truth, w, h, r).map_err(|e| in_image(e, "the truth image", r))?,
            synthetic: region_mean(synthetic, w, h, r)
                .map_err(|e| in_image(e, "the synthetic image", r))?,
        });
    }
    let t: Vec<f64> = rv.iter().map(|r| r.truth).collect();
    let s: Vec<f64> = rv.iter().map(|r| r.synthetic).collect();
    Ok(Comparison {
        spearman_rho: spearman_rho(&t, &s)?,
        rms: rms_difference(&t, &s)?,
        regions: rv,
    })
}

/// No-imaging sanity check: the radiance of a Lambertian panel of spectral
/// reflectance `R(λ)` lit by a lamp of spectral intensity `I(λ)`
/// (W sr⁻¹ nm⁻¹) at distance `r_m` and incidence `theta_deg`:
/// `L = cos θ / (π r²) ∫ I(λ) R(λ) dλ` over `band_nm`, W m⁻² sr⁻¹.
pub fn panel_radiance_no_imaging(
    intensity_w_sr_nm: &Spectrum,
    reflectance: &Spectrum,
    r_m: f64,
    theta_deg: f64,
    band_nm: (f64, f64),
) -> Result<f64, CalibError> {
    if !(r_m > 0.0 && r_m.is_finite() && theta_deg.is_finite()) {
        return Err(CalibError::Invalid(format!(
            "distance {r_m} m must be positive and the angle finite"
        )));
    }
    let c = theta_deg.to_radians().cos().max(0.0);
    let i = intensity_w_sr_nm
        .product(reflectance)
        .integrate_band(band_nm.0, band_nm.1);
    Ok(c / (std::f64::consts::PI * r_m * r_m) * i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_imaging_flat_spectra() {
        let i = Spectrum::constant(400.0, 700.0, 0.01).unwrap();
        let r = Spectrum::constant(300.0, 1100.0, 0.5).unwrap();
        let l = panel_radiance_no_imaging(&i, &r, 2.0, 60.0, (400.0, 700.0)).unwrap();
        let want = 0.5 / (std::f64::consts::PI * 4.0) * (0.01 * 300.0 * 0.5);
        assert!((l - want).abs() < 1e-12 * want);
        assert_eq!(
            panel_radiance_no_imaging(&i, &r, 2.0, 120.0, (400.0, 700.0)).unwrap(),
            0.0
        );
    }

    /// Regions are bounded by the pixels they add up to, before any sum:
    /// 2 049 distinct rectangles of a quarter of a 2048 × 1024 image is 2^30 + 2^19
    /// pixels (refused); 2 048 of them is 2^30 (taken).
    #[test]
    fn regions_are_bounded_by_their_pixels() {
        let (w, h) = (2048, 1024);
        let rect = |i: usize| Region {
            name: format!("r{i}"),
            x: i % 1024,
            y: i / 1024,
            width: 1024,
            height: 512,
        };
        let many: Vec<Region> = (0..2049).map(rect).collect();
        let e = check_regions(w, h, &many).unwrap_err().to_string();
        assert!(
            e.ends_with("the 2049 regions cover 1074266112 pixels in all: at most 1073741824 (2^30) are summed"),
            "{e}"
        );
        check_regions(w, h, &many[..2048]).unwrap();
    }

    #[test]
    fn compare_with_ties() {
        // 5 regions of 1 pixel each along a 5×1 image: the scipy example.
        let t = [1.0, 2.0, 3.0, 4.0, 5.0];
        let s = [5.0, 6.0, 7.0, 8.0, 7.0];
        let regions: Vec<Region> = (0..5)
            .map(|x| Region {
                name: String::new(),
                x,
                y: 0,
                width: 1,
                height: 1,
            })
            .collect();
        let c = compare_images(&t, &s, 5, 1, &regions).unwrap();
        assert!((c.spearman_rho - 0.820_782_681_668_123_3).abs() < 1e-12);
        assert!((c.rms - (16.0f64 * 4.0 + 4.0).sqrt() / 5f64.sqrt()).abs() < 1e-12);
        // Round 12 of issue 46: a region with no finite pixel names the
        // image that has none, and the region's rectangle.
        let mut nan = s;
        nan[4] = f64::NAN;
        let e = compare_images(&t, &nan, 5, 1, &regions)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("the synthetic image: region '' holds no finite pixel (x 4, width 1"),
            "{e}"
        );
    }
}
