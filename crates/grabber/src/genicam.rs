//! `genicam:` grabbers: any GenICam camera (GigE Vision, USB3 Vision) as a
//! [`FrameGrabber`](crate::FrameGrabber), through Aravis (feature `genicam`, Debian's
//! `libaravis-dev` 0.8).
//!
//! Aravis does the transport (discovery, GVCP/U3V control, GVSP with
//! PACKETRESEND, the GenICam XML); this module maps the grabber controls
//! onto SFNC features through Aravis's camera API, which already knows the
//! vendor variants (`ExposureTime`/`ExposureTimeAbs`, `Gain`/`GainRaw`):
//!
//! | grabber | GenICam |
//! |---|---|
//! | [`DeviceControl::set_gain`] | `GainAuto=Off`, then `Gain` (in the camera's unit: `GainLinear` where the camera has it (gloam's device), else `Gain` in the camera's unit (dB by SFNC) |
//! | [`DeviceControl::set_agc`] | `GainAuto=Continuous` / `Off` |
//! | [`DeviceControl::set_bits`] | `PixelFormat` Mono8 / Mono12 / Mono16 |
//! | [`DeviceControl::set_exposure_s`] | `ExposureTime`, µs |
//! | frame size (`?size=WxH`) | `Width`, `Height` |
//! | [`DeviceControl::present`] | `GloamStimulus` (gloam's own device only; real cameras: the operator sets the source) |
//! | each frame's `gain`, `agc` | the frame's own `ChunkGainLinear` (else `ChunkGain`) and `ChunkAgcActive` where the camera offers chunk data (gloam's device), else the features read after the frame |
//! | each frame's `exposure_us`, `gate_duty` | the frame's own `ChunkExposureTime` and `ChunkGateDuty` where the camera offers them (gloam's device), else not recorded |
//!
//! By default every [`FrameStream::grab`] fires `TriggerSoftware` and waits
//! for that one frame (`?trigger=software`, when the camera has it), so a
//! frame is always exposed after the settings before it, and frame *k* of
//! gloam's own GigE device is frame *k* of the `sim:` grabber. With
//! `?trigger=off` the camera free-runs; a setting change then restarts the
//! acquisition so no frame taken before it is returned after it.
//!
//! Incomplete buffers (missing packets, timeouts, size mismatches) come
//! back as [`GrabError::FrameDamaged`], gaps in the camera's frame ids as
//! [`GrabError::FramesLost`]: never as good frames. Lost packets are asked
//! for again only from a camera whose GVCP capability register offers
//! PACKETRESEND (Aravis checks the same bit); for one that does not
//! (Aravis's fake camera) the grabber warns once and says so with every
//! damaged frame.

use std::io::Write as _;
use std::sync::Mutex;

use aravis::glib::object::Cast;
use aravis::prelude::*;
use aravis::{Auto, Buffer, BufferStatus, Camera, Stream};

use crate::stream_ids::{FrameIds, IdStep, mono_layout};

use crate::interface::{
    DeviceControl, Frame, FrameMeta, FrameStatus, FrameStream, GrabError, PacketResends, Stimulus,
};
pub use crate::uri::{GenicamOptions, TriggerChoice};

/// Aravis keeps one global device list: discovery and opening by name go
/// through this lock.
static ARAVIS: Mutex<()> = Mutex::new(());

