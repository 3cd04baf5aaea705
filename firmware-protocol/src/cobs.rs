//! Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999), canonical
//! form, with `0x00` as the frame delimiter.
//!
//! COBS is used on the serial link because it gives unambiguous resync: a
//! `0x00` byte can only ever be a delimiter, so after any corruption the
//! receiver loses at most the frame in flight and re-locks on the next `0x00`.
//! Overhead is at most one byte per 254 plus the delimiter.
//!
//! Both directions are written for speed on large pixel chunks: runs of
//! non-zero bytes are found eight bytes at a time (SWAR) and moved with
//! `copy_from_slice` rather than byte by byte.

use crate::error::{EncodeError, FrameError};

/// Longest COBS block: code byte `0xFF` followed by 254 data bytes.
const MAX_RUN_LEN: usize = 254;

/// Worst-case COBS length of `data_len` bytes, *excluding* the `0x00`
/// delimiter: one code byte per started block of 254.
#[must_use]
pub const fn max_encoded_len(data_len: usize) -> usize {
    data_len + data_len / MAX_RUN_LEN + 1
}

/// Position of the first `0x00` in `s`.
///
/// Scans eight bytes per step with the classic "has zero byte" bit trick;
/// the lowest flagged byte is always a true zero (false positives can only
/// appear above a real zero), so the answer is exact without a rescan.
#[inline]
pub(crate) fn find_zero(s: &[u8]) -> Option<usize> {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    let mut words = s.chunks_exact(8);
    let mut base = 0usize;
    for w in &mut words {
        let mut bytes = [0u8; 8];
        bytes.copy_from_slice(w);
        let x = u64::from_le_bytes(bytes);
        let z = x.wrapping_sub(LO) & !x & HI;
        if z != 0 {
            return Some(base + (z.trailing_zeros() / 8) as usize);
        }
        base += 8;
    }
    words
        .remainder()
        .iter()
        .position(|&b| b == 0)
        .map(|p| p + base)
}

/// Exact zero-byte mask: `0x80` in every byte of `x` that is `0x00`, `0`
/// elsewhere (no borrow-propagation false positives, unlike the cheaper
/// test in [`find_zero`]).
#[inline]
const fn zero_mask(x: u64) -> u64 {
    const M: u64 = 0x7F7F_7F7F_7F7F_7F7F;
    !(((x & M).wrapping_add(M)) | x | M)
}

#[inline]
fn load_word(bytes: &[u8]) -> Option<u64> {
    let w: [u8; 8] = bytes.get(..8)?.try_into().ok()?;
    Some(u64::from_le_bytes(w))
}

/// Incremental COBS encoder writing into a caller-provided buffer.
///
/// Lets a message be encoded from several pieces (header, pixel data
/// borrowed straight from the frame buffer, CRC) without first copying them
/// into one contiguous buffer.
pub struct CobsEncoder<'o> {
    out: &'o mut [u8],
    /// Index of the current block's (not yet written) code byte.
    code_idx: usize,
    /// Next free output index.
    pos: usize,
    /// Data bytes in the current block so far (0..=254).
    run_len: usize,
    /// Set once any write failed; the encoder then only tracks `needed_len`.
    needed_len: usize,
    overflowed: bool,
}

impl<'o> CobsEncoder<'o> {
    /// Start encoding into `out`.
    pub fn new(out: &'o mut [u8]) -> Self {
        let overflowed = out.is_empty();
        Self {
            out,
            code_idx: 0,
            pos: 1,
            run_len: 0,
            needed_len: 1,
            overflowed,
        }
    }

    /// Append the bytes of `data` to the encoded stream.
    pub fn push(&mut self, mut data: &[u8]) {
        if !self.overflowed {
            let used = self.push_words(data);
            data = &data[used..];
        }
        while !data.is_empty() {
            if self.run_len == MAX_RUN_LEN {
                // Full block and more data follows: close it with 0xFF (no
                // implied zero) and open the next one.
                self.close_block(0xFF);
            }
            let take = (MAX_RUN_LEN - self.run_len).min(data.len());
            let window = &data[..take];
            match find_zero(window) {
                Some(z) => {
                    self.copy(&window[..z]);
                    self.run_len += z;
                    // run_len <= 253 here, so the code fits in a u8.
                    self.close_block((self.run_len + 1) as u8);
                    data = &data[z + 1..];
                }
                None => {
                    self.copy(window);
                    self.run_len += take;
                    data = &data[take..];
                }
            }
        }
    }

