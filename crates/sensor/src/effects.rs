//! The sensor's part of the effect plan: which stages run, why, and what
//! share of the signal they are estimated to carry.

use serde::Serialize;

use crate::config::{CouplingKind, SensorConfig, SensorKind};
use crate::kernel::Kernel;
use crate::stages::Chain;
use crate::stages::bright::BrightStages;

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

/// Every stage of the chain, in order, with enabled/reason and its
/// estimated share. A stage at identity or with its noise off is listed as
/// disabled with the reason; it costs nothing at capture.
pub fn sensor_effects(config: &SensorConfig) -> Vec<SensorEffect> {
    let mut v = Plan(Vec::new());
    let chain = match Chain::new(config) {
        Ok(c) => c,
        Err(e) => {
            v.push(("sensor", false, format!("invalid configuration: {e}")));
            return v.0;
        }
    };
    let kind = config.kind;
    let g = chain.reference_gain;
    let o = &config.optics;
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
    let stages = chain.stages_at(g);
    let pre: Vec<_> = stages.iter().filter(|s| !s.after_noise).collect();
    let post: Vec<_> = stages.iter().filter(|s| s.after_noise).collect();
    let kpre = Kernel::from_mtf(|f| pre.iter().map(|s| s.term.at(f)).product());
    let kpost = Kernel::from_mtf(|f| post.iter().map(|s| s.term.at(f)).product());
    let names =
        |s: &[&crate::stages::MtfStage]| s.iter().map(|s| s.name).collect::<Vec<_>>().join(", ");
    v.push((
        "MTF before shot noise",
        kpre.is_some(),
        match &kpre {
            Some(k) => format!("{} (kernel radius {})", names(&pre), k.radius),
            None => "identity to 0.1 % up to Nyquist".into(),
        },
    ));
    let intens = kind != SensorKind::Ccd;
    v.push((
        "photocathode",
        intens,
        if intens {
            "intensified camera".into()
        } else {
            "plain CCD detects the scene directly".into()
        },
    ));
    let ebi = chain.ebi_pe(g);
    v.push((
        "dark emission (EBI)",
        ebi > 0.0,
        if ebi > 0.0 {
            format!("{ebi:.3e} photoelectrons/pixel/frame at the configured gain")
        } else {
            "no EBI configured".into()
        },
    ));
    let intensifier = chain.intensifier();
    let iccd = intensifier.is_some();
    let why_not_iccd = || format!("kind = {kind:?}: no MCP or phosphor");
    v.push((
        "MCP gain",
        iccd,
        match intensifier {
            Some(i) => format!(
                "gamma shape {}, open area {}",
                i.mcp.gain_shape, i.mcp.open_area
            ),
            None => why_not_iccd(),
        },
    ));
    let saturation = intensifier.and_then(|i| i.mcp.saturation_e);
    v.push((
        "MCP saturation",
        saturation.is_some(),
        match saturation {
            Some(q) => format!("soft knee at {q:.3e} e⁻/pixel/frame"),
            None if iccd => "no output current limit configured".into(),
            None => why_not_iccd(),
        },
    ));
    v.push((
        "phosphor screen",
        iccd,
        match intensifier {
            Some(i) => format!("{:.0} photons/e⁻", i.phosphor_photons_per_e),
            None => why_not_iccd(),
        },
    ));
    let lag = chain.lag_fraction();
    let period = 1.0 / config.timing.frame_rate_hz;
    v.share(
        "phosphor persistence",
        lag > 0.0,
        if lag > 0.0 {
            format!(
                "{lag} of a frame's light in later frames (geometric lag, 1/e decay time {:.2} ms); shows when the scene or gain changes",
                -period / lag.ln() * 1e3
            )
        } else if iccd {
            "lag fraction 0".into()
        } else {
            why_not_iccd()
        },
        Some(lag),
    );
    let coupling = config.coupling.as_ref();
    v.push((
        "coupling",
        coupling.is_some(),
        match (coupling, intensifier) {
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
    let eb = kind == SensorKind::Ebccd;
    v.push((
        "electron bombardment",
        eb,
        if eb {
            "EBCCD: Fano and backscatter gain noise".into()
        } else {
            format!("kind = {kind:?}")
        },
    ));
    v.push((
        "MTF after gain noise",
        kpost.is_some(),
        match &kpost {
            Some(k) => format!("{} (kernel radius {})", names(&post), k.radius),
            None => "identity to 0.1 % up to Nyquist or no stage".into(),
        },
    ));
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
    let agc = config.agc.as_ref().is_some_and(|a| a.enabled);
    v.push((
        "AGC",
        agc,
        if agc {
            "closed loop on mean brightness".into()
        } else {
            "fixed gain (override or no AGC)".into()
        },
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
        let t = crate::stages::video_timing::LineTiming::of(video.format);
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
            crate::stages::video_timing::VideoFormat::Rs170 => 640,
            crate::stages::video_timing::VideoFormat::Ccir => 768,
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
    bright_source_effects(&mut v, &chain);
    v.0
}

/// The bright-source stages: when they switch on and their shares.
fn bright_source_effects(v: &mut Plan, chain: &Chain) {
    let Some(b) = BrightStages::of(chain) else {
        let why = format!("kind = {:?}: no intensifier", chain.kind);
        for name in [
            "halo",
            "MCP pore depletion",
            "ABC / bright-source protection",
        ] {
            v.share(name, false, why.clone(), Some(0.0));
        }
        return;
    };
    let g = chain.reference_gain;
    let when = format!(
        "per frame, when the input's max exceeds {} × its mean (off in a uniform field)",
        b.on_above_max_over_mean
    );
    match &b.halo {
        Some(h) => v.share(
            "halo",
            true,
            format!(
                "MCP-input backscatter onto a disc of radius {:.1} px (2 × cathode–MCP gap); {when}",
                h.radius_px
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
    match (&b.depletion, chain.mcp_e_at_saturation(g)) {
        (Some(d), Some(q_fs)) => {
            // The largest compression an unclipped pixel can show: a steady
            // pixel at the CCD's saturation level.
            let bound = d.steady_compression(q_fs);
            v.share(
                "MCP pore depletion",
                true,
                format!(
                    "reservoir {:.3e} e⁻/pixel, recovery {} s; the CCD clips at {:.3e} MCP e⁻/pixel/frame, where the plate compresses by {:.2} %; {when}",
                    d.reservoir_e,
                    chain.config.bright_source.mcp_depletion.recovery_time_s,
                    q_fs,
                    100.0 * bound
                ),
                Some(bound),
            );
        }
        _ => v.share(
            "MCP pore depletion",
            false,
            "bright_source.mcp_depletion.enabled = false or no mcp.output_current_limit_a_cm2"
                .into(),
            Some(0.0),
        ),
    }
    match (&b.abc, chain.mcp_e_at_saturation(g)) {
        (Some(a), Some(q_fs)) => v.share(
            "ABC / bright-source protection",
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
            "ABC / bright-source protection",
            false,
            "bright_source.abc.enabled = false".into(),
            Some(0.0),
        ),
    }
}