/// Buffers queued for the stream.
const N_BUFFERS: usize = 8;
/// GigE Vision bootstrap register "GVCP Capability" and its PACKETRESEND
/// bit (bit 29 counted from the MSB, as the specification numbers them).
const GVCP_CAPABILITY: u64 = 0x0934;
const GVCP_CAPABILITY_PACKET_RESEND: u32 = 1 << 2;
/// Timeouts in a row after which a triggered grab stops calling them
/// lost frames and reports the camera as not answering.
const MAX_TRIGGER_TIMEOUTS: u32 = 3;
/// The custom feature through which gloam's own GigE device takes a
/// stimulus (JSON of [`Stimulus`]).
pub const STIMULUS_FEATURE: &str = "GloamStimulus";
/// gloam's own GigE device offers the linear gain factor (the grabber's
/// unit) beside the SFNC `Gain`, which is in dB.
pub const GAIN_LINEAR_FEATURE: &str = "GainLinear";
/// `ChunkSelector` entries the grabber records per frame when the camera
/// offers them: the gain the frame was taken at (`GainLinear`, gloam's
/// device, else the SFNC `Gain` in the camera's unit) and whether the AGC
/// set it (`AgcActive`, gloam's device). Read from the frame itself, they
/// are the frame's values, not the camera's state when the grabber asks.
const GAIN_CHUNKS: [&str; 2] = ["GainLinear", "Gain"];
const AGC_CHUNK: &str = "AgcActive";
/// The exposure (SFNC `ExposureTime`, µs) and the photocathode's gate duty
/// (gloam's device) a frame was taken with, recorded when offered.
const EXPOSURE_CHUNK: &str = "ExposureTime";
const GATE_DUTY_CHUNK: &str = "GateDuty";

/// The gain in the grabber's unit: `GainLinear` where the camera has it,
/// else `Gain` in the camera's unit.
fn camera_gain(camera: &Camera) -> Result<f64, GlibError> {
    if camera
        .is_feature_available(GAIN_LINEAR_FEATURE)
        .unwrap_or(false)
    {
        camera.float(GAIN_LINEAR_FEATURE)
    } else {
        camera.gain()
    }
}

/// The GenICam cameras on every interface Aravis knows (GigE Vision
/// discovery is a broadcast on each network interface).
pub fn list_devices() -> Vec<crate::GenicamInfo> {
    let _g = ARAVIS.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: Aravis's global device list is only touched under `ARAVIS`.
    let list = unsafe { aravis::get_device_list() };
    list.into_iter()
        .map(|d| {
            let s = |c: &std::ffi::CStr| c.to_string_lossy().into_owned();
            let device_id = s(&d.id);
            crate::GenicamInfo {
                uri: format!("genicam:{device_id}"),
                device_id,
                vendor: s(&d.vendor),
                model: s(&d.model),
                protocol: s(&d.protocol),
                address: s(&d.address),
            }
        })
        .collect()
}

use aravis::glib::Error as GlibError;

fn dev(what: &str, e: GlibError) -> GrabError {
    GrabError::DeviceCall {
        what: what.to_string(),
        source: Box::new(e),
    }
}

/// `x` in `lo..=hi`, the ends as a device may store them (single
/// precision floats: 14.55 reads back as 14.5500002).
fn within(x: f64, lo: f64, hi: f64) -> bool {
    let slack = |v: f64| v.abs() * 1e-6;
    x >= lo - slack(lo) && x <= hi + slack(hi)
}

/// A GenICam camera as a frame grabber.
pub struct GenicamGrabber {
    camera: Camera,
    stream: Option<Stream>,
    label: String,
    triggered: bool,
    timeout_ms: Option<u64>,
    packet_resend: bool,
    size: (u32, u32),
    gain: f64,
    agc: bool,
    has_stimulus: bool,
    ids: FrameIds,
    first_timestamp_ns: Option<u64>,
    trigger_timeouts: u32,
    /// How long a grab waits, µs (worked out when the acquisition starts).
    timeout_us: u64,
    /// A whole frame that arrived after a gap: returned by the next grab,
    /// after the gap was reported.
    pending: Option<Frame>,
    /// The camera's chunk data, when it offers any the grabber records.
    chunks: Option<Chunks>,
    /// `TriggerMode` as found at open, restored on close.
    trigger_found: Option<String>,
    /// Why lost packets are not asked for again, when they are not: said
    /// with every damaged frame.
    no_resend: Option<&'static str>,
    /// Packet resends of the acquisitions already stopped (a stream's
    /// counts end with it).
    resends_before: PacketResends,
    /// Whether the camera offers PACKETRESEND, read when the acquisition
    /// starts.
    offers_resend: Option<bool>,
    /// Whether the running acquisition asks for lost packets again
    /// (`resend=always` and a camera that offers it).
    asking_resend: bool,
}

