//! The camera's own feature registers (above the bootstrap block) and the
//! GenICam XML that describes them. One table drives both, so the XML and
//! the register map cannot disagree.

use crate::bootstrap as bs;

/// Where the GenICam XML lives in device memory (the `Local:` URL points here).
pub const XML_ADDRESS: u32 = 0x0010_0000;
/// File name in the `Local:` URL.
pub const XML_FILE_NAME: &str = "gloam.xml";

/// Register addresses of the features (4-byte big-endian registers).
pub mod reg {
    pub const WIDTH: u32 = 0x0001_0000;
    pub const HEIGHT: u32 = 0x0001_0004;
    pub const SENSOR_WIDTH: u32 = 0x0001_0008;
    pub const SENSOR_HEIGHT: u32 = 0x0001_000C;
    pub const OFFSET_X: u32 = 0x0001_0010;
    pub const OFFSET_Y: u32 = 0x0001_0014;
    pub const PIXEL_FORMAT: u32 = 0x0001_0018;
    pub const PAYLOAD_SIZE: u32 = 0x0001_001C;
    pub const ACQUISITION_MODE: u32 = 0x0001_0020;
    pub const ACQUISITION_START: u32 = 0x0001_0024;
    pub const ACQUISITION_STOP: u32 = 0x0001_0028;
    pub const ACQUISITION_FRAME_COUNT: u32 = 0x0001_002C;
    /// IEEE-754 single, Hz.
    pub const ACQUISITION_FRAME_RATE: u32 = 0x0001_0030;
    /// IEEE-754 single, µs.
    pub const EXPOSURE_TIME: u32 = 0x0001_0034;
    pub const GAIN_AUTO: u32 = 0x0001_003C;
    pub const TRIGGER_SELECTOR: u32 = 0x0001_0040;
    pub const TRIGGER_MODE: u32 = 0x0001_0044;
    pub const TRIGGER_SOURCE: u32 = 0x0001_0048;
    pub const TRIGGER_SOFTWARE: u32 = 0x0001_004C;
    pub const TL_PARAMS_LOCKED: u32 = 0x0001_0050;
    /// IEEE-754 single, V.
    pub const INTENSIFIER_MCP_VOLTAGE: u32 = 0x0001_0054;
    /// IEEE-754 single, fraction of full scale.
    pub const GAIN_AUTO_SETPOINT: u32 = 0x0001_0058;
    pub const FRAMES_SENT: u32 = 0x0001_0064;
    pub const PACKETS_DROPPED: u32 = 0x0001_0068;
    pub const PACKETS_RESENT: u32 = 0x0001_006C;
    pub const RESEND_REQUESTS: u32 = 0x0001_0070;
    /// 0 inactive, 1 active (AGC cameras).
    pub const BRIGHT_SOURCE_PROTECTION: u32 = 0x0001_0074;
    /// `UserSetSelector`: 0 Default (read-only), 1 UserSet1.
    pub const USER_SET_SELECTOR: u32 = 0x0001_0078;
    pub const USER_SET_LOAD: u32 = 0x0001_007C;
    pub const USER_SET_SAVE: u32 = 0x0001_0080;
    /// `UserSetDefault`: the set power-up and `DeviceReset` load.
    pub const USER_SET_DEFAULT: u32 = 0x0001_0084;
    pub const DEVICE_RESET: u32 = 0x0001_0088;
    /// `Gain`: IEEE-754 double (8 bytes, high word first), dB (SFNC:
    /// 20·log10 of the linear factor).
    pub const GAIN_DB: u32 = 0x0001_0090;
    /// `GainLinear`: IEEE-754 double (8 bytes), the linear factor, as
    /// `gloam capture --gain`.
    pub const GAIN_LINEAR: u32 = 0x0001_0098;
    /// `ChunkModeActive`: 0 off (image payloads, as without chunks), 1 on.
    pub const CHUNK_MODE_ACTIVE: u32 = 0x0001_00A0;
    /// `ChunkSelector`: index into [`super::chunk::DEFS`].
    pub const CHUNK_SELECTOR: u32 = 0x0001_00A4;
    /// `ChunkEnable` of the selected chunk.
    pub const CHUNK_ENABLE: u32 = 0x0001_00A8;
    /// `ExposureAuto`: Off only (see the XML's tooltip for why).
    pub const EXPOSURE_AUTO: u32 = 0x0001_00AC;
    /// `AcquisitionFrameRateEnable`: 1 paces the stream to
    /// `AcquisitionFrameRate`, 0 to the sensor's own frame rate.
    pub const ACQUISITION_FRAME_RATE_ENABLE: u32 = 0x0001_00B0;
    /// `GainSelector`: All (the camera has one gain).
    pub const GAIN_SELECTOR: u32 = 0x0001_00B4;
    /// First address past the feature block.
    pub const END: u32 = 0x0001_00B8;

    /// The 8-byte double registers, by the address of their high word.
    pub const DOUBLES: [u32; 2] = [GAIN_DB, GAIN_LINEAR];
    /// `GloamStimulus`: what the simulated camera looks at, as the JSON of
    /// `gloam_grabber::Stimulus` (NUL-terminated), [`STIMULUS_BYTES`] long.
    pub const STIMULUS: u32 = 0x0002_0000;
    pub const STIMULUS_BYTES: u32 = 512;
}

/// PFNC pixel format codes.
pub mod pixel_format {
    pub const MONO8: u32 = 0x0108_0001;
    pub const MONO12: u32 = 0x0110_0005;
    pub const MONO16: u32 = 0x0110_0007;

    /// Digitizer bits of a format.
    pub fn bits(code: u32) -> Option<u8> {
        match code {
            MONO8 => Some(8),
            MONO12 => Some(12),
            MONO16 => Some(16),
            _ => None,
        }
    }