    /// Fast path: eight input bytes per step, stored as one word; each zero
    /// byte in the word then only costs a code-byte write. Near the 254-byte
    /// block limit a word is done byte by byte. Stops (returning the bytes
    /// consumed) when fewer than 8 input bytes remain or the output might not
    /// hold the next word; [`Self::push`] finishes with the general path.
    fn push_words(&mut self, data: &[u8]) -> usize {
        let out = &mut *self.out;
        let mut pos = self.pos;
        let mut code = self.code_idx;
        let mut used = 0;
        for w in data.chunks_exact(8) {
            // Worst case this word needs 8 bytes plus one 0xFF split.
            if pos + 9 > out.len() {
                break;
            }
            if pos - code <= MAX_RUN_LEN + 1 - 8 {
                out[pos..pos + 8].copy_from_slice(w);
                let mut z = load_word(w).map_or(0, zero_mask);
                while z != 0 {
                    let zp = pos + (z.trailing_zeros() / 8) as usize;
                    // zp - code <= 254 here, the finished block's code.
                    out[code] = (zp - code) as u8;
                    code = zp;
                    z &= z - 1;
                }
                pos += 8;
            } else {
                for &b in w {
                    if pos - code == MAX_RUN_LEN + 1 {
                        out[code] = 0xFF;
                        code = pos;
                        pos += 1;
                    }
                    out[pos] = b;
                    if b == 0 {
                        out[code] = (pos - code) as u8;
                        code = pos;
                    }
                    pos += 1;
                }
            }
            used += 8;
        }
        self.pos = pos;
        self.code_idx = code;
        self.run_len = pos - code - 1;
        self.needed_len = self.needed_len.max(pos);
        used
    }

    fn copy(&mut self, bytes: &[u8]) {
        let end = self.pos + bytes.len();
        self.needed_len = self.needed_len.max(end);
        if !self.overflowed {
            match self.out.get_mut(self.pos..end) {
                Some(dst) => dst.copy_from_slice(bytes),
                None => self.overflowed = true,
            }
        }
        self.pos = end;
    }

    /// Write `code` for the current block and reserve the next code byte.
    fn close_block(&mut self, code: u8) {
        if let Some(slot) = self.out.get_mut(self.code_idx) {
            *slot = code;
        } else {
            self.overflowed = true;
        }
        self.code_idx = self.pos;
        self.pos += 1;
        self.run_len = 0;
        self.needed_len = self.needed_len.max(self.pos);
    }

    /// Finish the last block and return the encoded length (no delimiter).
    pub fn finish(mut self) -> Result<usize, EncodeError> {
        self.finish_inner()
    }

    /// Finish and append the `0x00` delimiter; returns the total length.
    pub fn finish_with_delimiter(mut self) -> Result<usize, EncodeError> {
        let n = self.finish_inner().map_err(|e| match e {
            EncodeError::BufferTooSmall { needed_len } => EncodeError::BufferTooSmall {
                needed_len: needed_len + 1,
            },
            other => other,
        })?;
        match self.out.get_mut(n) {
            Some(b) => {
                *b = 0;
                Ok(n + 1)
            }
            None => Err(EncodeError::BufferTooSmall { needed_len: n + 1 }),
        }
    }

    fn finish_inner(&mut self) -> Result<usize, EncodeError> {
        let code = if self.run_len == MAX_RUN_LEN {
            0xFF
        } else {
            // run_len <= 253 here.
            (self.run_len + 1) as u8
        };
        match self.out.get_mut(self.code_idx) {
            Some(slot) if !self.overflowed => *slot = code,
            _ => self.overflowed = true,
        }
        if self.overflowed {
            Err(EncodeError::BufferTooSmall {
                needed_len: self.needed_len,
            })
        } else {
            Ok(self.pos)
        }
    }
}