/// Chunk data switched on for this acquisition, and how to read it.
struct Chunks {
    parser: aravis::ChunkParser,
    /// `Chunk…` feature of the gain, if the camera sends one.
    gain: Option<String>,
    agc: bool,
    exposure: bool,
    gate_duty: bool,
}

/// What one buffer's chunks say (each `None` when not there).
#[derive(Clone, Copy, Debug, Default)]
struct ChunkValues {
    gain: Option<f64>,
    agc: Option<bool>,
    exposure_us: Option<f64>,
    gate_duty: Option<f64>,
}

impl GenicamGrabber {
    /// Opens the camera named in `opts` and takes control of it.
    pub fn open(opts: &GenicamOptions) -> Result<Self, GrabError> {
        let camera = {
            let _g = ARAVIS.lock().unwrap_or_else(|e| e.into_inner());
            Camera::new(Some(&opts.name)).map_err(|e| GrabError::NotFound {
                what: format!("no GenICam camera '{}'", opts.name),
                source: Box::new(e),
            })?
        };
        let text = |r: Result<aravis::glib::GString, GlibError>| {
            r.map(|s| s.to_string()).unwrap_or_else(|_| "?".into())
        };
        let vendor = text(camera.vendor_name());
        let model = text(camera.model_name());
        let id = text(camera.device_id());
        let trigger_ok = camera.is_software_trigger_supported().is_ok();
        let triggered = match opts.trigger {
            TriggerChoice::Auto => trigger_ok,
            TriggerChoice::Off => false,
            TriggerChoice::Software if trigger_ok => true,
            TriggerChoice::Software => {
                return Err(GrabError::Unsupported(format!(
                    "GenICam camera '{}' has no software trigger (use ?trigger=off)",
                    opts.name
                )));
            }
        };
        // Registers persist across control sessions (SFNC): the next
        // client finds what this one leaves, so the trigger mode found here
        // is put back on close.
        let trigger_found = camera
            .is_feature_available("TriggerMode")
            .unwrap_or(false)
            .then(|| camera.string("TriggerMode").ok())
            .flatten()
            .map(|s| s.to_string());
        if triggered {
            camera
                .set_trigger("Software")
                .map_err(|e| dev("setting TriggerMode=On, TriggerSource=Software", e))?;
        } else if trigger_ok || camera.is_feature_available("TriggerMode").unwrap_or(false) {
            camera
                .clear_triggers()
                .map_err(|e| dev("setting TriggerMode=Off", e))?;
        }
        camera
            .set_acquisition_mode(aravis::AcquisitionMode::Continuous)
            .map_err(|e| dev("setting AcquisitionMode=Continuous", e))?;
        if let Some((w, h)) = opts.size {
            let (x, y, _, _) = camera.region().map_err(|e| dev("reading the region", e))?;
            let check = |v: u32, b: Result<(i32, i32), GlibError>, what: &str| {
                let (lo, hi) = b.map_err(|e| dev(&format!("reading {what} bounds"), e))?;
                if i64::from(v) < i64::from(lo) || i64::from(v) > i64::from(hi) {
                    return Err(GrabError::InvalidSetting(format!(
                        "{what} {v} outside the camera's {lo}…{hi}"
                    )));
                }
                Ok(())
            };
            check(w, camera.width_bounds(), "Width")?;
            check(h, camera.height_bounds(), "Height")?;
            camera
                .set_region(x, y, w as i32, h as i32)
                .map_err(|e| dev(&format!("setting Width×Height to {w}×{h}"), e))?;
        }
        let (_, _, w, h) = camera.region().map_err(|e| dev("reading the region", e))?;
        let agc = camera.is_gain_auto_available().unwrap_or(false)
            && camera.gain_auto().is_ok_and(|a| a == Auto::Continuous);
        // A camera without a Gain feature reports unity gain.
        let gain = camera_gain(&camera).unwrap_or(1.0);
        let has_stimulus = camera
            .is_feature_available(STIMULUS_FEATURE)
            .unwrap_or(false);
        let label = format!(
            "GenICam {vendor} {model} ({id}) via Aravis, {}",
            if triggered {
                "software trigger"
            } else {
                "free-running"
            }
        );
        Ok(Self {
            camera,
            stream: None,
            label,
            triggered,
            timeout_ms: opts.timeout_ms,
            packet_resend: opts.packet_resend,
            size: (w.max(0) as u32, h.max(0) as u32),
            gain,
            agc,
            has_stimulus,
            ids: FrameIds::default(),
            first_timestamp_ns: None,
            trigger_timeouts: 0,
            timeout_us: 0,
            pending: None,
            chunks: None,
            trigger_found,
            no_resend: None,
            resends_before: PacketResends {
                resend: opts.packet_resend,
                ..PacketResends::default()
            },
            offers_resend: None,
            asking_resend: false,
        })
    }

