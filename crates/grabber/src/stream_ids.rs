//! What a GenICam stream carries, apart from Aravis: the camera's frame
//! (block) ids made monotonic, and the PFNC codes of the Mono pixel formats.
//! Kept out of `genicam.rs` (feature `genicam`, which needs libaravis) so
//! their tests run in every build.
#![cfg_attr(not(feature = "genicam"), allow(dead_code))]

/// PFNC (GenICam Pixel Format Naming Convention) codes of the unpacked
/// Mono formats: 8 or 16 bits a pixel (bits 16–23) and an id.
const MONO_8: u32 = 0x0108_0001;
const MONO_10: u32 = 0x0110_0003;
const MONO_12: u32 = 0x0110_0005;
const MONO_14: u32 = 0x0110_0025;
const MONO_16: u32 = 0x0110_0007;

/// Bits per pixel value and bytes per pixel of an unpacked Mono format,
/// from its PFNC code; `None` for any other format.
pub(crate) fn mono_layout(pfnc: u32) -> Option<(u8, usize)> {
    match pfnc {
        MONO_8 => Some((8, 1)),
        MONO_10 => Some((10, 2)),
        MONO_12 => Some((12, 2)),
        MONO_14 => Some((14, 2)),
        MONO_16 => Some((16, 2)),
        _ => None,
    }
}

/// Frame ids as the camera numbers them, made monotonic and counted from 0
/// (seq = id − 1, so frame *k* of an acquisition is seq *k* as with the
/// `sim:` grabber): GigE Vision 1.x block ids run 1…65535 and wrap (0 is
/// never used); extended ids do not.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct FrameIds {
    last: Option<(u64, u64)>, // (raw id, unwrapped seq)
}

pub(crate) enum IdStep {
    /// The next frame, after `lost` missing ones; its unwrapped sequence number.
    Next { seq: u64, lost: u64 },
    /// Already seen or older than the last frame: not new.
    Stale,
}

impl FrameIds {
    pub(crate) fn step(&mut self, raw: u64) -> IdStep {
        let Some((last_raw, last_seq)) = self.last else {
            let seq = raw.saturating_sub(1);
            self.last = Some((raw, seq));
            return IdStep::Next { seq, lost: 0 };
        };
        let delta = if raw <= 0xFFFF && last_raw <= 0xFFFF {
            // 65535 ids in the cycle; forward distances beyond half of it
            // are older frames arriving late.
            let d = (raw + 65535 - last_raw) % 65535;
            if d == 0 || d > 32767 {
                return IdStep::Stale;
            }
            d
        } else if raw > last_raw {
            raw - last_raw
        } else {
            return IdStep::Stale;
        };
        let seq = last_seq + delta;
        self.last = Some((raw, seq));
        IdStep::Next {
            seq,
            lost: delta - 1,
        }
    }

    /// A frame that never arrived still used up the next id.
    pub(crate) fn skip_one(&mut self) -> u64 {
        match self.last {
            Some((raw, seq)) => {
                let next = if raw <= 0xFFFF {
                    raw % 65535 + 1
                } else {
                    raw + 1
                };
                self.last = Some((next, seq + 1));
                seq + 1
            }
            None => 0,
        }
    }

    pub(crate) fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn next(ids: &mut FrameIds, raw: u64) -> Option<(u64, u64)> {
        match ids.step(raw) {
            IdStep::Next { seq, lost } => Some((seq, lost)),
            IdStep::Stale => None,
        }
    }

    #[test]
    fn frame_ids_unwrap_and_count_gaps() {
        let mut ids = FrameIds::default();
        // Block id 1, the first of an acquisition, is seq 0 (as sim:'s).
        assert_eq!(next(&mut ids, 1), Some((0, 0)));
        assert_eq!(next(&mut ids, 2), Some((1, 0)));
        assert_eq!(next(&mut ids, 5), Some((4, 2)));
        assert_eq!(next(&mut ids, 5), None);
        assert_eq!(next(&mut ids, 3), None);
        // 16-bit block ids skip 0 when they wrap.
        let mut ids = FrameIds::default();
        assert_eq!(next(&mut ids, 65534), Some((65533, 0)));
        assert_eq!(next(&mut ids, 65535), Some((65534, 0)));
        assert_eq!(next(&mut ids, 1), Some((65535, 0)));
        assert_eq!(next(&mut ids, 3), Some((65537, 1)));
        // A frame that timed out used its id: arriving late it is stale.
        assert_eq!(ids.skip_one(), 65538);
        assert_eq!(next(&mut ids, 4), None);
        assert_eq!(next(&mut ids, 5), Some((65539, 0)));
        // Extended (64-bit) ids do not wrap.
        let mut ids = FrameIds::default();
        assert_eq!(next(&mut ids, 70_000), Some((69_999, 0)));
        assert_eq!(next(&mut ids, 70_003), Some((70_002, 2)));
        assert_eq!(next(&mut ids, 69_999), None);
    }

    /// The layouts against the codes as the PFNC tables print them
    /// (decimal, as Aravis's headers spell them).
    #[test]
    fn mono_layouts_follow_the_pfnc_codes() {
        assert_eq!(mono_layout(17_301_505), Some((8, 1))); // Mono8
        assert_eq!(mono_layout(17_825_797), Some((12, 2))); // Mono12
        assert_eq!(mono_layout(17_825_799), Some((16, 2))); // Mono16
        assert_eq!(mono_layout(17_825_829), Some((14, 2))); // Mono14
        assert_eq!(mono_layout(0x010C_0006), None); // Mono12Packed
        // The bits-per-pixel field of every code is the storage size.
        for code in [MONO_8, MONO_10, MONO_12, MONO_14, MONO_16] {
            let (_, bytes) = mono_layout(code).unwrap();
            assert_eq!(((code >> 16) & 0xFF) as usize, 8 * bytes);
        }
    }
}
