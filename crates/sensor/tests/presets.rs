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
        assert!(effects.iter().any(|e| e.0 == "digitizer" && e.1));
        for e in &effects {
            println!("  {:<28} {:<5} {}", e.0, e.1, e.2);
        }
    }
}
