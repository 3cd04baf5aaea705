//! The sensor's part of the effect plan: which stages run, why, and what
//! share of the signal they are estimated to carry.

use serde::Serialize;

use crate::config::{CouplingKind, SensorConfig, SensorKind};
use crate::stages::Chain;
use crate::stages::list::{Stage, Stages, blur_kernel, blur_terms};
use crate::stages::video_timing::{LineTiming, VideoFormat};

/// One stage of the sensor's effect plan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorEffect {
    pub name: &'static str,
    pub enabled: bool,
    pub reason: String,
    /// The stage's estimated share of the signal (the fraction it moves,
    /// removes or compresses, or an upper bound on it); None when not
    /// estimated.
    pub estimated_share: Option<f64>,
}

impl From<(&'static str, bool, String)> for SensorEffect {
    fn from((name, enabled, reason): (&'static str, bool, String)) -> Self {
        Self {
            name,
            enabled,
            reason,
            estimated_share: None,
        }
    }
}

/// The plan's effects with a share, pushed as tuples or as full entries.
struct Plan(Vec<SensorEffect>);

impl Plan {
    fn push(&mut self, e: impl Into<SensorEffect>) {
        self.0.push(e.into());
    }
    fn share(&mut self, name: &'static str, enabled: bool, reason: String, share: Option<f64>) {
        self.0.push(SensorEffect {
            name,
            enabled,
            reason,
            estimated_share: share,
        });
    }
}

/// Every stage of the chain, in the order the camera runs them (the
/// camera's own [`Stages`] list), with enabled/reason and its estimated
/// share. A stage at identity or with its noise off is listed as disabled
/// with the reason; it costs nothing at capture.
pub fn sensor_effects(config: &SensorConfig) -> Vec<SensorEffect> {
    let mut v = Plan(Vec::new());
    let chain = match Chain::new(config) {
        Ok(c) => c,
        Err(e) => {
            v.push(("sensor", false, format!("invalid configuration: {e}")));
            return v.0;
        }
    };
    for stage in Stages::of(&chain).iter() {
        match stage {
            Stage::Optics { .. } => optics(&mut v, &chain),
            Stage::Blur { after_noise, .. } => blur(&mut v, &chain, *after_noise),
            Stage::Photocathode => photocathode(&mut v, &chain),
            // Its threshold is quoted by the halo and the pore depletion.
            Stage::BrightSwitch(_) => {}
            Stage::Abc { abc, .. } => abc_entry(&mut v, &chain, abc.as_ref()),
            Stage::Halo(h) => halo(&mut v, &chain, h.as_ref()),
            Stage::Mcp(m) => mcp(&mut v, &chain, m.as_ref().and_then(|m| m.depletion())),
            Stage::Phosphor { .. } => phosphor(&mut v, &chain),
            Stage::Coupling => coupling(&mut v, &chain),
            Stage::Bombardment(e) => {
                let kind = chain.kind;
                v.push((
                    "electron bombardment",
                    e.is_some(),
                    if e.is_some() {
                        "EBCCD: Fano and backscatter gain noise".into()
                    } else {
                        format!("kind = {kind:?}")
                    },
                ));
            }
            Stage::Readout(_) => readout(&mut v, &chain),
            Stage::Agc => {
                let agc = chain.config.agc.as_ref().is_some_and(|a| a.enabled);
                v.push((
                    "AGC",
                    agc,
                    if agc {
                        "closed loop on mean brightness".into()
                    } else {
                        "fixed gain (override or no AGC)".into()
                    },
                ));
            }
        }
    }
    v.0
}

fn optics(v: &mut Plan, chain: &Chain) {
    let o = &chain.config.optics;
    v.push((
        "optics: camera equation",
        true,
        format!("f/{}, τ = {}", o.f_number, o.transmission),
    ));
    v.push((
        "optics: cos⁴θ fall-off",
        o.vignetting,
        if o.vignetting {
            format!("focal length {} mm", o.focal_length_mm)
        } else {
            "optics.vignetting = false".into()
        },
    ));
}

/// The blur before the shot noise or after the gain noise, at the
/// reference gain.
fn blur(v: &mut Plan, chain: &Chain, after_noise: bool) {
    let terms = blur_terms(chain, chain.reference_gain, after_noise);
    let kernel = blur_kernel(&terms);
    let names = terms.iter().map(|s| s.name).collect::<Vec<_>>().join(", ");
    let (name, identity) = if after_noise {
        (
            "MTF after gain noise",
            "identity to 0.1 % up to Nyquist or no stage",
        )
    } else {
        ("MTF before shot noise", "identity to 0.1 % up to Nyquist")
    };
    v.push((
        name,
        kernel.is_some(),
        match &kernel {
            Some(k) => format!("{names} (kernel radius {})", k.radius),
            None => identity.into(),
        },
    ));
}

fn photocathode(v: &mut Plan, chain: &Chain) {
    let intens = chain.kind != SensorKind::Ccd;
    v.push((
        "photocathode",
        intens,
        if intens {
            "intensified camera".into()
        } else {
            "plain CCD detects the scene directly".into()
        },
    ));
    let ebi = chain.ebi_pe(chain.reference_gain);
    v.push((
        "dark emission (EBI)",
        ebi > 0.0,
        if ebi > 0.0 {
            format!("{ebi:.3e} photoelectrons/pixel/frame at the configured gain")
        } else {
            "no EBI configured".into()
        },
    ));
}

/// Why an intensifier stage is off on a camera without one.
fn no_intensifier(chain: &Chain) -> String {
    format!("kind = {:?}: no intensifier", chain.kind)
}

/// When the bright-source stages switch on.
fn when_bright(chain: &Chain) -> String {
    format!(
        "per frame, when the input's max exceeds {} × its mean (off in a uniform field)",
        chain.config.bright_source.on_above_max_over_mean
    )
}

fn abc_entry(v: &mut Plan, chain: &Chain, abc: Option<&crate::stages::abc::Abc>) {
    const NAME: &str = "ABC / bright-source protection";
    if chain.intensifier().is_none() {
        return v.share(NAME, false, no_intensifier(chain), Some(0.0));
    }
    match (abc, chain.mcp_e_at_saturation(chain.reference_gain)) {
        (Some(a), Some(q_fs)) => v.share(
            NAME,
            true,
            format!(
                "screen current limit {:.3e} A/cm² ({:.3e} e⁻/pixel/frame, {:.1} × the CCD's saturation level), time constant {} s; MCP voltage first, then gating to {} s",
                a.limit_a_cm2,
                a.limit_e_per_pixel,
                a.limit_e_per_pixel / q_fs,
                chain.config.bright_source.abc.time_constant_s,
                chain.config.bright_source.abc.gate_min_s
            ),
            // Cuts nothing until the mean screen current passes the limit.
            Some(0.0),
        ),
        _ => v.share(
            NAME,
            false,
            "bright_source.abc.enabled = false".into(),
            Some(0.0),
        ),
    }
}

fn halo(v: &mut Plan, chain: &Chain, halo: Option<&crate::stages::halo::Halo>) {
    if chain.intensifier().is_none() {
        return v.share("halo", false, no_intensifier(chain), Some(0.0));
    }
    match halo {
        Some(h) => v.share(
            "halo",
            true,
            format!(
                "MCP-input backscatter onto a disc of radius {:.1} px (2 × cathode–MCP gap); {}",
                h.radius_px,
                when_bright(chain)
            ),
            Some(h.fraction),
        ),
        None => v.share(
            "halo",
            false,
            "bright_source.halo.enabled = false or no gap".into(),
            Some(0.0),
        ),
    }
}

fn why_not_iccd(chain: &Chain) -> String {
    format!("kind = {:?}: no MCP or phosphor", chain.kind)
}

fn mcp(v: &mut Plan, chain: &Chain, depletion: Option<&crate::stages::mcp_depletion::Depletion>) {
    let intensifier = chain.intensifier();
    let iccd = intensifier.is_some();
    v.push((
        "MCP gain",
        iccd,
        match intensifier {
            Some(i) => format!(
                "gamma shape {}, open area {}",
                i.mcp.gain_shape, i.mcp.open_area
            ),
            None => why_not_iccd(chain),
        },
    ));
    let saturation = intensifier.and_then(|i| i.mcp.saturation_e);
    v.push((
        "MCP saturation",
        saturation.is_some(),
        match saturation {
            Some(q) => format!("soft knee at {q:.3e} e⁻/pixel/frame"),
            None if iccd => "no output current limit configured".into(),
            None => why_not_iccd(chain),
        },
    ));
    const NAME: &str = "MCP pore depletion";
    if !iccd {
        return v.share(NAME, false, no_intensifier(chain), Some(0.0));
    }
    match (depletion, chain.mcp_e_at_saturation(chain.reference_gain)) {
        (Some(d), Some(q_fs)) => {
            // The largest compression an unclipped pixel can show: a steady
            // pixel at the CCD's saturation level.
            let bound = d.steady_compression(q_fs);
            v.share(
                NAME,
                true,
                format!(
                    "reservoir {:.3e} e⁻/pixel, recovery {} s; the CCD clips at {:.3e} MCP e⁻/pixel/frame, where the plate compresses by {:.2} %; {}",
                    d.reservoir_e,
                    chain.config.bright_source.mcp_depletion.recovery_time_s,
                    q_fs,
                    100.0 * bound,
                    when_bright(chain)
                ),
                Some(bound),
            );
        }
        _ => v.share(
            NAME,
            false,
            "bright_source.mcp_depletion.enabled = false or no mcp.output_current_limit_a_cm2"
                .into(),
            Some(0.0),
        ),
    }
}

fn phosphor(v: &mut Plan, chain: &Chain) {
    let intensifier = chain.intensifier();
    v.push((
        "phosphor screen",
        intensifier.is_some(),
        match intensifier {
            Some(i) => format!("{:.0} photons/e⁻", i.phosphor_photons_per_e),
            None => why_not_iccd(chain),
        },
    ));
    let lag = chain.lag_fraction();
    let period = 1.0 / chain.config.timing.frame_rate_hz;
    v.share(
        "phosphor persistence",
        lag > 0.0,
        if lag > 0.0 {
            format!(
                "{lag} of a frame's light in later frames (geometric lag, 1/e decay time {:.2} ms); shows when the scene or gain changes",
                -period / lag.ln() * 1e3
            )
        } else if intensifier.is_some() {
            "lag fraction 0".into()
        } else {
            why_not_iccd(chain)
        },
        Some(lag),
    );
}

fn coupling(v: &mut Plan, chain: &Chain) {
    let coupling = chain.config.coupling.as_ref();
    v.push((
        "coupling",
        coupling.is_some(),
        match (coupling, chain.intensifier()) {
            (Some(c), Some(i)) => format!(
                "{:?}, {:.3} of the screen light",
                c.kind, i.coupling_fraction
            ),
            _ => "no phosphor to couple".into(),
        },
    ));
    let cw = coupling.is_some_and(|c| {
        c.kind != CouplingKind::RelayLens
            && c.chicken_wire_cell_um > 0.0
            && c.chicken_wire_depth > 0.0
    });
    v.push((
        "chicken-wire pattern",
        cw,
        if cw {
            "multifibre boundaries of the fibre optic".into()
        } else {
            "no fibre optic or chicken_wire_depth = 0".into()
        },
    ));
}

/// The fused readout: CCD, video line and digitizer.
fn readout(v: &mut Plan, chain: &Chain) {
    let config = &chain.config;
    let c = &config.ccd;
    let noise = config.noise.enabled;
    v.push((
        "temporal noise",
        noise,
        if noise {
            format!("seed {}", config.noise.seed)
        } else {
            "noise.enabled = false (deterministic means)".into()
        },
    ));
    v.push((
        "CCD dark current",
        c.dark_current_e_s > 0.0,
        format!("{} e⁻/s", c.dark_current_e_s),
    ));
    v.push(("PRNU", c.prnu > 0.0, format!("{} rms", c.prnu)));
    v.push(("DSNU", c.dsnu_e > 0.0, format!("{} e⁻ rms", c.dsnu_e)));
    v.push((
        "blooming",
        c.blooming,
        format!("full well {} e⁻", c.full_well_e),
    ));
    v.push((
        "read noise",
        noise && chain.read_noise_e > 0.0,
        format!("{:.2} e⁻ rms", chain.read_noise_e),
    ));
    v.push((
        "analogue video",
        config.video.is_some(),
        if config.video.is_some() {
            "1 V p-p composite".into()
        } else {
            "direct digital readout".into()
        },
    ));
    if let Some(video) = &config.video {
        let t = LineTiming::of(video.format);
        v.push((
            "video line timing",
            true,
            format!(
                "{}: {:.3} µs lines, {:.3} µs active, 2:1 interlace",
                video.format.label(),
                t.line_s * 1e6,
                t.active_s() * 1e6
            ),
        ));
        // The square-pixel width of the format sets the quoted pixel clock.
        let cols = match video.format {
            VideoFormat::Rs170 => 640,
            VideoFormat::Ccir => 768,
        };
        v.push((
            "video bandwidth",
            chain.amplifier().is_some(),
            match (chain.amplifier(), chain.line_sampler(cols)) {
                (Some(a), Some(l)) => format!(
                    "{} −3 dB at {:.2} MHz, horizontal only: MTF ×{:.3} at 0.25 cy/px \
                     for {cols} columns ({:.2} MHz pixel clock, sampled at phase {})",
                    a.kind.label(),
                    a.bandwidth_hz / 1e6,
                    l.sampled_mtf(0.25),
                    l.pixel_clock_hz() / 1e6,
                    l.phase
                ),
                _ => "video.bandwidth_hz not set: the amplifier is taken as flat".into(),
            },
        ));
    }
    v.push(("digitizer", true, format!("{} bits", config.digitizer.bits)));
}
