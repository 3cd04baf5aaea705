//! SFNC behaviour of `gloam device --gige` as Aravis's own `arv-tool-0.8`
//! sees it: registers that persist across control sessions until
//! `DeviceReset` loads the `UserSetDefault` set, user sets saved and
//! loaded. Each run is one private network namespace with loopback alone
//! (`unshare -n`, see `aravis_netns`); without Aravis a loud notice, or a
//! failure under `GLOAM_REQUIRE_ARAVIS=1` (CI).

mod aravis_netns;
use aravis_netns::{aravis_ready, in_netns};

/// The value of the `n`-th `name = value` line (`arv-tool-0.8 control`'s
/// output, which prints a written value back too) in `section`, as a
/// number; its unit, if any, ignored.
fn number(section: &str, name: &str, n: usize) -> f64 {
    section
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("{name} = ")))
        .nth(n)
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("no {name} #{n} in:\n{section}"))
}

/// The enumeration entry of the `n`-th `name = entry` line in `section`.
fn entry<'a>(section: &'a str, name: &str, n: usize) -> &'a str {
    section
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("{name} = ")))
        .nth(n)
        .and_then(|v| v.split_whitespace().next())
        .unwrap_or_else(|| panic!("no {name} #{n} in:\n{section}"))
}

/// Splits `out` at `== NAME` marker lines: the text after each marker.
fn sections(out: &str) -> std::collections::BTreeMap<String, String> {
    let mut m = std::collections::BTreeMap::new();
    let mut cur = String::new();
    for l in out.lines() {
        if let Some(name) = l.strip_prefix("== ") {
            cur = name.to_string();
            m.insert(cur.clone(), String::new());
        } else if let Some(s) = m.get_mut(&cur) {
            s.push_str(l);
            s.push('\n');
        }
    }
    m
}

/// The preset's power-up values, from the sensor chain in process (not
/// from the device): (GainAuto on, gain in dB, frame rate Hz).
fn preset_defaults() -> (bool, f64, f64) {
    use gloam_grabber::FrameSource;
    let src = gloam_simcam::SensorSource::new(
        "gen2-s20-iccd",
        "uniform",
        1,
        (64, 48),
        &gloam_io::ReadLog::off(),
    )
    .expect("preset");
    let d = src.info().defaults;
    let toml = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sims/sensors/gen2-s20-iccd.toml"
    );
    let rate: f64 = std::fs::read_to_string(toml)
        .expect("preset toml")
        .lines()
        .find_map(|l| l.strip_prefix("frame_rate_hz = "))
        .and_then(|v| v.trim().parse().ok())
        .expect("frame_rate_hz");
    (
        d.agc,
        20.0 * (f64::from(d.gain_milli) / 1000.0).log10(),
        rate,
    )
}

