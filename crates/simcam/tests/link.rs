//! The protocol client against the emulator serving the sensor chain.

use std::time::{Duration, Instant};

mod common;

use gloam_grabber::{DeviceControl, FrameStream, Framing};

/// Slow controls answer `Pending` first; the client waits for the final Ack.
/// Unsupported and out-of-range values come back as clear errors.
#[test]
fn pending_controls_and_naks() {
    use firmware_protocol::Control;
    let src = gloam_simcam::SensorSource::new(
        "gen2-s20-iccd",
        "uniform",
        1,
        (32, 24),
        &gloam_io::ReadLog::off(),
    )
    .unwrap();
    let (mut g, emu) = common::over_the_wire(src, Framing::Cobs);
    let t = Instant::now();
    g.set_control_raw(Control::McpVoltageMv, 900_000).unwrap();
    assert!(
        t.elapsed() >= Duration::from_millis(25),
        "MCP slew is modelled as a Pending operation"
    );
    assert_eq!(g.get_control_raw(Control::McpVoltageMv).unwrap(), 900_000);
    let e = g.set_bits(10).unwrap_err();
    assert!(
        matches!(e, gloam_grabber::GrabError::InvalidSetting(_)),
        "{e}"
    );
    // Past the wire's 32 bits of thousandths: refused before it is sent.
    let e = g.set_gain(1e9).unwrap_err();
    assert!(
        e.to_string().contains("largest the protocol carries"),
        "{e}"
    );
    // On the wire but past the camera's range: the device's NAK, in its units.
    let e = g.set_gain(1e6).unwrap_err();
    assert!(
        e.to_string().contains("out of range, in thousandths"),
        "{e}"
    );
    // The emulator renders stimuli (its own extension request).
    assert!(g.present(&gloam_grabber::Stimulus::Dark).unwrap());
    g.grab().unwrap();
    drop(g);
    emu.stop().unwrap();
}