    /// Format carrying `bits`-bit pixels.
    pub fn for_bits(bits: u8) -> u32 {
        match bits {
            0..=8 => MONO8,
            9..=12 => MONO12,
            _ => MONO16,
        }
    }

    /// Bytes per pixel on the wire (Mono12 is unpacked: 12 bits in 16).
    pub fn bytes_per_pixel(code: u32) -> usize {
        if code == MONO8 { 1 } else { 2 }
    }
}

/// Values of the enumerations.
pub mod value {
    pub const ACQUISITION_MODE_CONTINUOUS: u32 = 0;
    pub const ACQUISITION_MODE_SINGLE_FRAME: u32 = 1;
    pub const ACQUISITION_MODE_MULTI_FRAME: u32 = 2;
    pub const GAIN_AUTO_OFF: u32 = 0;
    pub const GAIN_AUTO_CONTINUOUS: u32 = 2;
    pub const TRIGGER_SELECTOR_FRAME_START: u32 = 0;
    pub const TRIGGER_SOURCE_SOFTWARE: u32 = 0;
    pub const OFF: u32 = 0;
    pub const ON: u32 = 1;
    pub const USER_SET_DEFAULT: u32 = 0;
    pub const USER_SET_1: u32 = 1;
    pub const EXPOSURE_AUTO_OFF: u32 = 0;
    pub const GAIN_SELECTOR_ALL: u32 = 0;
}

/// Chunk data: what each frame says about itself when `ChunkModeActive`
/// is on. One table drives the XML (selector entries, chunk features and
/// their ports) and the bytes the stream sends.
pub mod chunk {
    /// Chunk id of the image itself (the first chunk of a payload).
    pub const IMAGE_ID: u32 = 0x676C_0000;

    /// How a chunk's value is encoded (big-endian, as every register here).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Kind {
        U32,
        U64,
        F64,
    }

    impl Kind {
        pub fn bytes(self) -> usize {
            match self {
                Kind::U32 => 4,
                Kind::U64 | Kind::F64 => 8,
            }
        }
    }

    /// One chunk: its `ChunkSelector` entry is `name`, its feature
    /// `Chunk{name}`, read from chunk `id` at offset 0.
    #[derive(Clone, Copy, Debug)]
    pub struct Def {
        pub name: &'static str,
        pub id: u32,
        pub kind: Kind,
        /// SFNC name (Standard namespace) or gloam's own (Custom).
        pub standard: bool,
        pub unit: &'static str,
        pub tip: &'static str,
    }

    const fn def(
        name: &'static str,
        id: u32,
        kind: Kind,
        standard: bool,
        unit: &'static str,
        tip: &'static str,
    ) -> Def {
        Def {
            name,
            id,
            kind,
            standard,
            unit,
            tip,
        }
    }

    /// The chunks, in `ChunkSelector` order (the selector value is the index).
    pub const DEFS: [Def; 10] = [
        def(
            "OffsetX",
            0x676C_0001,
            Kind::U32,
            true,
            "",
            "OffsetX of the frame (always 0)",
        ),
        def(
            "OffsetY",
            0x676C_0002,
            Kind::U32,
            true,
            "",
            "OffsetY of the frame (always 0)",
        ),
        def(
            "FrameID",
            0x676C_0003,
            Kind::U64,
            true,
            "",
            "The frame's id: its GVSP block id, unwrapped (1 for the first frame of an acquisition)",
        ),
        def(
            "Timestamp",
            0x676C_0004,
            Kind::U64,
            true,
            "",
            "Exposure start, timestamp ticks (ns), as the leader's",
        ),
        def(
            "Gain",
            0x676C_0005,
            Kind::F64,
            true,
            "dB",
            "Gain in effect for this frame, dB (under GainAuto, the AGC's)",
        ),
        def(
            "GainLinear",
            0x676C_0006,
            Kind::F64,
            false,
            "x",
            "Gain in effect for this frame as a linear factor (GainLinear)",
        ),
        def(
            "ExposureTime",
            0x676C_0007,
            Kind::F64,
            true,
            "us",
            "Exposure of this frame, microseconds",
        ),
        def(
            "GateDuty",
            0x676C_0008,
            Kind::F64,
            false,
            "",
            "Fraction of the exposure the photocathode was gated on for this frame: the preset's duty times the tube's autogating (1 without a gated photocathode)",
        ),
        def(
            "AgcActive",
            0x676C_0009,
            Kind::U32,
            false,
            "",
            "1 when the AGC (GainAuto Continuous) set this frame's gain, 0 for a fixed gain",
        ),
        def(
            "BrightSourceProtection",
            0x676C_000A,
            Kind::U32,
            false,
            "",
            "1 when the AGC's bright-source protection was cutting the gain at this frame",
        ),
    ];

    /// `ChunkEnable` of every chunk (the power-up state).
    pub const ALL_ENABLED: u32 = (1 << DEFS.len()) - 1;

    /// What one frame's chunks say.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Values {
        pub frame_id: u64,
        pub timestamp_ticks: u64,
        /// Linear gain factor in effect.
        pub gain_linear: f64,
        pub exposure_us: f64,
        pub gate_duty: f64,
        pub agc_active: bool,
        pub bright_source_protection: bool,
    }

    impl Values {
        /// The bytes of chunk `def` (index into [`DEFS`]).
        fn bytes(&self, index: usize) -> Vec<u8> {
            let u = |x: u64, kind: Kind| match kind {
                Kind::U32 => (x as u32).to_be_bytes().to_vec(),
                _ => x.to_be_bytes().to_vec(),
            };
            let f = |x: f64| x.to_be_bytes().to_vec();
            match DEFS[index].name {
                "FrameID" => u(self.frame_id, Kind::U64),
                "Timestamp" => u(self.timestamp_ticks, Kind::U64),
                "Gain" => f(super::gain_db(self.gain_linear)),
                "GainLinear" => f(self.gain_linear),
                "ExposureTime" => f(self.exposure_us),
                "GateDuty" => f(self.gate_duty),
                "AgcActive" => u(u64::from(self.agc_active), Kind::U32),
                "BrightSourceProtection" => u(u64::from(self.bright_source_protection), Kind::U32),
                _ => vec![0; DEFS[index].kind.bytes()],
            }
        }

        /// `(chunk id, bytes)` of the chunks enabled in the bit mask `enabled`.
        pub fn chunks(&self, enabled: u32) -> Vec<(u32, Vec<u8>)> {
            (0..DEFS.len())
                .filter(|i| enabled & (1 << i) != 0)
                .map(|i| (DEFS[i].id, self.bytes(i)))
                .collect()
        }
    }

    /// Payload bytes of an image of `image_bytes` with the chunks of
    /// `enabled`.
    pub fn payload_bytes(image_bytes: usize, enabled: u32) -> usize {
        crate::gvsp::chunked_payload_bytes(
            image_bytes,
            (0..DEFS.len())
                .filter(|i| enabled & (1 << i) != 0)
                .map(|i| DEFS[i].kind.bytes()),
        )
    }
}

