//! The emulator serving a sensor chain over an in-memory link, and the
//! protocol client connected to it: the wire side of the simcam tests.

use gloam_grabber::emulator::{EmulatorConfig, EmulatorHandle};
use gloam_grabber::memory::{MemoryHost, MemoryOptions, memory_link};
use gloam_grabber::{ClientOptions, Framing, ProtocolGrabber};
use gloam_simcam::SensorSource;

/// `src` served over a memory link with `framing` (no baud-rate pacing),
/// and the client connected to it. Stop the emulator after dropping the
/// client.
pub fn over_the_wire(
    src: SensorSource,
    framing: Framing,
) -> (ProtocolGrabber<MemoryHost>, EmulatorHandle) {
    let (host, dev, _ctl) = memory_link(MemoryOptions::new(framing));
    let emu = EmulatorHandle::spawn(
        dev,
        src,
        EmulatorConfig {
            baud: None,
            ..Default::default()
        },
    );
    let wire = ProtocolGrabber::connect(host, ClientOptions::default()).unwrap();
    (wire, emu)
}