    /// Whether a GigE Vision camera says it answers PACKETRESEND (its GVCP
    /// capability register). Aravis reads the same bit and, without it,
    /// never asks for a lost packet again whatever the stream's resend
    /// setting (Aravis's fake camera: capability 0, `n_resend_requests`
    /// stays 0). `None`: not GigE Vision, or the register does not read.
    fn offers_packet_resend(&self) -> Option<bool> {
        if !self.camera.is_gv_device() {
            return None;
        }
        let (ok, v) = self.camera.device()?.read_register(GVCP_CAPABILITY).ok()?;
        ok.then_some(v & GVCP_CAPABILITY_PACKET_RESEND != 0)
    }

    /// The running acquisition's packet resends, as Aravis counts them
    /// (`None`: no stream, or not a GigE Vision one).
    fn stream_resends(&self) -> Option<PacketResends> {
        let stream = self.stream.as_ref()?;
        let gv = stream.downcast_ref::<aravis::GvStream>()?;
        let (packets_resent, packets_missing) = gv.statistics();
        Some(PacketResends {
            resend: self.asking_resend,
            camera_offers_resend: self.offers_resend,
            resend_requests: stream.info_uint64_by_name("n_resend_requests"),
            packets_resent,
            packets_missing,
        })
    }

    /// Stops the acquisition (if running); the next grab starts a new one.
    fn stop(&mut self) {
        self.pending = None;
        if let Some(r) = self.stream_resends() {
            self.resends_before = self.resends_before.plus(r);
        }
        if self.stream.take().is_some() {
            // Dropping the stream ends its receive thread and buffers.
            let _ = self.camera.stop_acquisition();
        }
    }

    /// In free-running mode frames already in flight were taken with the
    /// old settings: restart so none of them is returned after the change.
    fn settings_changed(&mut self) {
        // A frame held back behind a reported gap was taken before the
        // change: it is stale now.
        self.pending = None;
        if !self.triggered {
            self.stop();
        }
    }

    /// Switches on the chunks the grabber records, where the camera offers
    /// them (Aravis's fake camera offers none: the values then come from
    /// the camera's features, as without chunk support).
    fn enable_chunks(&mut self) {
        self.chunks = None;
        let cam = &self.camera;
        if !cam.is_feature_available("ChunkModeActive").unwrap_or(false) {
            return;
        }
        let Ok(offered) = cam.dup_available_enumerations_as_strings("ChunkSelector") else {
            return;
        };
        let has = |c: &str| offered.iter().any(|o| o.as_str() == c);
        let gain = GAIN_CHUNKS.into_iter().find(|c| has(c));
        let agc = has(AGC_CHUNK);
        let exposure = has(EXPOSURE_CHUNK);
        let gate_duty = has(GATE_DUTY_CHUNK);
        let list: Vec<&str> = gain
            .into_iter()
            .chain(agc.then_some(AGC_CHUNK))
            .chain(exposure.then_some(EXPOSURE_CHUNK))
            .chain(gate_duty.then_some(GATE_DUTY_CHUNK))
            .collect();
        if list.is_empty() || cam.set_chunks(&list.join(",")).is_err() {
            let _ = cam.set_chunk_mode(false);
            return;
        }
        self.chunks = cam.create_chunk_parser().map(|parser| Chunks {
            parser,
            gain: gain.map(|g| format!("Chunk{g}")),
            agc,
            exposure,
            gate_duty,
        });
    }

