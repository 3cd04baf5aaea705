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
    let src =
        gloam_simcam::SensorSource::new("gen2-s20-iccd", "uniform", 1, (64, 48)).expect("preset");
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
