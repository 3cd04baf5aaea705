//! GVSP (GigE Vision Stream Protocol): one frame as leader, payload and
//! trailer packets (standard 16-bit block ids, 24-bit packet ids), and the
//! store of recent frames that PACKETRESEND is served from.

use std::collections::VecDeque;

/// Packet content types (byte 4 of the header).
pub const CONTENT_LEADER: u8 = 1;
pub const CONTENT_TRAILER: u8 = 2;
pub const CONTENT_PAYLOAD: u8 = 3;
/// Payload type "image".
pub const PAYLOAD_TYPE_IMAGE: u16 = 0x0001;
/// Payload type "image" with the extended-chunk flag (bit 14): the image
/// leader as for [`PAYLOAD_TYPE_IMAGE`], and a payload of chunks (see
/// [`chunked_payload`]).
pub const PAYLOAD_TYPE_IMAGE_EXTENDED_CHUNK: u16 = 0x4001;
/// Bytes of a chunk trailer: chunk id and data length, both u32 big-endian.
pub const CHUNK_TRAILER_BYTES: usize = 8;
/// GVSP status: packet unavailable (answer to a resend we cannot serve).
pub const STATUS_PACKET_UNAVAILABLE: u16 = 0x800C;
/// IP + UDP + GVSP header bytes, which GigE Vision packet sizes include.
pub const OVERHEAD_BYTES: usize = 20 + 8 + 8;
/// GVSP header bytes.
pub const HEADER_BYTES: usize = 8;

/// The 8-byte header: status, block id, content type and packet id.
pub fn header(status: u16, block_id: u16, content: u8, packet_id: u32) -> [u8; 8] {
    let mut h = [0u8; 8];
    h[..2].copy_from_slice(&status.to_be_bytes());
    h[2..4].copy_from_slice(&block_id.to_be_bytes());
    let infos = (u32::from(content) << 24) | (packet_id & 0x00FF_FFFF);
    h[4..].copy_from_slice(&infos.to_be_bytes());
    h
}

/// What the leader describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageInfo {
    /// [`PAYLOAD_TYPE_IMAGE`], or [`PAYLOAD_TYPE_IMAGE_EXTENDED_CHUNK`] when
    /// the payload carries chunks.
    pub payload_type: u16,
    pub timestamp_ticks: u64,
    pub pixel_format: u32,
    pub width: u32,
    pub height: u32,
}

/// The packets of one frame: `[leader, payload…, trailer]`, packet ids
/// 0, 1…n, n+1. `packet_bytes` counts IP and UDP headers as GigE Vision does.
pub fn packetize(
    block_id: u16,
    info: &ImageInfo,
    data: &[u8],
    packet_bytes: usize,
) -> Vec<Vec<u8>> {
    let chunk = packet_bytes.saturating_sub(OVERHEAD_BYTES).max(4);
    let n_payload = data.len().div_ceil(chunk);
    let mut out = Vec::with_capacity(n_payload + 2);
    let mut leader = header(0, block_id, CONTENT_LEADER, 0).to_vec();
    leader.extend_from_slice(&0u16.to_be_bytes());
    leader.extend_from_slice(&info.payload_type.to_be_bytes());
    leader.extend_from_slice(&((info.timestamp_ticks >> 32) as u32).to_be_bytes());
    leader.extend_from_slice(&(info.timestamp_ticks as u32).to_be_bytes());
    for v in [info.pixel_format, info.width, info.height, 0, 0] {
        leader.extend_from_slice(&v.to_be_bytes());
    }
    leader.extend_from_slice(&[0, 0, 0, 0]); // x and y padding
    out.push(leader);
    for (i, c) in data.chunks(chunk).enumerate() {
        let mut p = header(0, block_id, CONTENT_PAYLOAD, i as u32 + 1).to_vec();
        p.extend_from_slice(c);
        out.push(p);
    }
    let mut trailer = header(0, block_id, CONTENT_TRAILER, n_payload as u32 + 1).to_vec();
    trailer.extend_from_slice(&0u16.to_be_bytes());
    trailer.extend_from_slice(&info.payload_type.to_be_bytes());
    trailer.extend_from_slice(&info.height.to_be_bytes());
    out.push(trailer);
    out
}

/// Pixels as they travel: Mono8 one byte each, Mono12/Mono16 16-bit little-endian.
pub fn pixel_bytes(pixels: &[u16], bytes_per_pixel: usize, out: &mut Vec<u8>) {
    out.clear();
    if bytes_per_pixel == 1 {
        out.extend(pixels.iter().map(|&p| p.min(255) as u8));
    } else {
        out.reserve(pixels.len() * 2);
        for p in pixels {
            out.extend_from_slice(&p.to_le_bytes());
        }
    }
}

/// Turns the image bytes in `data` into a chunk payload (GigE Vision
/// extended chunk mode): the image padded to a multiple of 4 bytes and
/// framed as chunk `image_id`, then each `(id, bytes)` of `chunks` (each a
/// multiple of 4 bytes long, never empty). Every chunk is its data followed
/// by a trailer `[id u32 BE][length u32 BE]`, so a client finds a chunk by
/// walking the trailers back from the end of the payload, as Aravis does.
pub fn chunked_payload(data: &mut Vec<u8>, image_id: u32, chunks: &[(u32, Vec<u8>)]) {
    let image_bytes = data.len().next_multiple_of(4);
    data.resize(image_bytes, 0);
    push_trailer(data, image_id, image_bytes);
    for (id, bytes) in chunks {
        data.extend_from_slice(bytes);
        push_trailer(data, *id, bytes.len());
    }
}

