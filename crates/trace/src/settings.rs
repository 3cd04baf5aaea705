//! Render settings: every approximation is a named setting with a default.
//!
//! | key | default | meaning |
//! |---|---|---|
//! | `spp` | 4 | camera samples per pixel (placed in the pixel as `pixel_strata` says: a Sobol net by default); a whole-image `gloam render` given neither `spp` nor `target_error` samples to `target_error` 0.02 instead (`gloam_pipeline::render::SettingArgs::with_default_error`) |
//! | `seed` | 0 | seed of every random stream (per pixel: `(seed, pixel index)`) |
//! | `estimator` | `analytic` | area-source estimator: `analytic`, `solid-angle`, `dirsig2001` |
//! | `recursion` | 3 | 1 = direct lighting only, 2 = one specular bounce, … |
//! | `diffuse_bounces` | 0 | diffuse path-tracing bounces (0 = off) |
//! | `rr_start` | 1 | diffuse bounces before Russian roulette starts |
//! | `spectral_step_nm` | 5 | continuum grid step within the bands' support |
//! | `area_samples` | 4 | shadow rays per area source per hit (`analytic`, `solid-angle`); 4 rather than 16 since the pixel's many samples stratify penumbrae anyway (office, 64 spp: per-pixel error 1.09 % vs 1.05 % at 44 % fewer rays) |
//! | `occlusion` | `cv` | `analytic` occlusion correction: `cv` (control variate: exact when every shadow ray is clear, exactly 0 when every one is blocked, unbiased otherwise; sum clamped ≥ 0) or `ratio` (self-normalised: exact at full visibility *and* full occlusion, O(1/N) bias in penumbra) |
//! | `source_roulette_fraction` | 0.01 | `analytic`: a source whose closed-form irradiance is below this fraction of the total at the hit point gets proportionally fewer shadow rays, `⌈area_samples · share / fraction⌉ ≥ 1` (every count gives an unbiased correction, and umbra stays exactly 0) |
//! | `light_tree_min_lights` | 64 | scenes with at most this many emitters (area + point sources) evaluate every emitter at every vertex, exactly as before the light tree; above it a light tree picks emitters per vertex by importance (`light_tree_split`), each weighted by 1/probability (unbiased; cost per vertex bounded) |
//! | `light_tree_split` | `adaptive` | light tree: `adaptive` (Conty & Kulla 2018: a node whose importance is uncertain from the vertex is split, both children visited, else one child is sampled by importance and the test repeats below it; at most `light_tree_max_picks` emitters) or `fixed` (before issue 44: `light_tree_branches` subtrees, one emitter from each). `gloam bench scale` lamps 1 000, 80 × 60 px, spp 4: per-pixel error 16.2 % (fixed, 16 picks) → 0.54 % (fixed, 64) → 0.11 % (adaptive, 64 at most) at 31 / 100 / 107 shadow rays per sample |
//! | `light_split_threshold` | 0.2 | adaptive splitting: split a node when its relative importance uncertainty `1 − I_min/I_max` (bounds over its box and emission cone) exceeds this; 0 splits as far as the cap allows, 1 never (one emitter per vertex). Lamps 1 000 at 64 picks: 0.5 → 0.71 %, 0.2 → 0.11 % |
//! | `light_tree_max_picks` | 64 | adaptive splitting: most emitters reached per vertex (the most uncertain nodes are split first). Lamps 1 000: 16 → 13.6 %, 32 → 2.5 %, 48 → 0.30 %, 64 → 0.11 %, 128 → 0.06 % |
//! | `light_tree_branches` | 16 | `light_tree_split = fixed`: subtrees a vertex's selection splits into, one emitter from each (more: less noise, more shadow rays) |
//! | `sky_samples` | 16 | cosine-weighted sky-dome shadow rays per hit point (scenes with a `[sky]` block) |
//! | `resolution_scale` | 1 | multiplies the camera's width and height (rounded, ≥ 1 pixel); the field of view is kept |
//! | `light_strata` | sobol | camera-vertex light samples: `sobol` (one Owen-scrambled Sobol sequence per pixel and source, stratified across the pixel's samples: office, direct light only, 16 spp: per-pixel error 2.61 % → 0.92 % against the path-traced reference; whole light 0.98 % → 0.91 %) or `random` (an independent Latin-hypercube set per sample, the default before issue 30) |
//! | `pixel_strata` | sobol | positions in the pixel: `sobol` (one shuffled Owen-scrambled Sobol sequence per pixel, continued across the adaptive rounds, `sampler.rs`; office, direct light only, to 1 %: 8.5 vs 9.5 spp at the same achieved error against a 1 024-spp reference) or `latin` (a Latin hypercube per batch of samples, the default until 7 December 2026) |
//! | `path_guide` | true | `indirect = path`: a share of each diffuse bounce aims at the few facets lit far above the rest (a lamp's own housing), weighted by the mixture's density so the estimate stays unbiased (`guide.rs`; night-full-moon-lamps, one eighth size, 64 spp: noise of the lower sixths' sums 1.2–3.4 % → 0.3–0.5 %) |
//! | `all_effects` | false | run every estimator path even where the effect plan says it is not needed (for timing the plan's savings; the image agrees within noise) |
//! | `drop` | (none) | comma-separated effects left out of the render, to measure what each is worth (`gloam bench plan`): `area-sources`, `point-sources`, `shaped-point-sources`, `moon`, `night-sky`, `direct-view`, `specular-recursion`, `transmissive-occluders` (they become opaque), `interreflection`; `none` clears |
//! | `SAMPLE_AREA_DENSITY` | 1 | `dirsig2001`: sample points per scene unit² of source |
//! | `MAX_SAMPLE_POINTS` | 500 | `dirsig2001`: cap on points per source |
//! | `MAX_SOURCE_SAMPLES` | 100 | `dirsig2001`: cap on shadow rays per source per hit |
//! | `SOLID_ANGLE_THRESHOLD` | 1e-6 sr | `dirsig2001`: skip sources subtending less |
//! | `SOLID_ANGLE_DENSITY` | 1e3 /sr | `dirsig2001`: shadow rays per steradian |
//! | `IRRADIANCE_THRESHOLD` | 1e-10 W/m² | `dirsig2001`: skip sources whose unoccluded estimate is below |
//!
//! `threads` (not a `--set` key) picks the rayon pool size; results do not
//! depend on it.