/// `Gain` (dB, SFNC) of a linear gain factor.
pub fn gain_db(linear: f64) -> f64 {
    20.0 * linear.log10()
}

/// The linear gain factor of `Gain` in dB.
pub fn gain_linear(db: f64) -> f64 {
    10f64.powf(db / 20.0)
}

/// What the XML needs to know about this camera's ranges.
#[derive(Clone, Debug)]
pub struct XmlFacts {
    pub vendor: String,
    pub model: String,
    pub max_width: u32,
    pub max_height: u32,
    /// Width and height can change (rigs render any size; scenes cannot).
    pub resizable: bool,
    pub max_exposure_us: f64,
    pub max_frame_rate_hz: f64,
    pub has_agc: bool,
    /// MCP voltage range, V, when the tube has an MCP.
    pub mcp_range_v: Option<(f64, f64)>,
    /// Gain range, linear factor.
    pub gain_range: (f64, f64),
}

fn int_reg(name: &str, addr: u32, access: &str) -> String {
    format!(
        "  <IntReg Name=\"{name}\">\n    <Address>0x{addr:x}</Address>\n    <Length>4</Length>\n    <AccessMode>{access}</AccessMode>\n    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n  </IntReg>\n"
    )
}

fn float_reg(name: &str, addr: u32, access: &str) -> String {
    format!(
        "  <FloatReg Name=\"{name}\">\n    <Address>0x{addr:x}</Address>\n    <Length>4</Length>\n    <AccessMode>{access}</AccessMode>\n    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n    <Endianess>BigEndian</Endianess>\n  </FloatReg>\n"
    )
}

/// An 8-byte (double precision) float register.
fn double_reg(name: &str, addr: u32, access: &str) -> String {
    format!(
        "  <FloatReg Name=\"{name}\">\n    <Address>0x{addr:x}</Address>\n    <Length>8</Length>\n    <AccessMode>{access}</AccessMode>\n    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n    <Endianess>BigEndian</Endianess>\n  </FloatReg>\n"
    )
}

fn string_reg(name: &str, addr: u32, len: u32, access: &str, tip: &str) -> String {
    format!(
        "  <StringReg Name=\"{name}\" NameSpace=\"Standard\">\n    <ToolTip>{tip}</ToolTip>\n    <Address>0x{addr:x}</Address>\n    <Length>{len}</Length>\n    <AccessMode>{access}</AccessMode>\n    <pPort>Device</pPort>\n  </StringReg>\n"
    )
}

fn integer(name: &str, tip: &str, reg: &str, min: &str, max: &str) -> String {
    format!(
        "  <Integer Name=\"{name}\" NameSpace=\"Standard\">\n    <ToolTip>{tip}</ToolTip>\n    <pValue>{reg}</pValue>\n    {min}\n    {max}\n    <Inc>1</Inc>\n  </Integer>\n"
    )
}

fn float(name: &str, ns: &str, tip: &str, reg: &str, min: f64, max: f64, unit: &str) -> String {
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!("    <Unit>{unit}</Unit>\n")
    };
    format!(
        "  <Float Name=\"{name}\" NameSpace=\"{ns}\">\n    <ToolTip>{tip}</ToolTip>\n    <pValue>{reg}</pValue>\n    <Min>{min}</Min>\n    <Max>{max}</Max>\n{unit}  </Float>\n"
    )
}

/// A GenApi identifier (`[A-Za-z][0-9A-Za-z_]*`) made from any name.
fn identifier(s: &str) -> String {
    let mut id: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !id.starts_with(|c: char| c.is_ascii_alphabetic()) {
        id.insert_str(0, "gloam_");
    }
    id
}

fn enumeration(name: &str, tip: &str, entries: &[(&str, u32)], reg: &str, locked: bool) -> String {
    let mut s = format!(
        "  <Enumeration Name=\"{name}\" NameSpace=\"Standard\">\n    <ToolTip>{tip}</ToolTip>\n"
    );
    if locked {
        s += "    <pIsLocked>TLParamsLocked</pIsLocked>\n";
    }
    for (n, v) in entries {
        s += &format!("    <EnumEntry Name=\"{n}\">\n      <Value>{v}</Value>\n    </EnumEntry>\n");
    }
    s += &format!("    <pValue>{reg}</pValue>\n  </Enumeration>\n");
    s
}

fn command(name: &str, tip: &str, reg: &str) -> String {
    format!(
        "  <Command Name=\"{name}\" NameSpace=\"Standard\">\n    <ToolTip>{tip}</ToolTip>\n    <pValue>{reg}</pValue>\n    <CommandValue>1</CommandValue>\n  </Command>\n"
    )
}