#[test]
fn registers_persist_across_sessions_until_device_reset_loads_user_set_default() {
    if !aravis_ready("gige SFNC user sets", &["arv-tool-0.8", "ip"]) {
        return;
    }
    let (agc, default_db, default_hz) = preset_defaults();
    assert!(agc, "the preset runs its AGC at power-up");
    let dir = tempfile::tempdir().expect("tempdir");
    // One arv-tool process per control session.
    let t = "timeout 20 arv-tool-0.8 -a 127.0.0.1 control";
    let client = format!(
        r#"echo "== power-up"
{t} GainAuto Gain AcquisitionFrameRate UserSetDefault
{t} GainAuto=Off Gain=40 AcquisitionFrameRate=7.5
echo "== second session"
{t} GainAuto Gain AcquisitionFrameRate UserSetSelector=UserSet1 UserSetSave Gain=30 Gain UserSetLoad Gain AcquisitionFrameRate
echo "== third session"
{t} Gain DeviceReset
echo "== after reset"
{t} GainAuto Gain AcquisitionFrameRate UserSetDefault=UserSet1 GainAuto DeviceReset
echo "== after reset to UserSet1"
{t} UserSetDefault GainAuto Gain AcquisitionFrameRate UserSetSelector=Default UserSetSave
echo "== end""#
    );
    let run = in_netns(dir.path(), "--size 64x48 --seed 1", &client, 120);
    let out = &run.stdout;
    assert!(run.ok, "{out}\n{}\n{}", run.stderr, run.device_stderr);
    let s = sections(out);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-3;

    let p = &s["power-up"];
    assert_eq!(entry(p, "GainAuto", 0), "Continuous", "{out}");
    assert!(close(number(p, "Gain", 0), default_db), "{out}");
    assert!(
        close(number(p, "AcquisitionFrameRate", 0), default_hz),
        "{out}"
    );
    assert_eq!(entry(p, "UserSetDefault", 0), "Default", "{out}");

    // The next client sees what the last one wrote.
    let two = &s["second session"];
    assert_eq!(entry(two, "GainAuto", 0), "Off", "{out}");
    assert!(close(number(two, "Gain", 0), 40.0), "{out}");
    assert!(close(number(two, "AcquisitionFrameRate", 0), 7.5), "{out}");
    // Saved into UserSet1, changed (arv-tool prints a write's value back,
    // then the read), loaded back. The gain is set in thousandths of the
    // linear factor: 30 dB reads 30.0001.
    assert!(two.contains("UserSetSave executed"), "{out}");
    assert!(close(number(two, "Gain", 2), 30.0), "{out}");
    assert!(two.contains("UserSetLoad executed"), "{out}");
    assert!(close(number(two, "Gain", 3), 40.0), "{out}");
    assert!(close(number(two, "AcquisitionFrameRate", 1), 7.5), "{out}");

    let three = &s["third session"];
    assert!(close(number(three, "Gain", 0), 40.0), "{out}");
    assert!(three.contains("DeviceReset executed"), "{out}");

    // DeviceReset loaded UserSetDefault = Default: the preset's values.
    let r = &s["after reset"];
    assert_eq!(entry(r, "GainAuto", 0), "Continuous", "{out}");
    assert!(close(number(r, "Gain", 0), default_db), "{out}");
    assert!(
        close(number(r, "AcquisitionFrameRate", 0), default_hz),
        "{out}"
    );
    // Choosing the default set loads nothing by itself.
    assert_eq!(entry(r, "GainAuto", 1), "Continuous", "{out}");

    // With UserSetDefault = UserSet1, DeviceReset loads UserSet1.
    let u = &s["after reset to UserSet1"];
    assert_eq!(entry(u, "UserSetDefault", 0), "UserSet1", "{out}");
    assert_eq!(entry(u, "GainAuto", 0), "Off", "{out}");
    assert!(close(number(u, "Gain", 0), 40.0), "{out}");
    assert!(close(number(u, "AcquisitionFrameRate", 0), 7.5), "{out}");
    // The factory set is read-only.
    assert!(u.contains("write-protect"), "{out}");
}

/// Per-second rates `arv-camera-test-0.8` prints (`N frames/s - …`), the
/// first second (the acquisition starting) left out, sorted.
fn rates(section: &str) -> Vec<f64> {
    let mut r: Vec<f64> = section
        .lines()
        .filter_map(|l| l.trim().split_once(" frame"))
        .filter_map(|(n, _)| n.trim().parse().ok())
        .skip(1)
        .collect();
    r.sort_by(f64::total_cmp);
    r
}

/// The first frame a `gen2-s20-iccd` at 64×48, seed 1, renders at its
/// defaults, looking at the uniform rig or at `shown` instead: its CRC.
fn first_frame_crc(shown: Option<&gloam_grabber::Stimulus>) -> u32 {
    use gloam_grabber::FrameSource;
    let mut src = gloam_simcam::SensorSource::new(
        "gen2-s20-iccd",
        "uniform",
        1,
        (64, 48),
        &gloam_io::ReadLog::off(),
    )
    .expect("preset");
    if let Some(s) = shown {
        src.present(s).expect("present");
    }
    src.restart();
    let s = src.info().defaults;
    let mut px = vec![0u16; 64 * 48];
    src.render(&s, &mut px).expect("render");
    gloam_grabber::pixels_crc32c(&px)
}