use serde::Serialize;

use crate::lights::Term;

/// Most camera samples per pixel (`spp`): 65 536 already takes a
/// 32 × 24 image past an hour on a laptop.
pub const MAX_SPP: u32 = 65536;

/// How extended (area) sources are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Estimator {
    /// Closed-form unoccluded irradiance + shadow-ray occlusion correction.
    Analytic,
    /// Uniform solid-angle sampling (spherical triangles / rectangles).
    SolidAngle,
    /// The published 2001 DIRSIG method, for comparison.
    Dirsig2001,
}

impl std::str::FromStr for Estimator {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('_', "-").as_str() {
            "analytic" => Ok(Self::Analytic),
            "solid-angle" => Ok(Self::SolidAngle),
            "dirsig2001" | "dirsig-2001" => Ok(Self::Dirsig2001),
            _ => Err(SettingsError::BadValue {
                key: "estimator".into(),
                value: s.into(),
                expected: "analytic, solid-angle or dirsig2001",
            }),
        }
    }
}

impl std::fmt::Display for Estimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Analytic => "analytic",
            Self::SolidAngle => "solid-angle",
            Self::Dirsig2001 => "dirsig2001",
        })
    }
}

/// How diffuse interreflection is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Indirect {
    /// The effect plan decides: the radiosity cache when the pilot's
    /// estimated share of interreflection exceeds `tolerance`, otherwise
    /// off; an explicit `diffuse_bounces > 0` selects `path`.
    Auto,
    /// Direct light only (the first wave's default).
    Off,
    /// Radiosity cache + final gather (see [`crate::indirect`]).
    Cache,
    /// Brute-force path tracing to `diffuse_bounces` (chosen by the plan
    /// when 0): the reference method.
    Path,
}

impl std::str::FromStr for Indirect {
    type Err = SettingsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "off" | "none" => Ok(Self::Off),
            "cache" | "radiosity" => Ok(Self::Cache),
            "path" | "path-tracing" => Ok(Self::Path),
            _ => Err(SettingsError::BadValue {
                key: "indirect".into(),
                value: s.into(),
                expected: "auto, off, cache or path",
            }),
        }
    }
}

