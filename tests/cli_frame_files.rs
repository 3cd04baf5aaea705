//! Frame files as other programs read them: `--frame-format fits` (the
//! header parsed here independently of the writer, counts through BZERO),
//! `tiff` (pages decoded by the `tiff` crate), the PNG frames' `sBIT`
//! scaling, all three holding the same counts (CRC-32C of frames.jsonl),
//! the contact sheet, and `--sensor none`.

mod common;

use std::path::Path;
use std::process::Command;

use common::records;

/// A new-moon street at gain 30 through the 12-bit Gen III camera: in
/// range, so the frames carry structure and noise.
const SCENE: &str = "sims/night-new-moon/scene.toml";
const ARGS: [&str; 12] = [
    "--spp",
    "1",
    "--seed",
    "5",
    "--set",
    "resolution_scale=0.25",
    "--sensor",
    "gen3-gaas-iccd",
    "--frames",
    "2",
    "--gain",
    "30",
];

fn render(out: &Path, extra: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(["render", SCENE, "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("run gloam");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// FITS header cards up to END, as (keyword, value text): strings without
/// their quotes, others up to the comment.
fn fits_header(bytes: &[u8]) -> (Vec<(String, String)>, usize) {
    let mut cards = Vec::new();
    for (i, card) in bytes.chunks(80).enumerate() {
        let card = std::str::from_utf8(card).unwrap();
        if card.starts_with("END ") {
            // The data start at the next 2 880-byte block.
            return (cards, ((i * 80 + 80).div_ceil(2880)) * 2880);
        }
        let (k, rest) = card.split_at(8);
        let v = rest.strip_prefix("= ").unwrap_or(rest).trim();
        let v = match v.strip_prefix('\'') {
            Some(s) => s.split('\'').next().unwrap().trim_end().to_string(),
            None => v.split(" /").next().unwrap().trim().to_string(),
        };
        cards.push((k.trim().to_string(), v));
    }
    panic!("no END card");
}

/// The whole header as text, up to END (comments included).
fn header_text(bytes: &[u8]) -> String {
    let end = bytes
        .chunks(80)
        .position(|c| c.starts_with(b"END "))
        .unwrap();
    String::from_utf8(bytes[..end * 80].to_vec()).unwrap()
}

/// `gloam sensor describe PRESET --gain G --json`'s DN per photoelectron.
fn describe_dn_per_photoelectron(preset: &str, gain: &str) -> f64 {
    let o = Command::new(env!("CARGO_BIN_EXE_gloam"))
        .args(["sensor", "describe", preset, "--gain", gain, "--json"])
        .output()
        .expect("run gloam");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    v["dn_per_photoelectron"].as_f64().unwrap()
}

#[test]
fn png_fits_and_tiff_frames_hold_the_same_counts_and_fits_has_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let (png, fits, tiff) = (
        dir.path().join("png"),
        dir.path().join("fits"),
        dir.path().join("tiff"),
    );
    render(&png, &ARGS);
    render(&fits, &[&ARGS[..], &["--frame-format", "fits"]].concat());
    render(&tiff, &[&ARGS[..], &["--frame-format", "tiff"]].concat());
    let (rp, rf, rt) = (records(&png), records(&fits), records(&tiff));
    assert_eq!(rp.len(), 2);
    let dn_per_pe = describe_dn_per_photoelectron("gen3-gaas-iccd", "30");
    let tiff_bytes = std::fs::read(tiff.join("frames.tiff")).unwrap();
    let mut tiff_pages = tiff::decoder::Decoder::new(std::io::Cursor::new(tiff_bytes)).unwrap();
    for i in 0..2 {
        let crc = rp[i]["pixels_crc32c"].as_u64().unwrap();
        assert_eq!(rf[i]["pixels_crc32c"].as_u64(), Some(crc));
        assert_eq!(rt[i]["pixels_crc32c"].as_u64(), Some(crc));

        // PNG: 12-bit counts scaled by 16 (sBIT 12); gloam's reader
        // returns the counts.
        let name = png.join(format!("frame-{i:06}.png"));
        assert_eq!(
            rp[i]["stored"],
            serde_json::json!({"format": "png", "sample_shift": 4})
        );
        let (w, h, counts) =
            gloam_calib::io::read_counts(&name, &gloam_io::ReadLog::off()).unwrap();
        assert_eq!((w, h), (192, 144));
        assert_eq!(u64::from(gloam_grabber::pixels_crc32c(&counts)), crc);
        let raw = image::open(&name).unwrap().into_luma16().into_raw();
        for (s, c) in raw.iter().zip(&counts) {
            assert_eq!((s >> 4, s & 15), (*c, c >> 8), "left-bit replication");
        }

        // FITS: BITPIX 16, BZERO 32768, the record's values in the header.
        let f = std::fs::read(fits.join(format!("frame-{i:06}.fits"))).unwrap();
        assert_eq!(f.len() % 2880, 0);
        let (cards, data_at) = fits_header(&f);
        let get = |k: &str| {
            let v = cards.iter().find(|(key, _)| key == k);
            v.unwrap_or_else(|| panic!("no {k} in {cards:?}")).1.clone()
        };
        let num = |k: &str| get(k).parse::<f64>().unwrap();
        assert_eq!(cards[0], ("SIMPLE".into(), "T".into()));
        assert_eq!((get("BITPIX"), get("BZERO")), ("16".into(), "32768".into()));
        assert_eq!((get("NAXIS1"), get("NAXIS2")), ("192".into(), "144".into()));
        let r = &rf[i];
        // serde_json's default float parsing may be off in the last digit
        // (the header's digits are Rust's exact shortest form; astropy's
        // test compares exactly).
        let close = |a: f64, b: f64| assert!((a - b).abs() <= 1e-14 * b.abs(), "{a} vs {b}");
        // The tube's linear gain under its own keyword; GAIN is e⁻/DN as
        // astropy and ccdproc read it: 1 / the DN per photoelectron
        // `gloam sensor describe` gives at that gain.
        assert_eq!(num("TUBEGAIN"), r["gain"].as_f64().unwrap());
        assert_eq!(num("TUBEGAIN"), 30.0);
        close(num("GAIN"), 1.0 / dn_per_pe);
        close(num("GAIN"), r["electrons_per_dn"].as_f64().unwrap());
        // The scene's [sky] utc (2025-10-22T04:00:00Z) + the frame's start
        // at the camera's 25 Hz: 0 and 40 ms.
        let date_obs = ["2025-10-22T04:00:00.000", "2025-10-22T04:00:00.040"][i];
        assert_eq!(get("DATE-OBS"), date_obs);
        assert!(header_text(&f).contains("scene [sky] utc + frame start"));
        assert_eq!(get("INSTRUME"), "gen3-gaas-iccd");
        assert_eq!(num("BITS"), 12.0);
        close(num("BLACKDN"), r["black_dn"].as_f64().unwrap());
        close(num("SATDN"), r["saturated_at_dn"].as_f64().unwrap());
        close(num("GATEDUTY"), r["gate_duty"].as_f64().unwrap());
        close(num("NDDENS"), r["nd_density"].as_f64().unwrap());
        let exposure = r["sensor"]["exposure_s"].as_f64().unwrap();
        assert!(exposure > 0.0);
        close(num("EXPTIME"), exposure);
        assert_eq!(num("TSTAMPUS"), r["timestamp"].as_f64().unwrap());
        assert_eq!(get("CAMERA"), "gen3-gaas-iccd");
        assert_eq!(get("SEED"), "5");
        assert_eq!(get("AGC"), "F");
        assert!(get("GLOAMVER").starts_with(env!("CARGO_PKG_VERSION")));
        assert_eq!(get("INPUT1"), SCENE);
        assert_eq!(get("ISHA1").len(), 64);
        let fits_counts: Vec<u16> = f[data_at..][..192 * 144 * 2]
            .chunks(2)
            .map(|c| (i32::from(i16::from_be_bytes([c[0], c[1]])) + 32768) as u16)
            .collect();
        assert_eq!(fits_counts, counts);

        // TIFF: page i, the 12-bit counts left-bit-replicated to 16 bits
        // as in the PNGs (a viewer shows the top code white), the scale
        // in the record and the page's ImageDescription.
        assert_eq!(rt[i]["file"], "frames.tiff");
        assert_eq!(
            rt[i]["stored"],
            serde_json::json!({"format": "tiff", "sample_shift": 4, "page": i})
        );
        if i > 0 {
            assert!(tiff_pages.more_images());
            tiff_pages.next_image().unwrap();
        }
        let description = tiff_pages
            .get_tag_ascii_string(tiff::tags::Tag::ImageDescription)
            .unwrap();
        assert!(description.contains("count = sample >> 4"), "{description}");
        match tiff_pages.read_image().unwrap() {
            tiff::decoder::DecodingResult::U16(v) => {
                let replicated: Vec<u16> = counts.iter().map(|c| (c << 4) | (c >> 8)).collect();
                assert_eq!(v, replicated);
                assert_eq!(v.iter().map(|s| s >> 4).collect::<Vec<_>>(), counts);
            }
            other => panic!("page {i}: not 16-bit: {other:?}"),
        }
    }
    assert!(!tiff_pages.more_images());

    // The contact sheet: 8-bit, two 192 × 144 frames side by side.
    let sheet = image::open(png.join("frames-preview.png")).unwrap();
    assert_eq!(sheet.color(), image::ColorType::L8);
    assert_eq!((sheet.width(), sheet.height()), (192 * 2 + 4, 144));
}

#[test]
fn sensor_none_renders_radiance_only_even_when_the_scene_names_a_camera() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "sims/night-full-moon-lamps/scene.toml";
    let text = std::fs::read_to_string(scene).unwrap();
    assert!(
        text.contains("\nsensor = "),
        "the scene should name a camera"
    );
    let small = ["--spp", "1", "--set", "resolution_scale=0.05"];
    let run = |out: &Path, extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_gloam"))
            .args(["render", scene, "--out"])
            .arg(out)
            .args(small)
            .args(extra)
            .output()
            .expect("run gloam");
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let none = dir.path().join("none");
    let (ok, err) = run(&none, &["--sensor", "none"]);
    assert!(ok, "{err}");
    assert!(none.join("radiance.npy").exists());
    assert!(!none.join("frames.jsonl").exists());
    assert!(!none.join("frames-preview.png").exists());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(none.join("report.json")).unwrap()).unwrap();
    assert!(report.get("sensor_capture").is_none());
    // Camera flags with no camera are refused, not ignored.
    let (ok, err) = run(
        &dir.path().join("x"),
        &["--sensor", "none", "--frames", "2"],
    );
    assert!(!ok && err.contains("--frames needs a camera"), "{err}");
}
