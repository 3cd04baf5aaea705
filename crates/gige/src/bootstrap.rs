//! Bootstrap register addresses (GigE Vision 2.0, table "bootstrap
//! registers") that gloam's device implements, and the constants it
//! reports in them.

pub const VERSION: u32 = 0x0000;
pub const DEVICE_MODE: u32 = 0x0004;
pub const MAC_HIGH: u32 = 0x0008;
pub const MAC_LOW: u32 = 0x000C;
pub const SUPPORTED_IP_CONFIGURATION: u32 = 0x0010;
pub const CURRENT_IP_CONFIGURATION: u32 = 0x0014;
pub const CURRENT_IP: u32 = 0x0024;
pub const CURRENT_SUBNET_MASK: u32 = 0x0034;
pub const CURRENT_GATEWAY: u32 = 0x0044;
pub const MANUFACTURER_NAME: u32 = 0x0048;
pub const MODEL_NAME: u32 = 0x0068;
pub const DEVICE_VERSION: u32 = 0x0088;
pub const MANUFACTURER_INFO: u32 = 0x00A8;
pub const SERIAL_NUMBER: u32 = 0x00D8;
pub const USER_DEFINED_NAME: u32 = 0x00E8;
/// End of the block a DISCOVERY_ACK mirrors (0x0000..0x00F8).
pub const DISCOVERY_DATA_END: u32 = 0x00F8;
pub const FIRST_URL: u32 = 0x0200;
pub const SECOND_URL: u32 = 0x0400;
pub const URL_BYTES: u32 = 512;
pub const NUMBER_OF_INTERFACES: u32 = 0x0600;
pub const PERSISTENT_IP: u32 = 0x064C;
pub const PERSISTENT_SUBNET_MASK: u32 = 0x065C;
pub const PERSISTENT_GATEWAY: u32 = 0x066C;
pub const NUMBER_OF_MESSAGE_CHANNELS: u32 = 0x0900;
pub const NUMBER_OF_STREAM_CHANNELS: u32 = 0x0904;
pub const GVCP_CAPABILITY: u32 = 0x0934;
pub const HEARTBEAT_TIMEOUT: u32 = 0x0938;
pub const TIMESTAMP_TICK_FREQUENCY_HIGH: u32 = 0x093C;
pub const TIMESTAMP_TICK_FREQUENCY_LOW: u32 = 0x0940;
pub const TIMESTAMP_CONTROL: u32 = 0x0944;
pub const TIMESTAMP_VALUE_HIGH: u32 = 0x0948;
pub const TIMESTAMP_VALUE_LOW: u32 = 0x094C;
pub const GVCP_CONFIGURATION: u32 = 0x0954;
pub const CONTROL_CHANNEL_PRIVILEGE: u32 = 0x0A00;
pub const STREAM_CHANNEL_PORT: u32 = 0x0D00;
pub const STREAM_CHANNEL_PACKET_SIZE: u32 = 0x0D04;
pub const STREAM_CHANNEL_PACKET_DELAY: u32 = 0x0D08;
pub const STREAM_CHANNEL_DESTINATION: u32 = 0x0D18;
pub const STREAM_CHANNEL_SOURCE_PORT: u32 = 0x0D1C;
pub const STREAM_CHANNEL_CAPABILITY: u32 = 0x0D20;
pub const STREAM_CHANNEL_CONFIGURATION: u32 = 0x0D24;

/// Size of each bootstrap string field, by its address.
pub fn string_field(addr: u32) -> Option<(u32, u32)> {
    [
        (MANUFACTURER_NAME, 32),
        (MODEL_NAME, 32),
        (DEVICE_VERSION, 32),
        (MANUFACTURER_INFO, 48),
        (SERIAL_NUMBER, 16),
        (USER_DEFINED_NAME, 16),
        (FIRST_URL, URL_BYTES),
        (SECOND_URL, URL_BYTES),
    ]
    .into_iter()
    .find(|(a, n)| (*a..*a + *n).contains(&addr))
}

/// Specification version reported: GigE Vision 2.0.
pub const VERSION_VALUE: u32 = 2 << 16;
/// Device mode: big-endian registers, transmitter, UTF-8 strings.
pub const DEVICE_MODE_VALUE: u32 = (1 << 31) | 1;
/// Control channel privilege bits (bit numbers counted from the LSB).
pub const CCP_EXCLUSIVE: u32 = 1 << 0;
pub const CCP_CONTROL: u32 = 1 << 1;
/// Capabilities: user-defined name, serial number, concatenation, WRITEMEM,
/// PACKETRESEND (bits counted from the LSB as the registers are read).
pub const GVCP_CAPABILITY_VALUE: u32 = (1 << 31) | (1 << 30) | (1 << 2) | (1 << 1) | (1 << 0);
/// SCPS bit 31: fire one test packet of the configured size.
pub const SCPS_FIRE_TEST: u32 = 1 << 31;
/// SCPS bit 30: do not fragment (recorded; UDP on loopback never fragments).
pub const SCPS_DO_NOT_FRAGMENT: u32 = 1 << 30;
/// Timestamp tick: 1 ns.
pub const TICK_FREQUENCY_HZ: u64 = 1_000_000_000;
/// Heartbeat timeout at power-up, ms (the specification's default).
pub const DEFAULT_HEARTBEAT_MS: u32 = 3000;
/// Shortest heartbeat timeout accepted, ms.
pub const MIN_HEARTBEAT_MS: u32 = 500;
/// Stream packet size at power-up (standard Ethernet MTU), bytes including
/// the IP and UDP headers, as GigE Vision counts it.
pub const DEFAULT_PACKET_BYTES: u32 = 1500;
pub const MIN_PACKET_BYTES: u32 = 576;
/// Jumbo frames.
pub const MAX_PACKET_BYTES: u32 = 9000;