/// How the light tree splits at a shading point (`light_tree_split`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightTreeSplit {
    /// Split by each node's importance uncertainty, up to
    /// `light_tree_max_picks` emitters (Conty & Kulla 2018).
    Adaptive,
    /// `light_tree_branches` subtrees, one emitter from each (before
    /// issue 44).
    Fixed,
}

/// Occlusion correction used by the analytic estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Occlusion {
    /// `E = E_closed + (MC_occluded − MC_unoccluded)`, same samples.
    Cv,
    /// `E = E_closed · MC_occluded / MC_unoccluded`.
    Ratio,
}

/// The six settings of the 2001 method, with the published defaults.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[allow(non_snake_case)]
pub struct Dirsig2001Settings {
    pub SAMPLE_AREA_DENSITY: f64,
    pub MAX_SAMPLE_POINTS: u32,
    pub MAX_SOURCE_SAMPLES: u32,
    pub SOLID_ANGLE_THRESHOLD: f64,
    pub SOLID_ANGLE_DENSITY: f64,
    pub IRRADIANCE_THRESHOLD: f64,
}

impl Default for Dirsig2001Settings {
    fn default() -> Self {
        Self {
            SAMPLE_AREA_DENSITY: 1.0,
            MAX_SAMPLE_POINTS: 500,
            MAX_SOURCE_SAMPLES: 100,
            SOLID_ANGLE_THRESHOLD: 1e-6,
            SOLID_ANGLE_DENSITY: 1e3,
            IRRADIANCE_THRESHOLD: 1e-10,
        }
    }
}

/// Effects a render leaves out on purpose (`--set drop=a,b`): the plan's
/// decisions are checked by dropping each kept effect and measuring the
/// change (`gloam bench plan`). The light terms are kept by [`Term`], so a
/// new term is droppable by its name without a field here.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dropped {
    /// Per light term, by its number.
    lights: [bool; Term::COUNT],
    pub direct_view: bool,
    pub specular_recursion: bool,
    pub transmissive_occluders: bool,
    pub interreflection: bool,
}

/// The effects `drop` knows besides the light terms, in JSON order.
const OTHER_EFFECTS: [(&str, &str); 4] = [
    ("direct-view", "direct_view"),
    ("specular-recursion", "specular_recursion"),
    ("transmissive-occluders", "transmissive_occluders"),
    ("interreflection", "interreflection"),
];

impl Dropped {
    /// The effect names `drop` accepts (the effect plan's names): the
    /// light terms, then the others.
    pub const NAMES: [&'static str; Term::COUNT + OTHER_EFFECTS.len()] = {
        let mut names = [""; Term::COUNT + OTHER_EFFECTS.len()];
        let mut i = 0;
        while i < names.len() {
            names[i] = if i < Term::COUNT {
                Term::ALL[i].name()
            } else {
                OTHER_EFFECTS[i - Term::COUNT].0
            };
            i += 1;
        }
        names
    };

    /// The flag for effect `name`, if `drop` knows it.
    fn flag(&mut self, name: &str) -> Option<&mut bool> {
        if let Some(t) = Term::by_name(name) {
            return Some(&mut self.lights[t as usize]);
        }
        Some(match name {
            "direct-view" => &mut self.direct_view,
            "specular-recursion" => &mut self.specular_recursion,
            "transmissive-occluders" => &mut self.transmissive_occluders,
            "interreflection" => &mut self.interreflection,
            _ => return None,
        })
    }

    /// Whether light term `t` is left out.
    pub(crate) fn light(&self, t: Term) -> bool {
        self.lights[t as usize]
    }

    /// Parses `a,b,c` (or `none`).
    pub fn parse(value: &str) -> Result<Self, SettingsError> {
        let mut d = Self::default();
        if value.trim().eq_ignore_ascii_case("none") || value.trim().is_empty() {
            return Ok(d);
        }
        for name in value.split(',') {
            let n = name.trim().to_ascii_lowercase().replace('_', "-");
            match d.flag(&n) {
                Some(f) => *f = true,
                None => {
                    return Err(SettingsError::BadValue {
                        key: "drop".into(),
                        value: name.trim().into(),
                        expected: "effect names: area-sources, point-sources, shaped-point-sources, moon, night-sky, distant-sources, sun, twilight-sky, direct-view, specular-recursion, transmissive-occluders, interreflection (or none)",
                    });
                }
            }
        }
        Ok(d)
    }