/// The GenICam (GenApi schema 1.0) description of the device: the
/// category tree, then each control group's features and registers in
/// the order GenApi readers list them.
pub fn genicam_xml(f: &XmlFacts) -> String {
    let n = [
        categories(f),
        device_information(),
        user_sets(),
        image_format(f),
        chunk_data(),
        acquisition(f),
        triggers(),
        analog_control(f),
        transport_layer(),
        simulation(),
        "  <Port Name=\"Device\" NameSpace=\"Standard\"/>\n".to_string(),
    ]
    .concat();
    format!(
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<RegisterDescription ModelName=\"{}\" VendorName=\"{}\" ToolTip=\"gloam simulated low-light-level camera\" StandardNameSpace=\"GEV\" SchemaMajorVersion=\"1\" SchemaMinorVersion=\"0\" SchemaSubMinorVersion=\"0\" MajorVersion=\"1\" MinorVersion=\"0\" SubMinorVersion=\"0\" ProductGuid=\"6f7f1b0e-3d6a-4c55-9b0e-67c1a0a9e001\" VersionGuid=\"6f7f1b0e-3d6a-4c55-9b0e-67c1a0a9e002\" xmlns=\"http://www.genicam.org/GenApi/Version_1_0\" xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" xsi:schemaLocation=\"http://www.genicam.org/GenApi/Version_1_0 http://www.genicam.org/GenApi/GenApiSchema_Version_1_0.xsd\">\n{n}</RegisterDescription>\n",
        identifier(&f.model),
        identifier(&f.vendor)
    )
}

/// Device information features, sorted by name.
const DEVICE_CONTROL: [&str; 8] = [
    "DeviceID",
    "DeviceManufacturerInfo",
    "DeviceModelName",
    "DeviceReset",
    "DeviceSerialNumber",
    "DeviceUserID",
    "DeviceVendorName",
    "DeviceVersion",
];
const IMAGE_FORMAT_CONTROL: [&str; 10] = [
    "Width",
    "Height",
    "SensorWidth",
    "SensorHeight",
    "WidthMax",
    "HeightMax",
    "OffsetX",
    "OffsetY",
    "PixelFormat",
    "PayloadSize",
];
const ACQUISITION_CONTROL: [&str; 12] = [
    "AcquisitionMode",
    "AcquisitionStart",
    "AcquisitionStop",
    "AcquisitionFrameCount",
    "AcquisitionFrameRateEnable",
    "AcquisitionFrameRate",
    "ExposureTime",
    "ExposureAuto",
    "TriggerSelector",
    "TriggerMode",
    "TriggerSource",
    "TriggerSoftware",
];
const USER_SET_CONTROL: [&str; 4] = [
    "UserSetSelector",
    "UserSetLoad",
    "UserSetSave",
    "UserSetDefault",
];
const TRANSPORT_LAYER_CONTROL: [&str; 9] = [
    "PayloadSize",
    "GevSCPSPacketSize",
    "GevSCPD",
    "GevTimestampTickFrequency",
    "TLParamsLocked",
    "GloamFramesSent",
    "GloamPacketsDroppedByFaultInjector",
    "GloamPacketsResent",
    "GloamResendRequests",
];

fn category(name: &str, features: &[&str]) -> String {
    let mut s = format!("  <Category Name=\"{name}\" NameSpace=\"Standard\">\n");
    for x in features {
        s += &format!("    <pFeature>{x}</pFeature>\n");
    }
    s + "  </Category>\n"
}

/// The category tree: fixed groups, plus the gain and intensifier
/// features only a tube with an AGC or an MCP has.
fn categories(f: &XmlFacts) -> String {
    let mut cat_analog = vec!["GainSelector", "Gain", "GainLinear", "GainAuto"];
    if f.has_agc {
        cat_analog.push("GainAutoSetpoint");
    }
    let mut cat_intensifier = vec![];
    if f.mcp_range_v.is_some() {
        cat_intensifier.push("IntensifierMcpVoltage");
    }
    if f.has_agc {
        cat_intensifier.push("IntensifierBrightSourceProtection");
    }
    let mut root = vec![
        "DeviceControl",
        "ImageFormatControl",
        "AcquisitionControl",
        "AnalogControl",
        "UserSetControl",
        "ChunkDataControl",
        "TransportLayerControl",
    ];
    if !cat_intensifier.is_empty() {
        root.push("IntensifierControl");
    }
    root.push("GloamSimulation");
    let chunk_features: Vec<String> = chunk::DEFS
        .iter()
        .map(|d| format!("Chunk{}", d.name))
        .collect();
    let mut cat_chunk = vec!["ChunkModeActive", "ChunkSelector", "ChunkEnable"];
    cat_chunk.extend(chunk_features.iter().map(String::as_str));
    let mut n = category("Root", &root);
    n += &category("DeviceControl", &DEVICE_CONTROL);
    n += &category("ImageFormatControl", &IMAGE_FORMAT_CONTROL);
    n += &category("AcquisitionControl", &ACQUISITION_CONTROL);
    n += &category("AnalogControl", &cat_analog);
    n += &category("UserSetControl", &USER_SET_CONTROL);
    n += &category("ChunkDataControl", &cat_chunk);
    n += &category("TransportLayerControl", &TRANSPORT_LAYER_CONTROL);
    if !cat_intensifier.is_empty() {
        n += &category("IntensifierControl", &cat_intensifier);
    }
    n += &category("GloamSimulation", &["GloamStimulus"]);
    n
}

