//! Frame grabbers: one interface for the simulated camera, the device
//! emulator and real hardware, so calibration flows never know which one
//! they talk to.

mod interface;

pub mod client;
pub mod emulator;
pub mod faults;
pub mod memory;
pub mod source;
pub mod transport;

pub use client::{ClientOptions, ClientStats, ProtocolGrabber};
pub use interface::*;
pub use transport::{DeviceLink, Framing, LinkError, Transport};

/// CRC-32C (Castagnoli, `crc::CRC_32_ISCSI`) of pixels as little-endian
/// `u16` bytes: [`FrameMeta::pixels_crc32c`].
pub fn pixels_crc32c(pixels: &[u16]) -> u32 {
    const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
    let mut d = CRC.digest();
    let mut buf = [0u8; 4096];
    for block in pixels.chunks(buf.len() / 2) {
        for (o, p) in buf.chunks_exact_mut(2).zip(block) {
            o.copy_from_slice(&p.to_le_bytes());
        }
        d.update(&buf[..block.len() * 2]);
    }
    d.finalize()
}