/// COBS-encode `data` into `out` and append the `0x00` delimiter.
/// Returns the number of bytes written.
pub fn encode_frame(data: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut enc = CobsEncoder::new(out);
    enc.push(data);
    enc.finish_with_delimiter()
}

/// Decode one complete COBS frame (without its delimiter) into `out`.
/// Returns the decoded length.
pub fn decode_frame(encoded: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut acc = CobsAccumulator::new(out);
    let (_, first) = acc.feed(encoded);
    if let Feed::Error(e) = first {
        return Err(e);
    }
    match acc.feed(&[0]).1 {
        Feed::Frame(f) => Ok(f.len()),
        Feed::Error(e) => Err(e),
        // An empty encoded input is not a frame at all.
        Feed::NeedMore => Err(FrameError::Corrupt),
    }
}

/// What [`CobsAccumulator::feed`] found.
#[derive(Debug, PartialEq, Eq)]
pub enum Feed<'a> {
    /// All input consumed, no frame completed yet.
    NeedMore,
    /// A complete frame's decoded bytes (CRC not yet checked: pass them to
    /// [`crate::decode_message`]).
    Frame(&'a [u8]),
    /// A damaged or oversized frame was dropped; the stream is resynchronised.
    Error(FrameError),
}

/// Incremental COBS decoder for a serial byte stream.
///
/// Takes the stream in arbitrarily sized pieces, decodes in a single pass
/// straight into the caller's buffer (so the buffer bounds the *decoded*
/// message size), never panics, and resynchronises at every `0x00`. Empty
/// frames (back-to-back delimiters) are skipped silently so a sender may
/// emit a lone `0x00` to flush a receiver.
pub struct CobsAccumulator<B: AsMut<[u8]>> {
    buf: B,
    len: usize,
    /// Data bytes still expected in the current block; 0 = next byte is a code.
    block_remaining: usize,
    /// The previous block ended with an implied zero that is emitted only if
    /// another block follows (the last block's implied zero is dropped).
    zero_pending: bool,
    /// At least one code byte of the current frame has been seen.
    in_frame: bool,
    /// Overrun: skip everything up to the next delimiter.
    discarding: bool,
}

impl<B: AsMut<[u8]>> CobsAccumulator<B> {
    /// New accumulator writing decoded frames into `buf` (a `&mut [u8]` or
    /// an owned `[u8; N]`). A frame that
    /// decodes to more than `buf.len()` bytes is reported as
    /// [`FrameError::Overrun`].
    pub fn new(buf: B) -> Self {
        Self {
            buf,
            len: 0,
            block_remaining: 0,
            zero_pending: false,
            in_frame: false,
            discarding: false,
        }
    }

    /// Fast path from a code byte up to the next `0x00` (or the end of
    /// `input`). That stretch is known to hold no delimiter, so no per-block
    /// zero checks are needed, and it decodes to the very same bytes with
    /// each code byte replaced by the block's implied `0x00` — except code
    /// bytes that follow a `0xFF` block (or start the frame), which are
    /// dropped. So the bytes are moved in large windows with
    /// `copy_from_slice` under a running input→output offset, and one walk
    /// of the code chain writes the zeros and adjusts the offset at each
    /// dropped code byte. Returns the input consumed.
    fn decode_segment(&mut self, input: &[u8]) -> usize {
        /// Copy-ahead window: ≥ 255 so one copy always covers the next code.
        const WINDOW_LEN: usize = 512;
        let buf = self.buf.as_mut();
        // A segment decodes to at most its own length, so limiting it to the
        // free space keeps the fast path overrun-free (and bounds the scan).
        let room = buf.len().saturating_sub(self.len + 1);
        let window = &input[..input.len().min(room)];
        let seg_len = find_zero(window).unwrap_or(window.len());
        let seg = &input[..seg_len];
        if seg.is_empty() {
            return 0;
        }
        // Mapping: input index `x` (>= src_start) goes to output
        // `out_base + x - src_start`.
        let mut out_base = self.len;
        let mut src_start = usize::from(!self.zero_pending);
        let mut copied_to = src_start;
        let mut k = 0usize; // current code byte
        let mut zero_at_k = self.zero_pending;
        loop {
            while copied_to <= k.max(src_start) && copied_to < seg_len {
                let end = (copied_to + WINDOW_LEN).min(seg_len);
                let dst = out_base + copied_to - src_start;
                buf[dst..dst + end - copied_to].copy_from_slice(&seg[copied_to..end]);
                copied_to = end;
            }
            if zero_at_k {
                buf[out_base + k - src_start] = 0;
            }
            let code = usize::from(seg[k]);
            let next = k + code;
            if next >= seg_len {
                // Last block of the segment: move the rest of its bytes.
                if copied_to < seg_len {
                    let dst = out_base + copied_to - src_start;
                    buf[dst..dst + seg_len - copied_to].copy_from_slice(&seg[copied_to..]);
                }
                self.block_remaining = next - seg_len;
                self.zero_pending = code != 0xFF;
                break;
            }
            if code == 0xFF {
                // Finish this block under the current offset...
                if copied_to < next {
                    let dst = out_base + copied_to - src_start;
                    buf[dst..dst + next - copied_to].copy_from_slice(&seg[copied_to..next]);
                }
                // ...then the code byte at `next` produces no output: shift by one.
                out_base += next - src_start;
                src_start = next + 1;
                // Re-copy anything already moved under the old offset.
                copied_to = src_start;
                zero_at_k = false;
            } else {
                zero_at_k = true;
            }
            k = next;
        }
        self.len = out_base + seg_len.max(src_start) - src_start;
        self.in_frame = true;
        seg_len
    }

