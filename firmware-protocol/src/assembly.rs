//! Host-side frame reassembly: leader → chunks → trailer into a caller buffer.
//!
//! The one rule that matters: a frame is only ever handed out as good when
//! every check passed — leader well-formed, every chunk of the same `seq` at
//! exactly the next expected offset, byte count equal to the leader's
//! `payload_len_bytes` and the trailer's `valid_len_bytes`, trailer status
//! OK, and the CRC-32C of the assembled bytes equal to the trailer's. Any
//! loss (a dropped chunk, a missing trailer, a CRC mismatch) drops the frame
//! and says why; there is no retransmission of frame data, because for a
//! live camera the next frame is worth more than the old one.

use crate::crc32c::crc32c;
use crate::message::{ErrorCode, FrameChunk, FrameLeader, FrameTrailer, Message};

/// Why a frame was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DropReason {
    /// A new leader arrived before this frame's trailer.
    MissingTrailer,
    /// A chunk or trailer carried a different `seq` than the frame in progress.
    SequenceMismatch { got_seq: u32 },
    /// A chunk did not start where the previous one ended (a chunk was lost).
    OffsetGap {
        expected_offset: u32,
        got_offset: u32,
    },
    /// Chunks carried more bytes than the leader announced.
    Oversize,
    /// The leader's `payload_len_bytes` does not fit the assembler's buffer.
    TooLargeForBuffer { payload_len_bytes: u32 },
    /// The leader's `payload_len_bytes` != width × height × bytes per pixel.
    InconsistentLeader,
    /// Received byte count disagrees with the trailer or the leader.
    LengthMismatch { received_len_bytes: u32 },
    /// CRC-32C of the received pixels differs from the trailer's.
    BadCrc { expected: u32, computed: u32 },
    /// The device reported the frame as bad (trailer status).
    DeviceStatus(ErrorCode),
    /// [`FrameAssembler::abort`] was called (e.g. idle timeout).
    Aborted,
}

/// A frame that passed every check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameInfo {
    pub leader: FrameLeader,
    /// Frames whose leaders were never seen between the previous leader and
    /// this one (sequence gap), e.g. because the link dropped them.
    pub frames_missed: u32,
}

/// Result of feeding one message to the assembler.
#[derive(Debug, PartialEq, Eq)]
pub enum AssemblyEvent<'a> {
    /// Not a stream message; handle it as a reply.
    NotStream,
    /// Consumed; the frame is still in progress (or the message was a stray
    /// piece of a frame already dropped, and was ignored).
    InProgress,
    /// A complete, verified frame; `data` is its payload.
    Frame { info: FrameInfo, data: &'a [u8] },
    /// The frame `seq` was discarded.
    Dropped { seq: u32, reason: DropReason },
}

#[derive(Debug, Clone, Copy)]
enum State {
    Idle,
    Receiving {
        leader: FrameLeader,
        frames_missed: u32,
        received_len: usize,
    },
}

/// Reassembles frames into a caller-provided buffer (no allocation).
pub struct FrameAssembler<B: AsMut<[u8]>> {
    buf: B,
    state: State,
    last_leader_seq: Option<u32>,
}

impl<B: AsMut<[u8]>> FrameAssembler<B> {
    /// `buf` must hold the largest frame payload expected.
    pub fn new(buf: B) -> Self {
        Self {
            buf,
            state: State::Idle,
            last_leader_seq: None,
        }
    }