/// Device information (the bootstrap strings) and DeviceReset.
fn device_information() -> String {
    let mut n = String::new();
    n += &string_reg(
        "DeviceVendorName",
        bs::MANUFACTURER_NAME,
        32,
        "RO",
        "Manufacturer",
    );
    n += &string_reg("DeviceModelName", bs::MODEL_NAME, 32, "RO", "Model");
    n += &string_reg(
        "DeviceVersion",
        bs::DEVICE_VERSION,
        32,
        "RO",
        "Device version",
    );
    n += &string_reg(
        "DeviceManufacturerInfo",
        bs::MANUFACTURER_INFO,
        48,
        "RO",
        "Manufacturer information",
    );
    n += &string_reg(
        "DeviceSerialNumber",
        bs::SERIAL_NUMBER,
        16,
        "RO",
        "Serial number",
    );
    n += &string_reg("DeviceID", bs::SERIAL_NUMBER, 16, "RO", "Device identifier");
    n += &string_reg(
        "DeviceUserID",
        bs::USER_DEFINED_NAME,
        16,
        "RW",
        "User-defined name",
    );

    n += &command(
        "DeviceReset",
        "Reset the device as a power cycle would: acquisition stops, control is released, the UserSetDefault set is loaded",
        "DeviceResetReg",
    );
    n += &int_reg("DeviceResetReg", reg::DEVICE_RESET, "WO");
    n
}

/// User sets: Default holds the sensor preset's settings (read-only);
/// UserSet1 starts as a copy of it.
fn user_sets() -> String {
    let mut n = String::new();
    let sets = [
        ("Default", value::USER_SET_DEFAULT),
        ("UserSet1", value::USER_SET_1),
    ];
    n += &enumeration(
        "UserSetSelector",
        "User set UserSetLoad and UserSetSave act on (Default: the sensor preset's settings, read-only)",
        &sets,
        "UserSetSelectorReg",
        false,
    );
    n += &int_reg("UserSetSelectorReg", reg::USER_SET_SELECTOR, "RW");
    n += &command(
        "UserSetLoad",
        "Load the selected user set (not while acquiring)",
        "UserSetLoadReg",
    );
    n += &int_reg("UserSetLoadReg", reg::USER_SET_LOAD, "WO");
    n += &command(
        "UserSetSave",
        "Save the current settings into the selected user set (not Default)",
        "UserSetSaveReg",
    );
    n += &int_reg("UserSetSaveReg", reg::USER_SET_SAVE, "WO");
    n += &enumeration(
        "UserSetDefault",
        "User set loaded at power-up and by DeviceReset (registers otherwise persist across control sessions)",
        &sets,
        "UserSetDefaultReg",
        false,
    );
    n += &int_reg("UserSetDefaultReg", reg::USER_SET_DEFAULT, "RW");
    n
}

/// Image format: size (fixed unless the source renders any size), the
/// always-zero offsets, pixel format and payload size.
fn image_format(f: &XmlFacts) -> String {
    let mut n = String::new();
    let wmin = if f.resizable { 1 } else { f.max_width };
    let hmin = if f.resizable { 1 } else { f.max_height };
    n += &integer(
        "Width",
        "Image width, pixels",
        "WidthReg",
        &format!("<Min>{wmin}</Min>"),
        "<pMax>SensorWidthReg</pMax>",
    );
    n += &int_reg("WidthReg", reg::WIDTH, "RW");
    n += &integer(
        "Height",
        "Image height, pixels",
        "HeightReg",
        &format!("<Min>{hmin}</Min>"),
        "<pMax>SensorHeightReg</pMax>",
    );
    n += &int_reg("HeightReg", reg::HEIGHT, "RW");
    for (name, r, max) in [
        ("SensorWidth", "SensorWidthReg", f.max_width),
        ("SensorHeight", "SensorHeightReg", f.max_height),
        ("WidthMax", "SensorWidthReg", f.max_width),
        ("HeightMax", "SensorHeightReg", f.max_height),
    ] {
        n += &integer(
            name,
            "Largest image the simulated sensor renders, pixels",
            r,
            &format!("<Min>{max}</Min>"),
            &format!("<Max>{max}</Max>"),
        );
    }
    n += &int_reg("SensorWidthReg", reg::SENSOR_WIDTH, "RO");
    n += &int_reg("SensorHeightReg", reg::SENSOR_HEIGHT, "RO");
    for (name, r, a) in [
        ("OffsetX", "OffsetXReg", reg::OFFSET_X),
        ("OffsetY", "OffsetYReg", reg::OFFSET_Y),
    ] {
        n += &integer(
            name,
            "Region offset: always 0 (the whole rendered image is read out)",
            r,
            "<Min>0</Min>",
            "<Max>0</Max>",
        );
        n += &int_reg(r, a, "RW");
    }
    n += &enumeration(
        "PixelFormat",
        "Digitizer depth: Mono8, Mono12 (unpacked, 16-bit little-endian) or Mono16",
        &[
            ("Mono8", pixel_format::MONO8),
            ("Mono12", pixel_format::MONO12),
            ("Mono16", pixel_format::MONO16),
        ],
        "PixelFormatReg",
        true,
    );
    n += &int_reg("PixelFormatReg", reg::PIXEL_FORMAT, "RW");
    n += &integer(
        "PayloadSize",
        "Bytes per frame: the image, and with ChunkModeActive the enabled chunks",
        "PayloadSizeReg",
        "<Min>1</Min>",
        &format!(
            "<Max>{}</Max>",
            chunk::payload_bytes(
                f.max_width as usize * f.max_height as usize * 2,
                chunk::ALL_ENABLED
            )
        ),
    );
    n += &int_reg("PayloadSizeReg", reg::PAYLOAD_SIZE, "RO");
    n
}