    /// Drop any partial frame (e.g. after a link timeout).
    pub fn reset(&mut self) {
        self.len = 0;
        self.block_remaining = 0;
        self.zero_pending = false;
        self.in_frame = false;
        self.discarding = false;
    }

    /// Consume bytes from `input` until a frame completes, an error is found
    /// or the input runs out. Returns how many bytes were consumed; call
    /// again with the rest of the input after handling a `Frame`/`Error`.
    pub fn feed(&mut self, input: &[u8]) -> (usize, Feed<'_>) {
        let mut i = 0usize;
        while i < input.len() {
            let rest = &input[i..];
            if self.discarding {
                match find_zero(rest) {
                    Some(z) => {
                        self.reset();
                        return (i + z + 1, Feed::Error(FrameError::Overrun));
                    }
                    None => return (input.len(), Feed::NeedMore),
                }
            }
            if self.block_remaining == 0 {
                let used = self.decode_segment(rest);
                if used > 0 {
                    i += used;
                    continue;
                }
                let code = rest[0];
                i += 1;
                if code == 0 {
                    if !self.in_frame {
                        continue; // empty frame: ignore
                    }
                    let n = self.len;
                    self.reset();
                    return (i, Feed::Frame(&self.buf.as_mut()[..n]));
                }
                if self.zero_pending {
                    if self.len >= self.buf.as_mut().len() {
                        self.discarding = true;
                        continue;
                    }
                    self.buf.as_mut()[self.len] = 0;
                    self.len += 1;
                }
                self.in_frame = true;
                self.block_remaining = usize::from(code) - 1;
                self.zero_pending = code != 0xFF;
                continue;
            }
            // Fast path: move up to 8 block bytes as one word (over-copying
            // into buffer slack that later bytes overwrite), checking the
            // block's part of the word for a stray delimiter.
            if let Some(x) = load_word(rest) {
                let n = self.block_remaining.min(8);
                let keep = if n == 8 {
                    u64::MAX
                } else {
                    (1u64 << (8 * n)) - 1
                };
                if zero_mask(x) & keep == 0 {
                    if let Some(dst) = self.buf.as_mut().get_mut(self.len..self.len + 8) {
                        dst.copy_from_slice(&x.to_le_bytes());
                        self.len += n;
                        self.block_remaining -= n;
                        i += n;
                        continue;
                    }
                }
            }
            let take = self.block_remaining.min(rest.len());
            let window = &rest[..take];
            let zero_at = find_zero(window);
            let n = zero_at.unwrap_or(take);
            match self.buf.as_mut().get_mut(self.len..self.len + n) {
                Some(dst) => dst.copy_from_slice(&window[..n]),
                None => {
                    self.discarding = true;
                    continue;
                }
            }
            self.len += n;
            self.block_remaining -= n;
            i += n;
            if zero_at.is_some() {
                // A delimiter inside a block: the frame lost bytes.
                self.reset();
                return (i + 1, Feed::Error(FrameError::Corrupt));
            }
        }
        (input.len(), Feed::NeedMore)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enc(data: &[u8]) -> ([u8; 600], usize) {
        let mut out = [0u8; 600];
        let n = encode_frame(data, &mut out).unwrap();
        (out, n)
    }

    #[test]
    fn wikipedia_examples() {
        let cases: &[(&[u8], &[u8])] = &[
            (&[0x00], &[0x01, 0x01, 0x00]),
            (&[0x00, 0x00], &[0x01, 0x01, 0x01, 0x00]),
            (&[0x00, 0x11, 0x00], &[0x01, 0x02, 0x11, 0x01, 0x00]),
            (
                &[0x11, 0x22, 0x00, 0x33],
                &[0x03, 0x11, 0x22, 0x02, 0x33, 0x00],
            ),
            (
                &[0x11, 0x22, 0x33, 0x44],
                &[0x05, 0x11, 0x22, 0x33, 0x44, 0x00],
            ),
            (
                &[0x11, 0x00, 0x00, 0x00],
                &[0x02, 0x11, 0x01, 0x01, 0x01, 0x00],
            ),
            (&[], &[0x01, 0x00]),
        ];
        for (raw, wire) in cases {
            let (out, n) = enc(raw);
            assert_eq!(&out[..n], *wire, "encoding {raw:02x?}");
            let mut dec = [0u8; 16];
            if !raw.is_empty() {
                let m = decode_frame(&wire[..wire.len() - 1], &mut dec).unwrap();
                assert_eq!(&dec[..m], *raw);
            }
        }
    }

    #[test]
    fn long_runs() {
        // 254 non-zero bytes -> FF + data (no trailing 01 block).
        let data: [u8; 254] = core::array::from_fn(|i| (i + 1) as u8);
        let (out, n) = enc(&data);
        assert_eq!(n, 256);
        assert_eq!(out[0], 0xFF);
        assert_eq!(out[255], 0);
        // 255 bytes -> FF <254> 02 <1> 00
        let data: [u8; 255] = core::array::from_fn(|i| (i % 255 + 1) as u8);
        let (out, n) = enc(&data);
        assert_eq!(n, 258);
        assert_eq!(out[255], 0x02);
        let mut dec = [0u8; 300];
        let m = decode_frame(&out[..n - 1], &mut dec).unwrap();
        assert_eq!(&dec[..m], &data[..]);
        assert_eq!(max_encoded_len(255), 257);
    }

    #[test]
    fn find_zero_matches_scalar() {
        let mut v = [0x80u8; 40];
        for z in 0..40 {
            v.fill(0x80);
            v[z] = 0;
            if z + 3 < 40 {
                v[z + 3] = 0;
            }
            assert_eq!(find_zero(&v), Some(z));
        }
        v.fill(1);
        assert_eq!(find_zero(&v), None);
    }

    #[test]
    fn accumulator_resyncs() {
        let mut buf = [0u8; 8];
        let mut acc = CobsAccumulator::new(&mut buf);
        // Truncated block (code says 4 data bytes, delimiter after 1).
        let (n, f) = acc.feed(&[0x05, 0x11, 0x00, 0x02, 0x22, 0x00]);
        assert_eq!((n, f), (3, Feed::Error(FrameError::Corrupt)));
        let (n, f) = acc.feed(&[0x02, 0x22, 0x00]);
        assert_eq!(n, 3);
        assert_eq!(f, Feed::Frame(&[0x22][..]));
        // Overrun then a good frame.
        let (n, f) = acc.feed(&[0x0A, 1, 2, 3, 4, 5, 6, 7, 8, 9, 0x00, 0x02, 0x33, 0x00]);
        assert_eq!((n, f), (11, Feed::Error(FrameError::Overrun)));
        let (_, f) = acc.feed(&[0x02, 0x33, 0x00]);
        assert_eq!(f, Feed::Frame(&[0x33][..]));
    }
}