fn push_trailer(data: &mut Vec<u8>, id: u32, len: usize) {
    data.extend_from_slice(&id.to_be_bytes());
    data.extend_from_slice(&(len as u32).to_be_bytes());
}

/// Bytes [`chunked_payload`] makes of `image_bytes` of image and chunks of
/// `chunk_bytes` (their data lengths).
pub fn chunked_payload_bytes(
    image_bytes: usize,
    chunk_bytes: impl Iterator<Item = usize>,
) -> usize {
    image_bytes.next_multiple_of(4)
        + CHUNK_TRAILER_BYTES
        + chunk_bytes.map(|n| n + CHUNK_TRAILER_BYTES).sum::<usize>()
}

/// The next block id after `id` (16-bit ids skip 0).
pub fn next_block_id(id: u16) -> u16 {
    if id == u16::MAX { 1 } else { id + 1 }
}

/// Recent frames kept for PACKETRESEND, bounded by bytes.
pub struct ResendStore {
    frames: VecDeque<(u16, Vec<Vec<u8>>, usize)>,
    bytes: usize,
    max_bytes: usize,
}

impl ResendStore {
    pub fn new(max_bytes: usize) -> Self {
        Self {
            frames: VecDeque::new(),
            bytes: 0,
            max_bytes,
        }
    }

    pub fn clear(&mut self) {
        self.frames.clear();
        self.bytes = 0;
    }

    /// Keep a frame's packets; the oldest go when over the byte budget (the
    /// newest frame is always kept).
    pub fn insert(&mut self, block_id: u16, packets: Vec<Vec<u8>>) {
        let n: usize = packets.iter().map(Vec::len).sum();
        self.frames.retain(|f| f.0 != block_id);
        self.frames.push_back((block_id, packets, n));
        self.bytes += n;
        while self.bytes > self.max_bytes && self.frames.len() > 1 {
            if let Some(f) = self.frames.pop_front() {
                self.bytes -= f.2;
            }
        }
        self.bytes = self.frames.iter().map(|f| f.2).sum();
    }

    /// The packets asked for, or `PACKET_UNAVAILABLE` stand-ins for those
    /// this device no longer (or never) had. `last = 0xFFFFFF` means "to the
    /// end of the block". At most `limit` packets.
    pub fn resend(&self, block_id: u64, first: u32, last: u32, limit: usize) -> Vec<Vec<u8>> {
        let bid = block_id as u16;
        let frame = (block_id <= u64::from(u16::MAX))
            .then(|| self.frames.iter().find(|f| f.0 == bid))
            .flatten();
        let mut out = Vec::new();
        match frame {
            Some((_, packets, _)) => {
                let n = packets.len() as u32;
                let last = if last == 0x00FF_FFFF {
                    n.saturating_sub(1)
                } else {
                    last
                };
                for id in first..=last {
                    if out.len() >= limit {
                        break;
                    }
                    match packets.get(id as usize) {
                        Some(p) => out.push(p.clone()),
                        None => out.push(
                            header(STATUS_PACKET_UNAVAILABLE, bid, CONTENT_PAYLOAD, id).to_vec(),
                        ),
                    }
                }
            }
            None => {
                let last = if last == 0x00FF_FFFF { first } else { last };
                for id in first..=last.min(first.saturating_add(limit as u32 - 1)) {
                    out.push(header(STATUS_PACKET_UNAVAILABLE, bid, CONTENT_PAYLOAD, id).to_vec());
                }
            }
        }
        out
    }
}

/// Injected stream faults: each GVSP packet (first sends and resends) is
/// dropped with probability `loss`, or held back behind the next packet
/// with probability `reorder`. Seeded, so a run is reproducible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamFaults {
    pub loss: f64,
    pub reorder: f64,
    pub seed: u64,
}

impl Default for StreamFaults {
    fn default() -> Self {
        Self {
            loss: 0.0,
            reorder: 0.0,
            seed: 1,
        }
    }
}

/// Applies [`StreamFaults`] to a sequence of packets.
pub struct FaultInjector {
    cfg: StreamFaults,
    rng: gloam_grabber::faults::SplitMix,
    held: Option<Vec<u8>>,
    pub dropped: u64,
    pub reordered: u64,
}

impl FaultInjector {
    pub fn new(cfg: StreamFaults) -> Self {
        Self {
            rng: gloam_grabber::faults::SplitMix::new(cfg.seed),
            cfg,
            held: None,
            dropped: 0,
            reordered: 0,
        }
    }

    /// The packets to send now in place of `packet` (none, it, or it and
    /// one held back earlier).
    pub fn apply(&mut self, packet: Vec<u8>, out: &mut Vec<Vec<u8>>) {
        if self.cfg.loss > 0.0 && self.rng.unit() < self.cfg.loss {
            self.dropped += 1;
            return;
        }
        if self.cfg.reorder > 0.0 && self.held.is_none() && self.rng.unit() < self.cfg.reorder {
            self.reordered += 1;
            self.held = Some(packet);
            return;
        }
        out.push(packet);
        if let Some(h) = self.held.take() {
            out.push(h);
        }
    }

    /// Whatever is still held back.
    pub fn flush(&mut self, out: &mut Vec<Vec<u8>>) {
        if let Some(h) = self.held.take() {
            out.push(h);
        }
    }
}