/// Chunk data: the mode, the per-chunk switches, and each chunk's value.
fn chunk_data() -> String {
    let mut n = String::new();
    n += "  <Boolean Name=\"ChunkModeActive\" NameSpace=\"Standard\">\n    <ToolTip>Chunk data on: each frame's payload carries the image as a chunk, then the enabled chunks (PayloadSize grows); off: image payloads as without chunk support</ToolTip>\n    <pIsLocked>TLParamsLocked</pIsLocked>\n    <pValue>ChunkModeActiveReg</pValue>\n    <OnValue>1</OnValue>\n    <OffValue>0</OffValue>\n  </Boolean>\n";
    n += &int_reg("ChunkModeActiveReg", reg::CHUNK_MODE_ACTIVE, "RW");
    n += "  <Enumeration Name=\"ChunkSelector\" NameSpace=\"Standard\">\n    <ToolTip>Chunk ChunkEnable acts on</ToolTip>\n";
    for (i, d) in chunk::DEFS.iter().enumerate() {
        n += &format!(
            "    <EnumEntry Name=\"{}\">\n      <Value>{i}</Value>\n    </EnumEntry>\n",
            d.name
        );
    }
    n += "    <pValue>ChunkSelectorReg</pValue>\n    <pSelected>ChunkEnable</pSelected>\n  </Enumeration>\n";
    n += &int_reg("ChunkSelectorReg", reg::CHUNK_SELECTOR, "RW");
    n += "  <Boolean Name=\"ChunkEnable\" NameSpace=\"Standard\">\n    <ToolTip>Whether the selected chunk is sent while ChunkModeActive is on</ToolTip>\n    <pIsLocked>TLParamsLocked</pIsLocked>\n    <pValue>ChunkEnableReg</pValue>\n    <OnValue>1</OnValue>\n    <OffValue>0</OffValue>\n  </Boolean>\n";
    n += &int_reg("ChunkEnableReg", reg::CHUNK_ENABLE, "RW");
    for d in &chunk::DEFS {
        n += &chunk_value_register(d);
    }
    n
}

/// One chunk's value as a register on its own port, which reads from the
/// buffer's chunk of that id (GenApi ChunkID) rather than from the device.
fn chunk_value_register(d: &chunk::Def) -> String {
    let mut n = String::new();
    let name = format!("Chunk{}", d.name);
    let ns = if d.standard { "Standard" } else { "Custom" };
    let port = format!("{name}Port");
    let len = d.kind.bytes();
    n += &match d.kind {
        chunk::Kind::F64 => {
            let unit = if d.unit.is_empty() {
                String::new()
            } else {
                format!("    <Unit>{}</Unit>\n", d.unit)
            };
            format!(
                "  <FloatReg Name=\"{name}\" NameSpace=\"{ns}\">\n    <ToolTip>{}</ToolTip>\n    <Address>0x0</Address>\n    <Length>{len}</Length>\n    <AccessMode>RO</AccessMode>\n    <pPort>{port}</pPort>\n    <Cachable>NoCache</Cachable>\n    <Endianess>BigEndian</Endianess>\n{unit}  </FloatReg>\n",
                d.tip
            )
        }
        chunk::Kind::U32 | chunk::Kind::U64 => format!(
            "  <IntReg Name=\"{name}\" NameSpace=\"{ns}\">\n    <ToolTip>{}</ToolTip>\n    <Address>0x0</Address>\n    <Length>{len}</Length>\n    <AccessMode>RO</AccessMode>\n    <pPort>{port}</pPort>\n    <Cachable>NoCache</Cachable>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n  </IntReg>\n",
            d.tip
        ),
    };
    n += &format!(
        "  <Port Name=\"{port}\">\n    <ChunkID>{:08X}</ChunkID>\n  </Port>\n",
        d.id
    );
    n
}

/// Acquisition: mode, start and stop, frame count, pacing and exposure.
fn acquisition(f: &XmlFacts) -> String {
    let mut n = String::new();
    n += &enumeration(
        "AcquisitionMode",
        "Continuous, SingleFrame or MultiFrame (AcquisitionFrameCount frames)",
        &[
            ("Continuous", value::ACQUISITION_MODE_CONTINUOUS),
            ("SingleFrame", value::ACQUISITION_MODE_SINGLE_FRAME),
            ("MultiFrame", value::ACQUISITION_MODE_MULTI_FRAME),
        ],
        "AcquisitionModeReg",
        false,
    );
    n += &int_reg("AcquisitionModeReg", reg::ACQUISITION_MODE, "RW");
    n += &command(
        "AcquisitionStart",
        "Start streaming: frame 0 of a fresh noise stream",
        "AcquisitionStartReg",
    );
    n += &int_reg("AcquisitionStartReg", reg::ACQUISITION_START, "WO");
    n += &command("AcquisitionStop", "Stop streaming", "AcquisitionStopReg");
    n += &int_reg("AcquisitionStopReg", reg::ACQUISITION_STOP, "WO");
    n += &integer(
        "AcquisitionFrameCount",
        "Frames per MultiFrame acquisition",
        "AcquisitionFrameCountReg",
        "<Min>1</Min>",
        "<Max>65535</Max>",
    );
    n += &int_reg(
        "AcquisitionFrameCountReg",
        reg::ACQUISITION_FRAME_COUNT,
        "RW",
    );
    n += "  <Boolean Name=\"AcquisitionFrameRateEnable\" NameSpace=\"Standard\">\n    <ToolTip>On: the stream is paced to AcquisitionFrameRate; off: to the sensor's own frame rate (AcquisitionFrameRate is kept but not honoured)</ToolTip>\n    <pValue>AcquisitionFrameRateEnableReg</pValue>\n    <OnValue>1</OnValue>\n    <OffValue>0</OffValue>\n  </Boolean>\n";
    n += &int_reg(
        "AcquisitionFrameRateEnableReg",
        reg::ACQUISITION_FRAME_RATE_ENABLE,
        "RW",
    );
    n += &float(
        "AcquisitionFrameRate",
        "Standard",
        "Frame rate the stream is paced to while AcquisitionFrameRateEnable is on, Hz (default: the sensor's frame rate); frames never come faster than the exposure allows",
        "AcquisitionFrameRateReg",
        0.1,
        f.max_frame_rate_hz,
        "Hz",
    );
    n += &float_reg("AcquisitionFrameRateReg", reg::ACQUISITION_FRAME_RATE, "RW");
    n += &float(
        "ExposureTime",
        "Standard",
        "Exposure (CCD integration / intensifier gate), microseconds",
        "ExposureTimeReg",
        1.0,
        f.max_exposure_us,
        "us",
    );
    n += &float_reg("ExposureTimeReg", reg::EXPOSURE_TIME, "RW");
    n += &enumeration(
        "ExposureAuto",
        "Off only: the camera has no automatic exposure time. Its automatic controls are the AGC (GainAuto) and the tube's own brightness control, which shortens the photocathode gate within the exposure (ChunkGateDuty), not ExposureTime",
        &[("Off", value::EXPOSURE_AUTO_OFF)],
        "ExposureAutoReg",
        false,
    );
    n += &int_reg("ExposureAutoReg", reg::EXPOSURE_AUTO, "RW");
    n
}

