//! Frames to disk: each frame's file in its format and its line of
//! `frames.jsonl` ([`FrameWriter`]), with the FITS header a frame's record
//! and its run give. The capture that makes the frames is
//! [`crate::capture`].

use std::path::{Path, PathBuf};

use crate::frame_files::{ContactSheet, FrameFormat, FrameStorage, PREVIEW, TIFF_STACK};
use crate::output::{OutputError, write_atomic};
use gloam_io::fits::{FitsCard, FitsValue, fits_frame_bytes};
use gloam_io::frames::FrameLog;
use gloam_io::png::png_frame_bytes;
use gloam_io::tiff::TiffStack;

pub use gloam_io::frames::FrameRecord;

pub use crate::capture::{
    CaptureError, CaptureOptionsError, Captured, Capturing, FrameCapture, SaturationSummary,
    check_options, resolve_scene_sensor, resolve_sensor,
};

/// Why `frames.jsonl` or a frame was not written, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum FrameLogError {
    #[error(transparent)]
    Log(#[from] gloam_io::frames::FrameLogError),
    #[error(transparent)]
    Frame(#[from] OutputError),
}

impl From<gloam_io::EncodeError> for FrameLogError {
    fn from(e: gloam_io::EncodeError) -> Self {
        FrameLogError::Frame(e.into())
    }
}

/// What a frame file's header names besides the frame's own record: the
/// camera, the noise seed and the run's provenance (FITS only).
#[derive(Clone, Debug, Default)]
pub struct FrameContext {
    /// The camera: preset name, sensor file or grabber URI.
    pub camera: Option<String>,
    /// FITS `INSTRUME`: the camera model ([`instrument_of_grabber`] for
    /// a grabber); `None` takes the preset or sensor file name of
    /// `camera`.
    pub instrument: Option<String>,
    pub seed: Option<u64>,
    pub provenance: Option<crate::Provenance>,
    /// The scene's time (`[sky] utc`) at the start of frame 0, for
    /// simulated frames of a scene that has one: `DATE-OBS` is it plus
    /// the frame's start. Without it `DATE-OBS` is the host's clock.
    pub scene_utc: Option<gloam_sky::time::UtcInstant>,
}

/// FITS `INSTRUME` of a grabber opened from `uri` that describes itself
/// as `describe`: `sim:PRESET` (the preset's or sensor file's name) for a
/// simulated camera, `genicam:VENDOR MODEL` for a GenICam camera, else
/// the URI's scheme and the device's description up to its details
/// (`serial:gloam protocol 1.0 device #7`).
pub fn instrument_of_grabber(uri: &str, describe: &str) -> String {
    let scheme = uri.split_once(':').map_or(uri, |(s, _)| s);
    if let Ok(gloam_simcam::SimUri { preset, .. }) = gloam_simcam::SimUri::parse(uri) {
        return format!("sim:{}", sensor_name(&preset));
    }
    let model = describe.strip_prefix("GenICam ").unwrap_or(describe);
    let model = model.split(" (").next().unwrap_or(model);
    let model = model.split(" over ").next().unwrap_or(model);
    format!("{scheme}:{}", model.trim())
}

/// The time of `scene` (its `[sky] utc`), if it has one: the start of
/// frame 0 of its simulated captures ([`FrameContext::scene_utc`]).
pub fn scene_utc(scene: &gloam_scene::Scene) -> Option<gloam_sky::time::UtcInstant> {
    scene.sky.as_ref().map(|sky| sky.instant)
}

/// A sensor preset's name as it is, a sensor file's by its file name.
fn sensor_name(sensor: &str) -> String {
    Path::new(sensor)
        .file_name()
        .map_or(sensor.to_string(), |n| n.to_string_lossy().into_owned())
}

/// A UTC instant as FITS dates are written: ISO-8601 without the zone
/// letter (FITS 4.0 §4.4.2.1: UTC unless `TIMESYS` says otherwise).
fn fits_date(t: &gloam_sky::time::UtcInstant) -> String {
    t.to_iso8601().trim_end_matches('Z').to_string()
}

/// The host's clock now.
fn utc_now() -> Option<gloam_sky::time::UtcInstant> {
    let unix_s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .ok()?
        .as_secs_f64();
    // JD 2440587.5 is the Unix epoch.
    gloam_sky::time::UtcInstant::from_julian_date(unix_s / 86_400.0 + 2_440_587.5).ok()
}

/// The most frames [`FrameWriter`]'s contact sheet shows.
pub const PREVIEW_FRAMES: usize = 16;

/// Writes frames as every command does: each frame's file in the chosen
/// [`FrameFormat`] (PNG and FITS atomically, one file per frame; TIFF as
/// pages appended to `frames.tiff`), then its record appended to
/// `frames.jsonl`, so the log never lists a frame that is not on disk;
/// [`FrameWriter::finish`] adds the contact sheet `frames-preview.png`.
pub struct FrameWriter {
    dir: PathBuf,
    log: FrameLog,
    format: FrameFormat,
    context: FrameContext,
    tiff: Option<TiffStack>,
    sheet: ContactSheet,
}

impl FrameWriter {
    /// PNG frames; creates (truncates) `dir/frames.jsonl`.
    pub fn create(dir: &Path) -> Result<Self, FrameLogError> {
        Self::with_format(dir, FrameFormat::Png, FrameContext::default())
    }

    /// Frames in `format`, FITS headers naming `context`.
    pub fn with_format(
        dir: &Path,
        format: FrameFormat,
        context: FrameContext,
    ) -> Result<Self, FrameLogError> {
        Ok(Self {
            dir: dir.to_path_buf(),
            log: FrameLog::create(dir)?,
            format,
            context,
            tiff: None,
            sheet: ContactSheet::new(PREVIEW_FRAMES),
        })
    }

    /// Writes the frame `rec` describes (its index and size) with its
    /// counts `pixels` in row order, then appends `rec` to the log with
    /// its `file` and `stored` set to where and how the counts went.
    pub fn write(&mut self, rec: &FrameRecord, pixels: &[u16]) -> Result<(), FrameLogError> {
        let mut rec = rec.clone();
        rec.file = self.format.file_name(rec.index);
        let (w, h) = (rec.width, rec.height);
        let stored = match self.format {
            FrameFormat::Png => {
                let (png, shift) = png_frame_bytes(w, h, rec.bits, pixels)?;
                write_atomic(&self.dir.join(&rec.file), &png)?;
                FrameStorage {
                    format: self.format,
                    sample_shift: shift,
                    page: None,
                }
            }
            FrameFormat::Fits => {
                let cards = fits_cards(&rec, &self.context, utc_now());
                write_atomic(
                    &self.dir.join(&rec.file),
                    &fits_frame_bytes(w, h, pixels, &cards),
                )?;
                FrameStorage {
                    format: self.format,
                    sample_shift: 0,
                    page: None,
                }
            }
            FrameFormat::Tiff => {
                let stack = match &mut self.tiff {
                    Some(t) => t,
                    None => self
                        .tiff
                        .insert(TiffStack::create(&self.dir.join(TIFF_STACK))?),
                };
                let (page, shift) = stack.append(w, h, rec.bits, pixels)?;
                FrameStorage {
                    format: self.format,
                    sample_shift: shift,
                    page: Some(page),
                }
            }
        };
        rec.stored = Some(stored);
        let black = rec.black_dn.unwrap_or(0.0);
        (self.sheet).add(rec.index, w, h, pixels, black, rec.saturated_at_dn);
        Ok(self.log.append(&rec)?)
    }

    /// Writes `frames-preview.png` (the contact sheet) and closes the TIFF.
    pub fn finish(self) -> Result<(), FrameLogError> {
        drop(self.tiff);
        if let Some(png) = self.sheet.png()? {
            write_atomic(&self.dir.join(PREVIEW), &png)?;
        }
        Ok(())
    }
}

/// A frame's FITS header cards after the mandatory ones: the frame's
/// time, settings and levels from its record, then the context's camera,
/// seed and provenance; `now` is the host's clock as the frame is written
/// (`DATE-OBS` of a frame with no scene time).
fn fits_cards(
    rec: &FrameRecord,
    ctx: &FrameContext,
    now: Option<gloam_sky::time::UtcInstant>,
) -> Vec<FitsCard> {
    use FitsValue::{Bool, Float, Int, Str};
    let mut c = vec![
        FitsCard::new("BUNIT", Str("DN".into()), "digital counts"),
        FitsCard::new("FRAME", Int(rec.index.into()), "index in this capture"),
        FitsCard::new("SEQ", Int(rec.seq.into()), "camera frame number"),
        FitsCard::new(
            "TSTAMPUS",
            Int(rec.timestamp.into()),
            "frame start, us from stream start",
        ),
    ];
    // A simulated frame of a scene with a time: that time plus the frame's
    // start (a sequence's exposure start, else seq / frame rate).
    let scene_time = match (&rec.sensor, ctx.scene_utc) {
        (Some(m), Some(t0)) => {
            Some(t0.plus_seconds(rec.sequence.as_ref().map_or(m.time_s, |s| s.time_s)))
        }
        _ => None,
    };
    let date_obs = match (scene_time, now) {
        (Some(t), _) => Some((t, "UTC, scene [sky] utc + frame start")),
        (None, Some(t)) if rec.sensor.is_some() => {
            Some((t, "UTC, host clock at capture (no scene time)"))
        }
        (None, Some(t)) => Some((t, "UTC, host clock when the frame arrived")),
        (None, None) => None,
    };
    if let Some((t, why)) = date_obs {
        c.push(FitsCard::new("DATE-OBS", Str(fits_date(&t)), why));
    }
    let instrument = (ctx.instrument.clone()).or_else(|| ctx.camera.as_deref().map(sensor_name));
    if let Some(i) = instrument {
        c.push(FitsCard::new("INSTRUME", Str(i), "camera"));
    }
    if let Some(m) = &rec.sensor {
        c.push(FitsCard::new(
            "EXPTIME",
            Float(m.exposure_s),
            "exposure time, s",
        ));
    } else if let Some(us) = rec.exposure_us {
        c.push(FitsCard::new(
            "EXPTIME",
            Float(us / 1e6),
            "exposure time, s",
        ));
    }
    if let Some(d) = rec.gate_duty {
        c.push(FitsCard::new(
            "GATEDUTY",
            Float(d),
            "photocathode gate duty cycle",
        ));
    }
    if let Some(nd) = rec.nd_density {
        c.push(FitsCard::new(
            "NDDENS",
            Float(nd),
            "ND filter optical density",
        ));
    }
    c.extend([
        FitsCard::new(
            "TUBEGAIN",
            Float(rec.gain),
            "tube or system gain in effect, linear",
        ),
        FitsCard::new("AGC", Bool(rec.agc), "gain set by the AGC"),
        FitsCard::new("BITS", Int(rec.bits.into()), "digitizer bits"),
    ]);
    // ccdproc's and astropy's GAIN: electrons per DN. Only a camera that
    // knows its conversion says; a real camera's is not guessed.
    if let Some(k) = rec.electrons_per_dn.filter(|k| k.is_finite() && *k > 0.0) {
        c.push(FitsCard::new(
            "GAIN",
            Float(k),
            "e-/DN, photoelectrons per DN at TUBEGAIN",
        ));
    }
    if let Some(b) = rec.black_dn {
        c.push(FitsCard::new("BLACKDN", Float(b), "black level, DN"));
    }
    c.extend([
        FitsCard::new(
            "SATDN",
            Float(rec.saturated_at_dn),
            "saturated at or above, DN",
        ),
        FitsCard::new("MEANDN", Float(rec.mean_dn), "mean count, DN"),
        FitsCard::new(
            "SATFRAC",
            Float(rec.saturated_fraction),
            "saturated fraction",
        ),
    ]);
    if let Some(cam) = &ctx.camera {
        c.push(FitsCard::new(
            "CAMERA",
            Str(cam.clone()),
            "sensor preset, file or URI",
        ));
    }
    if let Some(seed) = ctx.seed {
        c.push(FitsCard::new("SEED", Int(seed.into()), "noise seed"));
    }
    c.push(FitsCard::new(
        "GLOAMVER",
        Str(crate::provenance::VERSION_WITH_COMMIT.into()),
        "software",
    ));
    if let Some(p) = &ctx.provenance {
        // FITS dates are UTC without a zone letter.
        let utc = p.utc.trim_end_matches('Z').to_string();
        c.push(FitsCard::new("DATE", Str(utc), "run start, UTC"));
        const KEYS: [(&str, &str); 4] = [
            ("INPUT1", "ISHA1"),
            ("INPUT2", "ISHA2"),
            ("INPUT3", "ISHA3"),
            ("INPUT4", "ISHA4"),
        ];
        for (f, (k, h)) in p.inputs.iter().zip(KEYS) {
            c.push(FitsCard::new(k, Str(f.path.clone()), "input file"));
            c.push(FitsCard::new(h, Str(f.sha256.clone()), "its SHA-256"));
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use gloam_grabber::{Frame, FrameStatus};

    #[test]
    fn instruments_name_the_camera_model() {
        assert_eq!(
            instrument_of_grabber("sim:gen3-gaas-iccd?rig=edge&seed=2", "simulated …"),
            "sim:gen3-gaas-iccd"
        );
        assert_eq!(
            instrument_of_grabber("sim:my/cams/cam.toml", ""),
            "sim:cam.toml"
        );
        assert_eq!(
            instrument_of_grabber(
                "genicam:127.0.0.1?resend=always",
                "GenICam Aravis Fake (Fake_1) via Aravis, software trigger"
            ),
            "genicam:Aravis Fake"
        );
        assert_eq!(
            instrument_of_grabber(
                "serial:/dev/pts/3",
                "gloam protocol 1.0 device #7 (firmware 1.2.3, 640×480 max) over serial /dev/pts/3 @ 115200 baud"
            ),
            "serial:gloam protocol 1.0 device #7"
        );
    }

    fn grabbed(levels: Option<gloam_grabber::DnLevels>) -> FrameRecord {
        let f = Frame {
            meta: gloam_grabber::FrameMeta {
                seq: 4,
                timestamp_us: 160_000,
                gain: 25.0,
                agc: false,
                bits: 12,
                width: 2,
                height: 1,
                pixels_crc32c: 0,
                status: FrameStatus::Ok,
                levels,
                exposure_us: None,
                gate_duty: None,
                nd_density: None,
                sensor: None,
            },
            pixels: vec![100, 200],
        };
        FrameRecord::of_frame(4, String::new(), &f, Vec::new())
    }

    fn card<'a>(cards: &'a [FitsCard], key: &str) -> Option<&'a FitsCard> {
        cards.iter().find(|c| c.key == key)
    }

    /// GAIN only from a camera that knows its conversion; the tube's
    /// gain always under TUBEGAIN; DATE-OBS the host clock for a grab.
    #[test]
    fn a_grabbed_frame_has_gain_only_when_the_camera_knows_it() {
        let now = gloam_sky::time::UtcInstant::parse_iso8601("2026-01-02T03:04:05.5Z").unwrap();
        let ctx = FrameContext {
            instrument: Some("serial:gloam protocol 1.0 device #7".into()),
            ..FrameContext::default()
        };
        let c = fits_cards(&grabbed(None), &ctx, Some(now));
        assert!(card(&c, "GAIN").is_none());
        assert_eq!(card(&c, "TUBEGAIN").unwrap().value, FitsValue::Float(25.0));
        let d = card(&c, "DATE-OBS").unwrap();
        assert_eq!(d.value, FitsValue::Str("2026-01-02T03:04:05.500".into()));
        assert!(d.comment.contains("host clock when the frame arrived"));
        assert_eq!(
            card(&c, "INSTRUME").unwrap().value,
            FitsValue::Str("serial:gloam protocol 1.0 device #7".into())
        );
        let levels = gloam_grabber::DnLevels {
            black_dn: 0.0,
            saturation_dn: 4095.0,
            saturated_at_dn: 4090.0,
            electrons_per_dn: Some(0.25),
        };
        let c = fits_cards(&grabbed(Some(levels)), &ctx, Some(now));
        assert_eq!(card(&c, "GAIN").unwrap().value, FitsValue::Float(0.25));
        assert!(c.iter().all(|c| c.key.len() <= 8));
    }
}