#[test]
fn sfnc_features_read_back_frame_rate_enable_paces_and_the_rig_stimulus_reads_back() {
    if !aravis_ready(
        "gige SFNC features",
        &["arv-tool-0.8", "arv-camera-test-0.8", "ip"],
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let t = "timeout 20 arv-tool-0.8 -a 127.0.0.1 control";
    let client = format!(
        r#"echo "== power-up"
{t} ExposureAuto GainSelector AcquisitionFrameRateEnable AcquisitionFrameRate GloamStimulus
echo "== writes"
{t} ExposureAuto=Continuous ExposureAuto GainSelector=All GainSelector AcquisitionFrameRateEnable=false AcquisitionFrameRate=5 AcquisitionFrameRateEnable AcquisitionFrameRate 2>&1
echo "== rate disabled"
timeout 30 arv-camera-test-0.8 --duration 4
echo "== rate enabled"
{t} AcquisitionFrameRateEnable=true AcquisitionFrameRateEnable
timeout 30 arv-camera-test-0.8 --duration 4
echo "== end""#
    );
    let run = in_netns(dir.path(), "--size 64x48 --seed 1", &client, 120);
    let out = &run.stdout;
    assert!(run.ok, "{out}\n{}\n{}", run.stderr, run.device_stderr);
    let s = sections(out);

    let p = &s["power-up"];
    assert_eq!(entry(p, "ExposureAuto", 0), "Off", "{out}");
    assert_eq!(entry(p, "GainSelector", 0), "All", "{out}");
    assert_eq!(entry(p, "AcquisitionFrameRateEnable", 0), "true", "{out}");
    assert!(
        (number(p, "AcquisitionFrameRate", 0) - 25.0).abs() < 1e-3,
        "{out}"
    );

    // The rig's stimulus, read back through GenICam, is the one in effect:
    // shown explicitly in process it gives the rig's first frame to the
    // bit, and 1 % more radiance does not.
    let json = p
        .lines()
        .find_map(|l| l.strip_prefix("GloamStimulus = "))
        .unwrap_or_else(|| panic!("no GloamStimulus in:\n{out}"));
    let shown: gloam_grabber::Stimulus =
        serde_json::from_str(json.trim()).unwrap_or_else(|e| panic!("{json}: {e}"));
    let gloam_grabber::Stimulus::Uniform {
        radiance_w_m2_sr,
        spectrum,
    } = &shown
    else {
        panic!("the uniform rig reads {json}");
    };
    assert!(*radiance_w_m2_sr > 0.0, "{json}");
    let rig = first_frame_crc(None);
    assert_eq!(first_frame_crc(Some(&shown)), rig, "{json}");
    let brighter = gloam_grabber::Stimulus::Uniform {
        radiance_w_m2_sr: radiance_w_m2_sr * 1.01,
        spectrum: spectrum.clone(),
    };
    assert_ne!(first_frame_crc(Some(&brighter)), rig);

    // One entry each: other values are refused, the entry stays.
    let w = &s["writes"];
    assert!(w.contains("ExposureAuto"), "{out}");
    assert_eq!(entry(w, "ExposureAuto", 0), "Off", "{out}");
    assert_eq!(entry(w, "GainSelector", 0), "All", "{out}");
    assert_eq!(entry(w, "AcquisitionFrameRateEnable", 0), "false", "{out}");
    assert!(
        (number(w, "AcquisitionFrameRate", 0) - 5.0).abs() < 1e-3,
        "{out}"
    );

    // Off: the sensor's 25 Hz, whatever AcquisitionFrameRate says; on: 5 Hz.
    let off = rates(&s["rate disabled"]);
    let on = rates(&s["rate enabled"]);
    assert!(off.len() >= 2 && on.len() >= 2, "{out}");
    let median = |r: &[f64]| r[r.len() / 2];
    assert!(median(&off) >= 15.0, "disabled: {off:?}\n{out}");
    assert!(
        (4.0..=6.0).contains(&median(&on)),
        "enabled at 5 Hz: {on:?}\n{out}"
    );
}