    /// Marks effect `name` (one of [`Dropped::NAMES`]) as left out.
    pub(crate) fn set(&mut self, name: &str) {
        if let Some(f) = self.flag(name) {
            *f = true;
        }
    }

    /// Whether effect `name` is dropped.
    pub fn has(&self, name: &str) -> bool {
        let mut c = *self;
        c.flag(name).is_some_and(|f| *f)
    }

    /// The dropped names, comma-separated (`none` when empty).
    pub fn names(&self) -> String {
        let v: Vec<&str> = Self::NAMES
            .iter()
            .copied()
            .filter(|n| self.has(n))
            .collect();
        if v.is_empty() {
            "none".into()
        } else {
            v.join(",")
        }
    }
}

/// As before terms were data: one boolean per effect name, in snake case.
impl Serialize for Dropped {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("Dropped", Self::NAMES.len())?;
        for t in Term::ALL {
            st.serialize_field(t.key(), &self.light(t))?;
        }
        let others = [
            self.direct_view,
            self.specular_recursion,
            self.transmissive_occluders,
            self.interreflection,
        ];
        for ((_, key), v) in OTHER_EFFECTS.iter().zip(others) {
            st.serialize_field(key, &v)?;
        }
        st.end()
    }
}

/// Everything a render or probe needs besides the scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RenderSettings {
    pub spp: u32,
    pub seed: u64,
    pub estimator: Estimator,
    /// Rayon threads (None: rayon's default). Never changes the result.
    pub threads: Option<usize>,
    pub recursion: u32,
    pub diffuse_bounces: u32,
    pub rr_start: u32,
    pub spectral_step_nm: f64,
    pub area_samples: u32,
    pub occlusion: Occlusion,
    pub source_roulette_fraction: f64,
    pub dirsig2001: Dirsig2001Settings,
    /// At most this many emitters: every emitter at every vertex (the
    /// exhaustive path); more: the light tree.
    pub light_tree_min_lights: u32,
    /// Light tree: emitters picked per vertex (subtrees split into) under
    /// `light_tree_split = fixed`.
    pub light_tree_branches: u32,
    /// Light tree: adaptive splitting (Conty & Kulla 2018) or the fixed
    /// number of picks before issue 44.
    pub light_tree_split: LightTreeSplit,
    /// Adaptive splitting: a node is split when its relative importance
    /// uncertainty `1 − I_min/I_max` exceeds this (0: split as far as
    /// `light_tree_max_picks` allows; 1: never, one emitter per vertex).
    pub light_split_threshold: f64,
    /// Adaptive splitting: most emitters reached per vertex.
    pub light_tree_max_picks: u32,
    /// Cosine-weighted sky-dome samples (shadow rays) per hit point.
    pub sky_samples: u32,
    /// Scale factor on the camera resolution (1 = the scene's).
    pub resolution_scale: f64,
    /// Compute every effect, planned or not (benchmarking the plan).
    pub all_effects: bool,
    /// Path tracing: guide a share of the diffuse bounces toward hot
    /// facets (`guide.rs`).
    pub path_guide: bool,
    /// Light samples at the camera vertex drawn from one scrambled Sobol
    /// sequence per pixel and source, stratified across the pixel's
    /// samples (`sobol`), or independently per sample (`random`).
    pub light_strata: LightStrataMode,
    /// Positions in the pixel (see `pixel_strata`).
    pub pixel_strata: PixelStrata,
    /// Effects left out on purpose (measuring what each is worth).
    pub drop: Dropped,
    /// Diffuse interreflection method.
    pub indirect: Indirect,
    /// Texel budget of the radiosity cache (both sides of every facet).
    pub cache_texels: u32,
    /// Gather rays per cache texel (the operator's estimate).
    pub cache_rays: u32,
    /// Stop the cache's bounce iteration when the estimated remainder is
    /// below this fraction of the reflected light (the geometric tail is
    /// then added).
    pub cache_tolerance: f64,
    /// Final-gather rays per camera sample reading the cache (0: read the
    /// cached indirect irradiance by bilinear interpolation).
    pub gather_rays: u32,
    /// The effect plan's tolerance: an effect whose estimated share of the
    /// band signal at the camera is below this is not simulated.
    pub tolerance: f64,
    /// Adaptive sampling: stop a pixel when its estimated relative standard
    /// error is below this (None: fixed `spp`).
    pub target_error: Option<f64>,
    /// Adaptive sampling: the most camera samples any pixel gets.
    pub max_spp: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            spp: 4,
            seed: 0,
            estimator: Estimator::Analytic,
            threads: None,
            recursion: 3,
            diffuse_bounces: 0,
            rr_start: 1,
            spectral_step_nm: 5.0,
            area_samples: 4,
            occlusion: Occlusion::Cv,
            source_roulette_fraction: 0.01,
            dirsig2001: Dirsig2001Settings::default(),
            light_tree_min_lights: 64,
            light_tree_branches: 16,
            light_tree_split: LightTreeSplit::Adaptive,
            light_split_threshold: 0.2,
            light_tree_max_picks: 64,
            sky_samples: 16,
            resolution_scale: 1.0,
            all_effects: false,
            path_guide: true,
            light_strata: LightStrataMode::Sobol,
            pixel_strata: PixelStrata::Sobol,
            drop: Dropped::default(),
            indirect: Indirect::Auto,
            cache_texels: 16384,
            cache_rays: 256,
            cache_tolerance: 1e-4,
            gather_rays: 16,
            tolerance: 0.005,
            target_error: None,
            max_spp: 1024,
        }
    }
}