/// Triggering: software trigger of FrameStart only.
fn triggers() -> String {
    let mut n = String::new();
    n += &enumeration(
        "TriggerSelector",
        "Trigger being configured",
        &[("FrameStart", value::TRIGGER_SELECTOR_FRAME_START)],
        "TriggerSelectorReg",
        false,
    );
    n += &int_reg("TriggerSelectorReg", reg::TRIGGER_SELECTOR, "RW");
    n += &enumeration(
        "TriggerMode",
        "On: one frame per trigger",
        &[("Off", value::OFF), ("On", value::ON)],
        "TriggerModeReg",
        false,
    );
    n += &int_reg("TriggerModeReg", reg::TRIGGER_MODE, "RW");
    n += &enumeration(
        "TriggerSource",
        "Trigger source",
        &[("Software", value::TRIGGER_SOURCE_SOFTWARE)],
        "TriggerSourceReg",
        false,
    );
    n += &int_reg("TriggerSourceReg", reg::TRIGGER_SOURCE, "RW");
    n += &command(
        "TriggerSoftware",
        "Take one frame (TriggerMode On)",
        "TriggerSoftwareReg",
    );
    n += &int_reg("TriggerSoftwareReg", reg::TRIGGER_SOFTWARE, "WO");
    n
}

/// Analog control: gain, AGC and the tube's MCP. Gain in dB as SFNC
/// defines it, and the linear factor gloam's CLI uses; both double
/// precision, locked while GainAuto servoes them.
fn analog_control(f: &XmlFacts) -> String {
    let mut n = String::new();
    let (glo, ghi) = f.gain_range;
    n += "  <Enumeration Name=\"GainSelector\" NameSpace=\"Standard\">\n    <ToolTip>All: the camera has one gain, the tube's (or system) gain; GainAuto's AGC and the tube's brightness control act on it</ToolTip>\n    <EnumEntry Name=\"All\">\n      <Value>0</Value>\n    </EnumEntry>\n    <pValue>GainSelectorReg</pValue>\n    <pSelected>Gain</pSelected>\n    <pSelected>GainLinear</pSelected>\n    <pSelected>GainAuto</pSelected>\n  </Enumeration>\n";
    n += &int_reg("GainSelectorReg", reg::GAIN_SELECTOR, "RW");
    n += &format!(
        "  <Float Name=\"Gain\" NameSpace=\"Standard\">\n    <ToolTip>Tube (or system) gain, dB: 20·log10 of GainLinear; reads back the gain in effect (under GainAuto, the AGC's); locked while GainAuto is Continuous</ToolTip>\n    <pIsLocked>GainLocked</pIsLocked>\n    <pValue>GainReg</pValue>\n    <Min>{}</Min>\n    <Max>{}</Max>\n    <Unit>dB</Unit>\n  </Float>\n",
        gain_db(glo),
        gain_db(ghi)
    );
    n += &double_reg("GainReg", reg::GAIN_DB, "RW");
    n += &format!(
        "  <Float Name=\"GainLinear\" NameSpace=\"Custom\">\n    <ToolTip>Tube (or system) gain as a linear factor, as gloam capture --gain (Gain is the same in dB); locked while GainAuto is Continuous</ToolTip>\n    <pIsLocked>GainLocked</pIsLocked>\n    <pValue>GainLinearReg</pValue>\n    <Min>{glo}</Min>\n    <Max>{ghi}</Max>\n    <Unit>x</Unit>\n  </Float>\n"
    );
    n += &double_reg("GainLinearReg", reg::GAIN_LINEAR, "RW");
    n += "  <IntSwissKnife Name=\"GainLocked\">\n    <pVariable Name=\"AUTO\">GainAutoReg</pVariable>\n    <Formula>AUTO != 0</Formula>\n  </IntSwissKnife>\n";
    let mut auto_entries = vec![("Off", value::GAIN_AUTO_OFF)];
    if f.has_agc {
        auto_entries.push(("Continuous", value::GAIN_AUTO_CONTINUOUS));
    }
    n += &enumeration(
        "GainAuto",
        "The camera's AGC: Continuous servoes the gain; Off fixes Gain (the override)",
        &auto_entries,
        "GainAutoReg",
        false,
    );
    n += &int_reg("GainAutoReg", reg::GAIN_AUTO, "RW");
    if f.has_agc {
        n += &float(
            "GainAutoSetpoint",
            "Custom",
            "AGC target mean as a fraction of full scale",
            "GainAutoSetpointReg",
            0.0,
            1.0,
            "",
        );
        n += &float_reg("GainAutoSetpointReg", reg::GAIN_AUTO_SETPOINT, "RW");
    }
    if let Some((lo, hi)) = f.mcp_range_v {
        n += &float(
            "IntensifierMcpVoltage",
            "Custom",
            "Micro-channel plate voltage, V (sets the tube gain when GainAuto is Off and Gain was not written since)",
            "IntensifierMcpVoltageReg",
            lo,
            hi,
            "V",
        );
        n += &float_reg(
            "IntensifierMcpVoltageReg",
            reg::INTENSIFIER_MCP_VOLTAGE,
            "RW",
        );
    }

    if f.has_agc {
        n += "  <Enumeration Name=\"IntensifierBrightSourceProtection\" NameSpace=\"Custom\">\n    <ToolTip>Whether the AGC's bright-source protection was cutting the gain at the last frame sent</ToolTip>\n    <EnumEntry Name=\"Inactive\">\n      <Value>0</Value>\n    </EnumEntry>\n    <EnumEntry Name=\"Active\">\n      <Value>1</Value>\n    </EnumEntry>\n    <pValue>IntensifierBrightSourceProtectionReg</pValue>\n  </Enumeration>\n";
        n += &int_reg(
            "IntensifierBrightSourceProtectionReg",
            reg::BRIGHT_SOURCE_PROTECTION,
            "RO",
        );
    }
    n
}