    /// The gain, AGC state, exposure and gate duty a buffer's chunks carry.
    fn chunk_values(&self, b: &Buffer) -> ChunkValues {
        let Some(c) = self.chunks.as_ref().filter(|_| b.has_chunks()) else {
            return ChunkValues::default();
        };
        let float = |on: bool, feature: &str| {
            on.then(|| c.parser.float_value(b, feature).ok())
                .flatten()
                .filter(|v| v.is_finite())
        };
        ChunkValues {
            gain: c.gain.as_deref().and_then(|g| float(true, g)),
            agc: c
                .agc
                .then(|| c.parser.integer_value(b, "ChunkAgcActive").ok())
                .flatten()
                .map(|v| v != 0),
            exposure_us: float(c.exposure, "ChunkExposureTime"),
            gate_duty: float(c.gate_duty, "ChunkGateDuty"),
        }
    }

    fn start(&mut self) -> Result<(), GrabError> {
        // Before PayloadSize is read: chunks make the payload longer.
        self.enable_chunks();
        let payload = self
            .camera
            .payload()
            .map_err(|e| dev("reading PayloadSize", e))?;
        let stream = self
            .camera
            .create_stream()
            .map_err(|e| dev("opening the stream channel", e))?;
        self.offers_resend = self.offers_packet_resend();
        // Resend requests only to a camera that answers them: with
        // `Always`, Aravis asked the fake camera (capability bit clear) 588
        // times in 8 frames and got nothing back.
        self.asking_resend = self.packet_resend && self.offers_resend != Some(false);
        if let Some(gv) = stream.downcast_ref::<aravis::GvStream>() {
            gv.set_packet_resend(if self.asking_resend {
                aravis::GvStreamPacketResend::Always
            } else {
                aravis::GvStreamPacketResend::Never
            });
        }
        self.no_resend = if !self.packet_resend {
            Some("resend=never")
        } else if self.offers_resend == Some(false) {
            // Said once here, and with each damaged frame: resend=always
            // cannot help with this camera.
            let _ = writeln!(
                std::io::stderr(),
                "warning: {} does not offer PACKETRESEND (GVCP capability register 0x0934): lost packets cannot be recovered; frames missing any are reported damaged",
                self.label
            );
            Some("the camera does not offer PACKETRESEND")
        } else {
            None
        };
        for _ in 0..N_BUFFERS {
            stream.push_buffer(Buffer::new_allocate(payload as usize));
        }
        self.camera
            .start_acquisition()
            .map_err(|e| dev("AcquisitionStart", e))?;
        self.stream = Some(stream);
        self.ids.reset();
        self.first_timestamp_ns = None;
        self.trigger_timeouts = 0;
        self.timeout_us = self.wait_us();
        Ok(())
    }

    fn wait_us(&self) -> u64 {
        let ms = self.timeout_ms.unwrap_or_else(|| {
            let exposure_us = self.camera.exposure_time().unwrap_or(0.0).max(0.0);
            let period_us = self
                .camera
                .frame_rate()
                .ok()
                .filter(|r| *r > 0.0)
                .map_or(0.0, |r| 1e6 / r);
            2000 + (3.0 * (exposure_us + period_us) / 1000.0).min(600_000.0) as u64
        });
        ms.saturating_mul(1000)
    }