    /// Forget sequence history (call when a new stream starts, so the
    /// restart at `seq` 0 is not counted as a gap).
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.last_leader_seq = None;
    }

    /// Drop the frame in progress, if any, returning its `seq`.
    pub fn abort(&mut self) -> Option<u32> {
        match core::mem::replace(&mut self.state, State::Idle) {
            State::Receiving { leader, .. } => Some(leader.seq),
            State::Idle => None,
        }
    }

    /// Feed one decoded message.
    pub fn push(&mut self, message: &Message<'_>) -> AssemblyEvent<'_> {
        match message {
            Message::FrameLeader(l) => self.on_leader(l),
            Message::FrameChunk(c) => self.on_chunk(c),
            Message::FrameTrailer(t) => self.on_trailer(t),
            _ => AssemblyEvent::NotStream,
        }
    }

    fn on_leader(&mut self, l: &FrameLeader) -> AssemblyEvent<'_> {
        let previous = self.abort();
        let frames_missed = match self.last_leader_seq {
            Some(s) => l.seq.wrapping_sub(s).wrapping_sub(1),
            None => 0,
        };
        self.last_leader_seq = Some(l.seq);
        let expected_len = u64::from(l.width_px)
            * u64::from(l.height_px)
            * l.pixel_format.bytes_per_pixel() as u64;
        let drop_new = if expected_len != u64::from(l.payload_len_bytes) {
            Some(DropReason::InconsistentLeader)
        } else if l.payload_len_bytes as usize > self.buf.as_mut().len() {
            Some(DropReason::TooLargeForBuffer {
                payload_len_bytes: l.payload_len_bytes,
            })
        } else {
            None
        };
        if let Some(seq) = previous {
            // The new frame may still be fine; it stays in progress, and its
            // own problems (if any) surface at its trailer.
            if drop_new.is_none() {
                self.start(l, frames_missed);
            }
            return AssemblyEvent::Dropped {
                seq,
                reason: DropReason::MissingTrailer,
            };
        }
        match drop_new {
            Some(reason) => AssemblyEvent::Dropped { seq: l.seq, reason },
            None => {
                self.start(l, frames_missed);
                AssemblyEvent::InProgress
            }
        }
    }

    fn start(&mut self, l: &FrameLeader, frames_missed: u32) {
        self.state = State::Receiving {
            leader: *l,
            frames_missed,
            received_len: 0,
        };
    }

    fn on_chunk(&mut self, c: &FrameChunk<'_>) -> AssemblyEvent<'_> {
        let State::Receiving {
            leader,
            received_len,
            ..
        } = &mut self.state
        else {
            return AssemblyEvent::InProgress;
        };
        let seq = leader.seq;
        let reason = if c.seq != seq {
            Some(DropReason::SequenceMismatch { got_seq: c.seq })
        } else if c.offset_bytes as usize != *received_len {
            Some(DropReason::OffsetGap {
                expected_offset: *received_len as u32,
                got_offset: c.offset_bytes,
            })
        } else if *received_len + c.data.len() > leader.payload_len_bytes as usize {
            Some(DropReason::Oversize)
        } else {
            None
        };
        if let Some(reason) = reason {
            self.state = State::Idle;
            return AssemblyEvent::Dropped { seq, reason };
        }
        let start = *received_len;
        let end = start + c.data.len();
        // payload_len_bytes <= buf.len() was checked at the leader.
        match self.buf.as_mut().get_mut(start..end) {
            Some(dst) => dst.copy_from_slice(c.data),
            None => {
                self.state = State::Idle;
                return AssemblyEvent::Dropped {
                    seq,
                    reason: DropReason::Oversize,
                };
            }
        }
        *received_len = end;
        AssemblyEvent::InProgress
    }

    fn on_trailer(&mut self, t: &FrameTrailer) -> AssemblyEvent<'_> {
        let State::Receiving {
            leader,
            frames_missed,
            received_len,
        } = core::mem::replace(&mut self.state, State::Idle)
        else {
            return AssemblyEvent::InProgress;
        };
        let seq = leader.seq;
        let dropped = |reason| AssemblyEvent::Dropped { seq, reason };
        if t.seq != seq {
            return dropped(DropReason::SequenceMismatch { got_seq: t.seq });
        }
        if t.status != ErrorCode::OK {
            return dropped(DropReason::DeviceStatus(t.status));
        }
        if t.valid_len_bytes as usize != received_len
            || received_len != leader.payload_len_bytes as usize
        {
            return dropped(DropReason::LengthMismatch {
                received_len_bytes: received_len as u32,
            });
        }
        let data = match self.buf.as_mut().get(..received_len) {
            Some(d) => d,
            None => return dropped(DropReason::Oversize),
        };
        let computed = crc32c(data);
        if computed != t.crc32c {
            return AssemblyEvent::Dropped {
                seq,
                reason: DropReason::BadCrc {
                    expected: t.crc32c,
                    computed,
                },
            };
        }
        AssemblyEvent::Frame {
            info: FrameInfo {
                leader,
                frames_missed,
            },
            data,
        }
    }
}
