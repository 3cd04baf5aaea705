//! USB bulk transport helpers.
//!
//! On USB each message (un-framed, CRC included, no COBS) is one bulk
//! *transfer*: a run of max-size packets ended by a short packet, or by a
//! zero-length packet (ZLP) when the message length is an exact multiple of
//! the max packet size. That is the standard USB rule for delimiting
//! transfers, so host stacks (nusb, rusb, WinUSB) complete a read exactly at
//! a message boundary without any length prefix.

use crate::error::FrameError;

/// Bulk max packet size at USB 2.0 high speed.
pub const USB_HS_MAX_PACKET_LEN: usize = 512;

/// Iterator over the packets of one transfer; see [`packets`].
#[derive(Debug, Clone)]
pub struct Packets<'a> {
    rest: &'a [u8],
    max_packet_len: usize,
    done: bool,
}

/// Split `message` into bulk packets of at most `max_packet_len` bytes
/// (clamped to ≥ 1), ending with a short packet or, if the last packet would
/// be full (or the message is empty), an extra zero-length packet.
#[must_use]
pub fn packets(message: &[u8], max_packet_len: usize) -> Packets<'_> {
    Packets {
        rest: message,
        max_packet_len: max_packet_len.max(1),
        done: false,
    }
}

/// Number of packets (including any ZLP) [`packets`] yields.
#[must_use]
pub const fn packet_count(message_len: usize, max_packet_len: usize) -> usize {
    let m = if max_packet_len == 0 {
        1
    } else {
        max_packet_len
    };
    message_len / m + 1
}

impl<'a> Iterator for Packets<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        if self.done {
            return None;
        }
        let n = self.rest.len().min(self.max_packet_len);
        let (p, rest) = self.rest.split_at(n);
        self.rest = rest;
        if n < self.max_packet_len {
            // Short packet (possibly the ZLP): the transfer ends here.
            self.done = true;
        }
        Some(p)
    }
}

/// Reassembles bulk packets into transfers (messages) in a caller buffer.
///
/// Needed where packets arrive one at a time (device firmware, packet-level
/// emulators); a host reading whole transfers gets messages directly.
pub struct TransferAssembler<B: AsMut<[u8]>> {
    buf: B,
    len: usize,
    max_packet_len: usize,
    discarding: bool,
}

impl<B: AsMut<[u8]>> TransferAssembler<B> {
    /// Assembler for packets of at most `max_packet_len` bytes (clamped ≥ 1).
    pub fn new(buf: B, max_packet_len: usize) -> Self {
        Self {
            buf,
            len: 0,
            max_packet_len: max_packet_len.max(1),
            discarding: false,
        }
    }

    /// Drop any partial transfer (e.g. after a bus reset).
    pub fn reset(&mut self) {
        self.len = 0;
        self.discarding = false;
    }

    /// Add one received packet. Returns the whole transfer when `packet` is
    /// short (ends it). An over-long packet is reported as
    /// [`FrameError::Corrupt`]; a transfer larger than the buffer as
    /// [`FrameError::Overrun`] once it ends. Either way the next packet
    /// starts a fresh transfer.
    pub fn push_packet(&mut self, packet: &[u8]) -> Result<Option<&[u8]>, FrameError> {
        if packet.len() > self.max_packet_len {
            self.reset();
            return Err(FrameError::Corrupt);
        }
        let ends = packet.len() < self.max_packet_len;
        if !self.discarding {
            let buf = self.buf.as_mut();
            match buf.get_mut(self.len..self.len + packet.len()) {
                Some(dst) => {
                    dst.copy_from_slice(packet);
                    self.len += packet.len();
                }
                None => self.discarding = true,
            }
        }
        if !ends {
            return Ok(None);
        }
        if self.discarding {
            self.reset();
            return Err(FrameError::Overrun);
        }
        let n = self.len;
        self.len = 0;
        Ok(Some(&self.buf.as_mut()[..n]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zlp_rules() {
        let msg = [7u8; 1024];
        let ps: heapless_vec::V = packets(&msg, 512).map(<[u8]>::len).collect();
        assert_eq!(ps.as_slice(), &[512, 512, 0]);
        let ps: heapless_vec::V = packets(&msg[..700], 512).map(<[u8]>::len).collect();
        assert_eq!(ps.as_slice(), &[512, 188]);
        let ps: heapless_vec::V = packets(&[], 512).map(<[u8]>::len).collect();
        assert_eq!(ps.as_slice(), &[0]);
        assert_eq!(packet_count(1024, 512), 3);
        assert_eq!(packet_count(700, 512), 2);
    }

    #[test]
    fn reassemble() {
        let msg: [u8; 1100] = core::array::from_fn(|i| i as u8);
        let mut asm = TransferAssembler::new([0u8; 2048], 512);
        let mut got = None;
        for p in packets(&msg, 512) {
            if let Some(m) = asm.push_packet(p).unwrap() {
                got = Some(m.len());
            }
        }
        assert_eq!(got, Some(1100));
        let mut small = TransferAssembler::new([0u8; 600], 512);
        let mut res = Ok(None);
        for p in packets(&msg, 512) {
            res = small.push_packet(p).map(|o| o.map(<[u8]>::len));
        }
        assert_eq!(res, Err(FrameError::Overrun));
        assert_eq!(small.push_packet(&[1, 2]).unwrap(), Some(&[1u8, 2][..]));
    }

    /// Tiny fixed-capacity collector so the tests stay alloc-free.
    mod heapless_vec {
        pub struct V {
            a: [usize; 8],
            n: usize,
        }
        impl V {
            pub fn as_slice(&self) -> &[usize] {
                &self.a[..self.n]
            }
        }
        impl FromIterator<usize> for V {
            fn from_iter<I: IntoIterator<Item = usize>>(it: I) -> Self {
                let mut v = V { a: [0; 8], n: 0 };
                for x in it {
                    v.a[v.n] = x;
                    v.n += 1;
                }
                v
            }
        }
    }
}