/// Transport layer: packet size and delay, the timestamp clock, the
/// parameter lock and the server's own counters.
fn transport_layer() -> String {
    let mut n = String::new();
    n += "  <Integer Name=\"GevSCPSPacketSize\" NameSpace=\"Standard\">\n    <ToolTip>Stream packet size, bytes, IP and UDP headers included</ToolTip>\n    <pValue>GevSCPSPacketSizeReg</pValue>\n";
    n += &format!(
        "    <Min>{}</Min>\n    <Max>{}</Max>\n    <Inc>4</Inc>\n  </Integer>\n",
        bs::MIN_PACKET_BYTES,
        bs::MAX_PACKET_BYTES
    );
    n += &format!(
        "  <MaskedIntReg Name=\"GevSCPSPacketSizeReg\">\n    <Address>0x{:x}</Address>\n    <Length>4</Length>\n    <AccessMode>RW</AccessMode>\n    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n    <LSB>31</LSB>\n    <MSB>16</MSB>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n  </MaskedIntReg>\n",
        bs::STREAM_CHANNEL_PACKET_SIZE
    );
    n += &integer(
        "GevSCPD",
        "Delay between stream packets, timestamp ticks (ns)",
        "GevSCPDReg",
        "<Min>0</Min>",
        "<Max>1000000</Max>",
    );
    n += &int_reg("GevSCPDReg", bs::STREAM_CHANNEL_PACKET_DELAY, "RW");
    n += "  <Integer Name=\"GevTimestampTickFrequency\" NameSpace=\"Standard\">\n    <ToolTip>Timestamp ticks per second</ToolTip>\n    <pValue>GevTimestampTickFrequencyReg</pValue>\n  </Integer>\n";
    n += &format!(
        "  <IntReg Name=\"GevTimestampTickFrequencyReg\">\n    <Address>0x{:x}</Address>\n    <Length>8</Length>\n    <AccessMode>RO</AccessMode>\n    <pPort>Device</pPort>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n  </IntReg>\n",
        bs::TIMESTAMP_TICK_FREQUENCY_HIGH
    );
    n += &integer(
        "TLParamsLocked",
        "Set by the host during acquisition: size and format cannot change",
        "TLParamsLockedReg",
        "<Min>0</Min>",
        "<Max>1</Max>",
    );
    n += &int_reg("TLParamsLockedReg", reg::TL_PARAMS_LOCKED, "RW");
    for (name, r, a, tip) in [
        (
            "GloamFramesSent",
            "GloamFramesSentReg",
            reg::FRAMES_SENT,
            "Frames streamed since power-up",
        ),
        (
            "GloamPacketsDroppedByFaultInjector",
            "GloamPacketsDroppedReg",
            reg::PACKETS_DROPPED,
            "GVSP packets the fault injector dropped",
        ),
        (
            "GloamPacketsResent",
            "GloamPacketsResentReg",
            reg::PACKETS_RESENT,
            "GVSP packets sent again on PACKETRESEND",
        ),
        (
            "GloamResendRequests",
            "GloamResendRequestsReg",
            reg::RESEND_REQUESTS,
            "PACKETRESEND commands received",
        ),
    ] {
        n += &format!(
            "  <Integer Name=\"{name}\" NameSpace=\"Custom\">\n    <ToolTip>{tip}</ToolTip>\n    <pValue>{r}</pValue>\n  </Integer>\n"
        );
        n += &int_reg(r, a, "RO");
    }
    n
}

/// The simulation's own control: what the camera looks at.
fn simulation() -> String {
    let mut n = String::new();
    n += &format!(
        "  <StringReg Name=\"GloamStimulus\" NameSpace=\"Custom\">\n    <ToolTip>What the simulated camera looks at, for calibration rehearsals: JSON of a gloam stimulus, e.g. {{\"kind\":\"dark\"}} or {{\"kind\":\"uniform\",\"radiance_w_m2_sr\":1e-5,\"spectrum\":\"cie-a\"}}; reads the stimulus in effect (a rig's at start); empty: a scene or sequence, which no stimulus describes</ToolTip>\n    <Address>0x{:x}</Address>\n    <Length>{}</Length>\n    <AccessMode>RW</AccessMode>\n    <pPort>Device</pPort>\n  </StringReg>\n",
        reg::STIMULUS,
        reg::STIMULUS_BYTES
    );
    n
}
