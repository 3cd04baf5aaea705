//! Frame grabbers: one interface for the simulated camera, the device
//! emulator and real hardware, so calibration flows never know which one
//! they talk to.

mod interface;

pub use interface::*;