    /// One buffer from the stream (or why not), given back to the stream
    /// after its pixels are copied.
    fn next_buffer(&mut self) -> Result<Frame, GrabError> {
        let timeout_us = self.timeout_us;
        let Some(stream) = self.stream.clone() else {
            return Err(GrabError::Other("no stream".into()));
        };
        loop {
            let Some(buffer) = stream.timeout_pop_buffer(timeout_us) else {
                if self.triggered && self.trigger_timeouts < MAX_TRIGGER_TIMEOUTS {
                    self.trigger_timeouts += 1;
                    let seq = self.ids.skip_one();
                    return Err(GrabError::FramesLost {
                        count: 1,
                        next_seq: seq + 1,
                    });
                }
                return Err(GrabError::Timeout {
                    what: format!("a frame from {}", self.label),
                    after_ms: timeout_us / 1000,
                });
            };
            self.trigger_timeouts = 0;
            let out = self.decode(&buffer);
            stream.push_buffer(buffer);
            match out {
                Some(r) => return r,
                None => continue, // stale: a frame already accounted for
            }
        }
    }

    /// `None` for a stale buffer (an id already returned or reported lost).
    fn decode(&mut self, b: &Buffer) -> Option<Result<Frame, GrabError>> {
        let status = b.status();
        let raw_id = b.frame_id();
        let (seq, lost) = match (raw_id, status) {
            // A buffer Aravis gave up on before it learnt the frame's id.
            (0, s) if s != BufferStatus::Success => (self.ids.skip_one(), 0),
            _ => match self.ids.step(raw_id) {
                IdStep::Stale => return None,
                IdStep::Next { seq, lost } => (seq, lost),
            },
        };
        if status != BufferStatus::Success {
            return Some(Err(if lost > 0 {
                GrabError::FramesLost {
                    count: lost + 1,
                    next_seq: seq + 1,
                }
            } else {
                GrabError::FrameDamaged {
                    seq,
                    reason: match self.no_resend {
                        Some(why) => format!(
                            "incomplete buffer (Aravis status {status:?}; no resend: {why})"
                        ),
                        None => format!("incomplete buffer (Aravis status {status:?})"),
                    },
                }
            }));
        }
        let frame = self.pixels(b, seq);
        if lost > 0 {
            // Report the gap first; this whole frame is the next grab's.
            match frame {
                Ok(f) => self.pending = Some(f),
                Err(e) => return Some(Err(e)),
            }
            return Some(Err(GrabError::FramesLost {
                count: lost,
                next_seq: seq,
            }));
        }
        Some(frame)
    }

    /// The buffer's pixels as counts, checked against its own description.
    fn pixels(&mut self, b: &Buffer, seq: u64) -> Result<Frame, GrabError> {
        let pf = b.image_pixel_format();
        let (bits, bytes_per_px) = mono_layout(pf.raw()).ok_or_else(|| {
            GrabError::Unsupported(format!(
                "pixel format 0x{:08x}: only unpacked Mono8/10/12/14/16 are read",
                pf.raw()
            ))
        })?;
        let (w, h) = (
            b.image_width().max(0) as u32,
            b.image_height().max(0) as u32,
        );
        let data = b.image_data();
        let n = w as usize * h as usize;
        if n == 0 || data.len() < n * bytes_per_px {
            return Err(GrabError::FrameDamaged {
                seq,
                reason: format!(
                    "{} bytes of image data for {w}×{h} at {bytes_per_px} byte(s) per pixel",
                    data.len()
                ),
            });
        }
        let pixels: Vec<u16> = if bytes_per_px == 1 {
            data[..n].iter().map(|&v| u16::from(v)).collect()
        } else {
            data[..2 * n]
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect()
        };
        let top = (1u32 << bits) - 1;
        if let Some(p) = pixels.iter().position(|&v| u32::from(v) > top) {
            // Whole (Aravis checked every packet) but not what the format
            // says: the camera, not the link, is at fault.
            return Err(GrabError::Device(format!(
                "frame {seq}: pixel {p} holds {} but PixelFormat has {bits} bits",
                pixels[p]
            )));
        }
        let ts = b.timestamp();
        let first = *self.first_timestamp_ns.get_or_insert(ts);
        let chunk = self.chunk_values(b);
        let gain = match chunk.gain {
            Some(g) => g,
            // Under AGC the camera's Gain reads the gain in effect (gloam's
            // device: that of the frame just sent).
            None if self.agc => camera_gain(&self.camera).unwrap_or(self.gain),
            None => self.gain,
        };
        let agc = chunk.agc.unwrap_or(self.agc);
        Ok(Frame {
            meta: FrameMeta {
                seq,
                timestamp_us: ts.saturating_sub(first) / 1000,
                gain,
                agc,
                bits,
                width: w,
                height: h,
                pixels_crc32c: crate::pixels_crc32c(&pixels),
                status: FrameStatus::Ok,
                levels: None,
                exposure_us: chunk.exposure_us,
                gate_duty: chunk.gate_duty,
                nd_density: None,
                sensor: None,
            },
            pixels,
        })
    }
}

