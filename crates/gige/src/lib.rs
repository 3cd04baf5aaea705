#![doc = include_str!("../README.md")]

/// `eprintln!` that never panics (std's does when stderr is full or
/// closed): the message is lost, the run is not.
macro_rules! eprintln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

pub mod bootstrap;
pub mod device;
pub mod features;
pub mod fuzzing;
pub mod gvcp;
pub mod gvsp;
pub mod server;
pub mod simulated;

pub use device::{CameraFacts, Device, Event, Identity, StreamConfig};
pub use gvsp::StreamFaults;
pub use server::{GigeServer, ServerConfig, ServerStats};
pub use simulated::{parse_bind_addr, simulated_identity};

/// The facts a device needs from a frame source, with the sensor's frame
/// rate (which [`gloam_grabber::source::SourceInfo`] does not carry).
pub fn camera_facts(
    info: &gloam_grabber::source::SourceInfo,
    resizable: bool,
    sensor_frame_rate_hz: f64,
    mcp_range_v: Option<(f64, f64)>,
) -> CameraFacts {
    CameraFacts {
        max_width: info.max_width,
        max_height: info.max_height,
        resizable,
        min_gain_milli: info.min_gain_milli,
        max_gain_milli: info.max_gain_milli,
        max_exposure_us: info.max_exposure_us,
        has_agc: info.has_agc,
        mcp_range_v: if info.has_mcp { mcp_range_v } else { None },
        sensor_frame_rate_hz,
        max_frame_rate_hz: 1000.0,
        defaults: info.defaults,
    }
}