/// A `--set KEY=VALUE` that could not be applied.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SettingsError {
    #[error("unknown setting `{0}` (known: {known})", known = RenderSettings::KEYS.join(", "))]
    UnknownKey(String),
    #[error("setting `{key}`: `{}` is not valid ({expected})", short_number(value))]
    BadValue {
        key: String,
        value: String,
        expected: &'static str,
    },
    #[error("expected KEY=VALUE, got `{0}`")]
    NotKeyValue(String),
}

/// A value as written, unless it is a number written long (a sweep's
/// range made `1e300` into 301 digits): then in exponent form.
fn short_number(value: &str) -> String {
    match value.trim().parse::<f64>() {
        Ok(x) if value.len() > 24 => gloam_spectra::num(x),
        _ => value.to_string(),
    }
}

fn parse<T: std::str::FromStr>(
    key: &str,
    value: &str,
    expected: &'static str,
    ok: impl Fn(&T) -> bool,
) -> Result<T, SettingsError> {
    value
        .trim()
        .parse::<T>()
        .ok()
        .filter(|v| ok(v))
        .ok_or_else(|| SettingsError::BadValue {
            key: key.into(),
            value: value.into(),
            expected,
        })
}

/// How [`RenderSettings::set`]'s errors name the values a key takes.
const POS_INT: &str = "an integer ≥ 1";
const NONNEG_INT: &str = "an integer ≥ 0";
const POS: &str = "a finite number > 0";
const NONNEG: &str = "a finite number ≥ 0";
/// Samples or rays taken per hit or per source (`area_samples`,
/// `sky_samples`, `MAX_SAMPLE_POINTS`, `MAX_SOURCE_SAMPLES`): each was
/// any u32, and 2³² − 1 of them hung a 32 × 24 render or aborted on an
/// allocation of that many points.
const PER_HIT: &str = "an integer in [1, 65536]";
fn per_hit(x: &u32) -> bool {
    (1..=65536).contains(x)
}

impl RenderSettings {
    /// The interreflection method asked for once the settings that
    /// override `indirect` are applied: dropped interreflection is off,
    /// and `auto` with diffuse bounces asked for is path tracing.
    pub(crate) fn requested_indirect(&self) -> Indirect {
        match self.indirect {
            _ if self.drop.interreflection => Indirect::Off,
            Indirect::Auto if self.diffuse_bounces > 0 => Indirect::Path,
            m => m,
        }
    }