impl Drop for GenicamGrabber {
    fn drop(&mut self) {
        self.stop();
        if self.chunks.is_some() {
            // Leave the camera as found: image payloads for the next client.
            let _ = self.camera.set_chunk_mode(false);
        }
        // And the trigger mode it had: a free-running camera left
        // triggered would send the next client nothing.
        if let Some(mode) = &self.trigger_found {
            let _ = self.camera.set_string("TriggerMode", mode);
        }
    }
}

impl DeviceControl for GenicamGrabber {
    fn describe(&self) -> String {
        self.label.clone()
    }

    fn frame_size(&self) -> (u32, u32) {
        self.size
    }

    fn set_gain(&mut self, gain: f64) -> Result<f64, GrabError> {
        if !gain.is_finite() {
            return Err(GrabError::InvalidSetting(format!(
                "gain {gain} is not a number"
            )));
        }
        if !self.camera.is_gain_available().unwrap_or(false) {
            return Err(GrabError::Unsupported(format!(
                "{} has no Gain",
                self.label
            )));
        }
        let linear = self
            .camera
            .is_feature_available(GAIN_LINEAR_FEATURE)
            .unwrap_or(false);
        let (lo, hi) = if linear {
            self.camera.float_bounds(GAIN_LINEAR_FEATURE)
        } else {
            self.camera.gain_bounds()
        }
        .map_err(|e| dev("reading the Gain range", e))?;
        if !within(gain, lo, hi) {
            return Err(GrabError::InvalidSetting(format!(
                "gain {gain} is outside the camera's range {lo}–{hi}; the camera is not run at a clamped gain"
            )));
        }
        if self.camera.is_gain_auto_available().unwrap_or(false) {
            self.camera
                .set_gain_auto(Auto::Off)
                .map_err(|e| dev("setting GainAuto=Off", e))?;
        }
        self.agc = false;
        if linear {
            self.camera.set_float(GAIN_LINEAR_FEATURE, gain)
        } else {
            self.camera.set_gain(gain)
        }
        .map_err(|e| dev(&format!("setting Gain={gain}"), e))?;
        self.gain = camera_gain(&self.camera).map_err(|e| dev("reading Gain back", e))?;
        self.settings_changed();
        Ok(self.gain)
    }

    fn set_agc(&mut self, on: bool) -> Result<bool, GrabError> {
        if !self.camera.is_gain_auto_available().unwrap_or(false) {
            if on {
                return Err(GrabError::Unsupported(format!(
                    "{} has no GainAuto (AGC)",
                    self.label
                )));
            }
            return Ok(false);
        }
        let mode = if on { Auto::Continuous } else { Auto::Off };
        self.camera
            .set_gain_auto(mode)
            .map_err(|e| dev(&format!("setting GainAuto={mode:?}"), e))?;
        let now = self
            .camera
            .gain_auto()
            .map_err(|e| dev("reading GainAuto back", e))?;
        self.agc = now == Auto::Continuous;
        if !self.agc {
            self.gain = camera_gain(&self.camera).unwrap_or(self.gain);
        }
        self.settings_changed();
        Ok(self.agc)
    }

