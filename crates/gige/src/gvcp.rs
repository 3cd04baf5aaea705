//! GVCP (GigE Vision Control Protocol) wire format: command headers,
//! acknowledge headers and status codes. Pure parsing and encoding, no state.
//!
//! Every GVCP datagram starts with an 8-byte header, big-endian:
//! command: `0x42, flags, command u16, length u16, req_id u16`;
//! acknowledge: `status u16, answer u16, length u16, ack_id u16`.

/// UDP port a GigE Vision device listens on for GVCP.
pub const GVCP_PORT: u16 = 3956;
/// First byte of every command ("key code").
pub const KEY_CODE: u8 = 0x42;
/// Command flag: the sender wants an acknowledge.
pub const FLAG_ACK_REQUIRED: u8 = 0x01;
/// Command flag (PACKETRESEND): 64-bit block ids follow.
pub const FLAG_EXTENDED_IDS: u8 = 0x10;
/// Largest GVCP datagram the specification allows (IP + UDP headers aside).
pub const MAX_DATAGRAM_BYTES: usize = 576 - 28;
/// Largest READMEM/WRITEMEM data block.
pub const MAX_MEMORY_BYTES: usize = 536;
/// Header size of commands and acknowledges.
pub const HEADER_BYTES: usize = 8;

/// GVCP command (and acknowledge = command + 1) codes.
pub mod command {
    pub const DISCOVERY: u16 = 0x0002;
    pub const FORCEIP: u16 = 0x0004;
    pub const PACKETRESEND: u16 = 0x0040;
    pub const READREG: u16 = 0x0080;
    pub const WRITEREG: u16 = 0x0082;
    pub const READMEM: u16 = 0x0084;
    pub const WRITEMEM: u16 = 0x0086;
    pub const PENDING: u16 = 0x0089;
    pub const EVENT: u16 = 0x00C0;
    pub const EVENTDATA: u16 = 0x00C2;
    pub const ACTION: u16 = 0x0100;
}

/// GEV status codes carried by acknowledges (and GVSP packets).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum Status {
    Success = 0x0000,
    NotImplemented = 0x8001,
    InvalidParameter = 0x8002,
    InvalidAddress = 0x8003,
    WriteProtect = 0x8004,
    BadAlignment = 0x8005,
    AccessDenied = 0x8006,
    Busy = 0x8007,
    PacketUnavailable = 0x800C,
    InvalidHeader = 0x800E,
    Error = 0x8FFF,
}

impl Status {
    pub fn code(self) -> u16 {
        self as u16
    }
}

/// A parsed command header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandHeader {
    pub flags: u8,
    pub command: u16,
    /// Payload length announced by the header, bytes.
    pub length: u16,
    pub req_id: u16,
}

impl CommandHeader {
    pub fn ack_required(&self) -> bool {
        self.flags & FLAG_ACK_REQUIRED != 0
    }
}

/// Why a datagram is not a GVCP command at all (the device stays silent:
/// the specification forbids answering datagrams without the key code).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NotACommand {
    TooShort,
    NoKeyCode,
}

/// Splits a datagram into its header and payload. The payload is what the
/// datagram actually carries; a mismatch with `length` is the caller's to
/// judge (it answers INVALID_HEADER).
pub fn parse_command(datagram: &[u8]) -> Result<(CommandHeader, &[u8]), NotACommand> {
    if datagram.len() < HEADER_BYTES {
        return Err(NotACommand::TooShort);
    }
    if datagram[0] != KEY_CODE {
        return Err(NotACommand::NoKeyCode);
    }
    let h = CommandHeader {
        flags: datagram[1],
        command: be16(&datagram[2..4]),
        length: be16(&datagram[4..6]),
        req_id: be16(&datagram[6..8]),
    };
    Ok((h, &datagram[HEADER_BYTES..]))
}

/// Encodes a command (the client side; used by tests and the fuzz corpus).
pub fn encode_command(flags: u8, command: u16, req_id: u16, payload: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(HEADER_BYTES + payload.len());
    v.push(KEY_CODE);
    v.push(flags);
    v.extend_from_slice(&command.to_be_bytes());
    v.extend_from_slice(&(payload.len() as u16).to_be_bytes());
    v.extend_from_slice(&req_id.to_be_bytes());
    v.extend_from_slice(payload);
    v
}

/// Encodes an acknowledge.
pub fn encode_ack(status: Status, answer: u16, ack_id: u16, payload: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(HEADER_BYTES + payload.len());
    v.extend_from_slice(&status.code().to_be_bytes());
    v.extend_from_slice(&answer.to_be_bytes());
    v.extend_from_slice(&(payload.len() as u16).to_be_bytes());
    v.extend_from_slice(&ack_id.to_be_bytes());
    v.extend_from_slice(payload);
    v
}

/// A parsed acknowledge (the client side).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ack<'a> {
    pub status: u16,
    pub answer: u16,
    pub ack_id: u16,
    pub payload: &'a [u8],
}

/// Parses an acknowledge; `None` when shorter than its header says.
pub fn parse_ack(datagram: &[u8]) -> Option<Ack<'_>> {
    if datagram.len() < HEADER_BYTES {
        return None;
    }
    let length = usize::from(be16(&datagram[4..6]));
    let payload = datagram.get(HEADER_BYTES..HEADER_BYTES + length)?;
    Some(Ack {
        status: be16(&datagram[0..2]),
        answer: be16(&datagram[2..4]),
        ack_id: be16(&datagram[6..8]),
        payload,
    })
}

pub(crate) fn be16(b: &[u8]) -> u16 {
    u16::from_be_bytes([b[0], b[1]])
}

pub(crate) fn be32(b: &[u8]) -> u32 {
    u32::from_be_bytes([b[0], b[1], b[2], b[3]])
}