    /// Every key accepted by [`RenderSettings::set`].
    pub const KEYS: &'static [&'static str] = &[
        "spp",
        "seed",
        "estimator",
        "recursion",
        "diffuse_bounces",
        "rr_start",
        "spectral_step_nm",
        "area_samples",
        "occlusion",
        "source_roulette_fraction",
        "SAMPLE_AREA_DENSITY",
        "MAX_SAMPLE_POINTS",
        "MAX_SOURCE_SAMPLES",
        "SOLID_ANGLE_THRESHOLD",
        "SOLID_ANGLE_DENSITY",
        "IRRADIANCE_THRESHOLD",
        "light_tree_min_lights",
        "light_tree_branches",
        "light_tree_split",
        "light_split_threshold",
        "light_tree_max_picks",
        "sky_samples",
        "resolution_scale",
        "all_effects",
        "path_guide",
        "light_strata",
        "pixel_strata",
        "drop",
        "indirect",
        "cache_texels",
        "cache_rays",
        "cache_tolerance",
        "gather_rays",
        "tolerance",
        "target_error",
        "max_spp",
    ];

    /// Applies `KEY=VALUE`.
    pub fn set_pair(&mut self, pair: &str) -> Result<(), SettingsError> {
        let (k, v) = pair
            .split_once('=')
            .ok_or_else(|| SettingsError::NotKeyValue(pair.into()))?;
        self.set(k.trim(), v.trim())
    }

    /// Sets one named setting (keys are case-insensitive).
    ///
    /// Counts are bounded before anything is allocated: `spp` ≤ [`MAX_SPP`].
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), SettingsError> {
        let pos = |x: &f64| x.is_finite() && *x > 0.0;
        let nonneg = |x: &f64| x.is_finite() && *x >= 0.0;
        let d = &mut self.dirsig2001;
        match key.to_ascii_lowercase().as_str() {
            "spp" => {
                self.spp = parse(key, value, "an integer in [1, 65536]", |&x: &u32| {
                    (1..=MAX_SPP).contains(&x)
                })?
            }
            "seed" => self.seed = parse(key, value, NONNEG_INT, |_: &u64| true)?,
            "estimator" => self.estimator = value.parse()?,
            "recursion" => self.recursion = parse(key, value, POS_INT, |&x: &u32| x >= 1)?,
            "diffuse_bounces" => {
                self.diffuse_bounces = parse(key, value, NONNEG_INT, |_: &u32| true)?
            }
            "rr_start" => self.rr_start = parse(key, value, NONNEG_INT, |_: &u32| true)?,
            "spectral_step_nm" => {
                self.spectral_step_nm = parse(
                    key,
                    value,
                    "a wavelength step of at least 0.001 nm",
                    |&x: &f64| x.is_finite() && x >= crate::spectral::MIN_STEP_NM,
                )?
            }
            "area_samples" => self.area_samples = parse(key, value, PER_HIT, per_hit)?,
            "occlusion" => {
                self.occlusion = parse_word(
                    key,
                    value,
                    &[
                        ("cv", Occlusion::Cv),
                        ("control-variate", Occlusion::Cv),
                        ("ratio", Occlusion::Ratio),
                    ],
                    "cv or ratio",
                )?
            }
            "source_roulette_fraction" => {
                self.source_roulette_fraction =
                    parse(key, value, "a number in [0, 1]", |x: &f64| {
                        (0.0..=1.0).contains(x)
                    })?
            }
            "sample_area_density" => d.SAMPLE_AREA_DENSITY = parse(key, value, POS, pos)?,
            "max_sample_points" => d.MAX_SAMPLE_POINTS = parse(key, value, PER_HIT, per_hit)?,
            "max_source_samples" => d.MAX_SOURCE_SAMPLES = parse(key, value, PER_HIT, per_hit)?,
            "solid_angle_threshold" => d.SOLID_ANGLE_THRESHOLD = parse(key, value, NONNEG, nonneg)?,
            "solid_angle_density" => d.SOLID_ANGLE_DENSITY = parse(key, value, POS, pos)?,
            "irradiance_threshold" => d.IRRADIANCE_THRESHOLD = parse(key, value, NONNEG, nonneg)?,
            _ => return self.set_lights_and_cache(key, value),
        }
        Ok(())
    }

    /// [`Self::set`]'s second half: the light sampler's, the sky's, the
    /// strata's, the cache's and the adaptive stop's keys.
    fn set_lights_and_cache(&mut self, key: &str, value: &str) -> Result<(), SettingsError> {
        match key.to_ascii_lowercase().as_str() {
            "light_tree_min_lights" => {
                self.light_tree_min_lights = parse(key, value, NONNEG_INT, |_: &u32| true)?
            }
            "light_tree_branches" => {
                self.light_tree_branches =
                    parse(key, value, "an integer in [1, 1024]", |&x: &u32| {
                        (1..=1024).contains(&x)
                    })?
            }
            "light_tree_split" => {
                let words = [
                    ("adaptive", LightTreeSplit::Adaptive),
                    ("fixed", LightTreeSplit::Fixed),
                ];
                self.light_tree_split = parse_word(key, value, &words, "adaptive or fixed")?
            }
            "light_split_threshold" => {
                self.light_split_threshold = parse(key, value, "a number in [0, 1]", |x: &f64| {
                    (0.0..=1.0).contains(x)
                })?
            }
            "light_tree_max_picks" => {
                self.light_tree_max_picks =
                    parse(key, value, "an integer in [1, 1024]", |&x: &u32| {
                        (1..=1024).contains(&x)
                    })?
            }
            "sky_samples" => self.sky_samples = parse(key, value, PER_HIT, per_hit)?,
            "resolution_scale" => {
                self.resolution_scale =
                    parse(key, value, "a finite number in (0, 16]", |x: &f64| {
                        x.is_finite() && *x > 0.0 && *x <= 16.0
                    })?
            }
            "path_guide" => self.path_guide = parse_bool(key, value)?,
            "all_effects" => self.all_effects = parse_bool(key, value)?,
            "light_strata" => {
                let words = [
                    ("sobol", LightStrataMode::Sobol),
                    ("random", LightStrataMode::Random),
                ];
                self.light_strata = parse_word(key, value, &words, "sobol or random")?
            }
            "pixel_strata" => {
                let words = [("latin", PixelStrata::Latin), ("sobol", PixelStrata::Sobol)];
                self.pixel_strata = parse_word(key, value, &words, "latin or sobol")?
            }
            "drop" => self.drop = Dropped::parse(value)?,
            "indirect" => self.indirect = value.parse()?,
            "cache_texels" => {
                self.cache_texels = parse(key, value, "an integer in [1, 4194304]", |&x: &u32| {
                    (1..=1 << 22).contains(&x)
                })?
            }
            "cache_rays" => {
                self.cache_rays = parse(key, value, "an integer in [1, 65536]", |&x: &u32| {
                    (1..=65536).contains(&x)
                })?
            }
            "cache_tolerance" => {
                self.cache_tolerance = parse(key, value, "a number in (0, 1)", |x: &f64| {
                    *x > 0.0 && *x < 1.0
                })?
            }
            "gather_rays" => {
                self.gather_rays = parse(key, value, "an integer in [0, 65536]", |&x: &u32| {
                    x <= 65536
                })?
            }
            "tolerance" => {
                self.tolerance = parse(key, value, "a number in [0, 1)", |x: &f64| {
                    (0.0..1.0).contains(x)
                })?
            }
            "target_error" => {
                self.target_error = if value.eq_ignore_ascii_case("none") {
                    None
                } else {
                    Some(parse(
                        key,
                        value,
                        "a number in [1e-6, 1] or none",
                        |x: &f64| (1e-6..=1.0).contains(x),
                    )?)
                }
            }
            "max_spp" => {
                self.max_spp = parse(key, value, "an integer in [1, 1048576]", |&x: &u32| {
                    (1..=1 << 20).contains(&x)
                })?
            }
            _ => return Err(SettingsError::UnknownKey(key.into())),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drop_parses_plan_names_and_refuses_others() {
        let mut s = RenderSettings::default();
        s.set("drop", "moon, specular_recursion").unwrap();
        assert!(s.drop.has("moon") && s.drop.specular_recursion && !s.drop.has("night-sky"));
        assert!(s.drop.light(Term::Moon) && !s.drop.light(Term::NightSky));
        assert_eq!(s.drop.names(), "moon,specular-recursion");
        let e = s.set("drop", "moon,saturn").unwrap_err();
        assert!(e.to_string().contains("`saturn`"), "{e}");
        s.set("drop", "none").unwrap();
        assert_eq!(s.drop, Dropped::default());
    }

    /// Every name `drop` knows round-trips, the refusal lists exactly
    /// them, and the JSON keeps one boolean per effect in snake case (the
    /// shape `report.json` had when the terms were fields).
    #[test]
    fn drop_names_message_and_json_agree() {
        let e = Dropped::parse("nothing-like-it").unwrap_err().to_string();
        let listed = e.split("effect names: ").nth(1).unwrap();
        let listed: Vec<&str> = listed.trim_end_matches(" (or none))").split(", ").collect();
        assert_eq!(listed, Dropped::NAMES, "{e}");
        for name in Dropped::NAMES {
            let d = Dropped::parse(name).unwrap();
            assert_eq!(d.names(), name);
            let json = serde_json::to_value(d).unwrap();
            let obj = json.as_object().unwrap();
            assert_eq!(obj.len(), Dropped::NAMES.len());
            let set: Vec<&String> = obj
                .iter()
                .filter(|(_, v)| v.as_bool() == Some(true))
                .map(|(k, _)| k)
                .collect();
            assert_eq!(set, [&name.replace('-', "_")]);
        }
    }

    #[test]
    fn set_known_and_reject_unknown() {
        let mut s = RenderSettings::default();
        s.set_pair("SOLID_ANGLE_DENSITY=2000").unwrap();
        s.set_pair("recursion=1").unwrap();
        s.set_pair("estimator=solid-angle").unwrap();
        assert_eq!(s.dirsig2001.SOLID_ANGLE_DENSITY, 2000.0);
        assert_eq!(s.recursion, 1);
        assert_eq!(s.estimator, Estimator::SolidAngle);
        assert!(matches!(
            s.set_pair("nope=1"),
            Err(SettingsError::UnknownKey(_))
        ));
        assert!(matches!(
            s.set_pair("spp=0"),
            Err(SettingsError::BadValue { .. })
        ));
        assert!(matches!(
            s.set_pair("spp"),
            Err(SettingsError::NotKeyValue(_))
        ));
        for k in RenderSettings::KEYS {
            // every documented key is accepted by `set` with some value
            let v = match *k {
                "estimator" => "analytic",
                "occlusion" => "ratio",
                "source_roulette_fraction" | "resolution_scale" => "0.5",
                "all_effects" | "path_guide" => "true",
                "light_strata" => "random",
                "pixel_strata" => "latin",
                "light_tree_split" => "fixed",
                "light_split_threshold" => "0.5",
                "indirect" => "cache",
                "drop" => "moon",
                "cache_tolerance" | "tolerance" | "target_error" => "0.01",
                _ => "3",
            };
            s.set(k, v).unwrap();
        }
    }
}

/// A `true`/`false` setting (also 1/0, yes/no, on/off).
fn parse_bool(key: &str, value: &str) -> Result<bool, SettingsError> {
    let words = [
        ("true", true),
        ("1", true),
        ("yes", true),
        ("on", true),
        ("false", false),
        ("0", false),
        ("no", false),
        ("off", false),
    ];
    parse_word(key, value, &words, "true or false")
}

/// `value` as one of `words` (case-insensitive), or an error naming
/// `key` and what it accepts.
fn parse_word<T: Copy>(
    key: &str,
    value: &str,
    words: &[(&str, T)],
    expected: &'static str,
) -> Result<T, SettingsError> {
    words
        .iter()
        .find(|(w, _)| w.eq_ignore_ascii_case(value))
        .map(|&(_, v)| v)
        .ok_or_else(|| SettingsError::BadValue {
            key: key.into(),
            value: value.into(),
            expected,
        })
}

/// Where a pixel's camera samples sit in it (see `pixel_strata`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PixelStrata {
    Latin,
    Sobol,
}

/// How the camera vertex draws its light samples (see `light_strata`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LightStrataMode {
    Sobol,
    Random,
}