    fn set_bits(&mut self, bits: u8) -> Result<u8, GrabError> {
        let name = match bits {
            8 => "Mono8",
            12 => "Mono12",
            16 => "Mono16",
            _ => {
                return Err(GrabError::InvalidSetting(format!(
                    "bit depth {bits}: use 8, 12 or 16"
                )));
            }
        };
        let available: Vec<String> = self
            .camera
            .dup_available_pixel_formats_as_strings()
            .map_err(|e| dev("reading the PixelFormat entries", e))?
            .iter()
            .map(|s| s.to_string())
            .collect();
        if !available.iter().any(|a| a == name) {
            return Err(GrabError::Unsupported(format!(
                "{} has no PixelFormat {name} (it has {})",
                self.label,
                available.join(", ")
            )));
        }
        // PixelFormat is locked during an acquisition: like the sim
        // grabber, a new bit depth starts a new stream.
        self.stop();
        self.camera
            .set_pixel_format_from_string(name)
            .map_err(|e| dev(&format!("setting PixelFormat={name}"), e))?;
        let now = self
            .camera
            .pixel_format()
            .map_err(|e| dev("reading PixelFormat back", e))?;
        mono_layout(now.raw()).map(|(b, _)| b).ok_or_else(|| {
            GrabError::Device(format!(
                "PixelFormat reads 0x{:08x} after writing {name}",
                now.raw()
            ))
        })
    }

    fn set_exposure_s(&mut self, exposure_s: f64) -> Result<f64, GrabError> {
        if !exposure_s.is_finite() || exposure_s <= 0.0 {
            return Err(GrabError::InvalidSetting(format!(
                "exposure {exposure_s} s must be positive"
            )));
        }
        let us = exposure_s * 1e6;
        let (lo, hi) = self
            .camera
            .exposure_time_bounds()
            .map_err(|e| dev("reading the ExposureTime range", e))?;
        if !within(us, lo, hi) {
            return Err(GrabError::InvalidSetting(format!(
                "exposure {exposure_s} s is outside the camera's range {} – {} s",
                lo / 1e6,
                hi / 1e6
            )));
        }
        // Whole microseconds, as every gloam grabber sends them.
        let us = us.round().max(1.0);
        self.camera
            .set_exposure_time(us)
            .map_err(|e| dev(&format!("setting ExposureTime={us} us"), e))?;
        let now = self
            .camera
            .exposure_time()
            .map_err(|e| dev("reading ExposureTime back", e))?;
        self.settings_changed();
        if self.stream.is_some() {
            self.timeout_us = self.wait_us();
        }
        Ok(now / 1e6)
    }

    fn present(&mut self, stimulus: &Stimulus) -> Result<bool, GrabError> {
        if !self.has_stimulus {
            // A real camera: the operator sets the lab source.
            return Ok(false);
        }
        let json = serde_json::to_string(stimulus).map_err(GrabError::StimulusJson)?;
        self.camera
            .set_string(STIMULUS_FEATURE, &json)
            .map_err(|e| GrabError::SettingRefused {
                what: STIMULUS_FEATURE.to_string(),
                source: Box::new(e),
            })?;
        self.settings_changed();
        Ok(true)
    }
}

impl FrameStream for GenicamGrabber {
    fn grab(&mut self) -> Result<Frame, GrabError> {
        if let Some(f) = self.pending.take() {
            return Ok(f);
        }
        if self.stream.is_none() {
            self.start()?;
        }
        if self.triggered {
            self.camera
                .software_trigger()
                .map_err(|e| dev("TriggerSoftware", e))?;
        }
        self.next_buffer()
    }

    fn stop(&mut self) -> Result<(), GrabError> {
        GenicamGrabber::stop(self);
        Ok(())
    }

    fn packet_resends(&self) -> Option<PacketResends> {
        match self.stream_resends() {
            Some(now) => Some(self.resends_before.plus(now)),
            // Before any acquisition, or between two: what was counted.
            None if self.camera.is_gv_device() => Some(self.resends_before),
            None => None,
        }
    }
}
