//! Every preset loads, validates and has sane derived figures.

use gloam_sensor::{Camera, PRESETS, SensorConfig, sensor_effects};

#[test]
fn every_preset_loads_and_describes() {
    for (name, _) in PRESETS {
        let cfg = SensorConfig::preset(name).unwrap().unwrap();
        let cam = Camera::new(cfg.clone()).unwrap();
        let d = cam.chain().describe(cam.gain());
        println!("{}", serde_json::to_string_pretty(&d).unwrap());
        assert!(d.dn_per_photoelectron > 0.0 && d.dn_per_photoelectron.is_finite());
        assert!(d.excess_noise_factor >= 1.0);
        assert!(d.saturation_dn > d.black_dn);
        assert!(d.saturation_dn <= ((1u32 << d.bit_depth) - 1) as f64);
        let effects = sensor_effects(&cfg);
        assert!(effects.iter().any(|e| e.name == "digitizer" && e.enabled));
        for e in &effects {
            assert!(
                e.estimated_share.is_none_or(|s| (0.0..=1.0).contains(&s)),
                "{e:?}"
            );
            println!(
                "  {:<28} {:<5} {:?} {}",
                e.name, e.enabled, e.estimated_share, e.reason
            );
        }
    }
}

/// Each preset against figures published for its class of camera (the
/// provenance is on each line), not against numbers the chain derives.
#[test]
fn presets_match_their_datasheet_figures() {
    let chain = |name: &str| {
        let cam = Camera::new(SensorConfig::preset(name).unwrap().unwrap()).unwrap();
        (cam.chain().clone(), cam.gain())
    };

    // Gen III filmed tube: noise figure √F ≈ 1.6 (Csorba, Image Tubes, 1985;
    // Frenkel et al., Appl. Opt. 36 (1997) 5288), and a GaAs cathode of
    // 1 350 µA/lm or more (MIL-PRF-49052 Gen III class; typical tubes
    // 1 800–2 200 µA/lm).
    let (c, g) = chain("gen3-gaas-iccd");
    let root_f = c.excess_noise_factor(g).sqrt();
    assert!((root_f - 1.6).abs() < 0.1, "gen3 √F = {root_f}");
    let s_ua = c.luminous_sensitivity_a_lm.unwrap() * 1e6;
    assert!(
        (1350.0..2600.0).contains(&s_ua),
        "gen3 cathode {s_ua} µA/lm"
    );

    // Gen II unfilmed MCP with an exponential PHD and 60 % open area:
    // F = (1 + 1/1)/0.6 = 3.3 (Eberhardt, IEEE TNS 28 (1981) 712); S-20
    // multialkali cathodes 150–400 µA/lm (Csorba, Image Tubes, table 3.2;
    // Photonis S20 data).
    let (c, g) = chain("gen2-s20-iccd");
    let f = c.excess_noise_factor(g);
    assert!((f - 3.33).abs() < 0.1, "gen2 F = {f}");
    let s_ua = c.luminous_sensitivity_a_lm.unwrap() * 1e6;
    assert!((150.0..400.0).contains(&s_ua), "S-20 cathode {s_ua} µA/lm");

    // EBCCD at 8 kV: gain 1 500–2 000 after a 1–2 keV dead layer
    // (Hamamatsu EB-CCD technical notes); closed form (8000 − 1500)/3.65.
    let (_, g) = chain("s25-ebccd");
    assert!((1500.0..2000.0).contains(&g), "EB gain {g}");
    assert!((g - 6500.0 / 3.65).abs() < 1e-9);

    // e2v CCD42-40 (back-illuminated midband): 100 ke⁻ full well at
    // 1.6 e⁻/DN over a 500 DN offset saturates at 500 + 100 000/1.6 = 63 000
    // DN, inside the 16-bit range; 3 e⁻ read noise is 1.875 DN.
    let (c, g) = chain("scientific-ccd");
    assert_eq!(c.saturation_dn(g), 63_000.0);
    assert!((c.read_noise_dn(g) - 1.875).abs() < 1e-12);
}
