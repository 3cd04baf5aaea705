//! `cargo run --release -p gloam-sensor --example throughput [PRESET] [FRAMES] [LEVEL]`
//! Prints frames/s of the full chain on a 1024×768 test scene of LEVEL
//! photoelectrons/pixel/frame (default 2).

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map_or("gen3-gaas-iccd", |s| s.as_str());
    let frames: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(60);
    let level: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let t = gloam_sensor::throughput_at(preset, 1024, 768, frames, level).expect("preset");
    println!("{}", serde_json::to_string(&t).expect("json"));
}
