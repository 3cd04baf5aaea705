//! Bounded reads of input files (scenes, spectra, OBJ, sensor files).
//!
//! A path that is a directory, a device (`/dev/zero`), a FIFO or larger
//! than its limit is refused before anything is read, with a message that
//! says which, so a bad path can never read forever or exhaust memory.
//!
//! Because every input goes through here, this is also where a run learns
//! what it read: each read takes the [`ReadLog`] of the run it serves,
//! which notes every file opened or read (with the SHA-256 of the bytes
//! read, for whole-file reads) for the run's provenance. Reads that are
//! not inputs (hashing outputs, checking a previous output set) pass
//! [`ReadLog::off`]. The log is a value each run owns, not process state,
//! so two runs in one process (Python, a sweep's parallel tasks) keep
//! their inputs apart.

use std::io::{Error, ErrorKind, Read};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use sha2::{Digest, Sha256};

/// A file read into a [`ReadLog`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileRead {
    /// The path as the reader was given it.
    pub path: PathBuf,
    pub bytes: u64,
    /// SHA-256 (hex) of the bytes read, for a whole-file read; None for a
    /// file opened for streaming (hash it afterwards).
    pub sha256: Option<String>,
}

/// Most reads one log records (a calibration over a stack of frames reads
/// many); later reads are counted in [`ReadLog::not_recorded`].
pub const MAX_RECORDED_READS: usize = 100_000;

#[derive(Debug, Default)]
struct Record {
    reads: Vec<FileRead>,
    dropped: usize,
}

/// The files one run read, in order (repeats included): made by whoever
/// owns the run (a request, a sweep task), handed to every loader, read
/// back for the provenance. Clones share one record and may be used from
/// several threads; [`ReadLog::off`] records nothing.
#[derive(Clone, Debug)]
pub struct ReadLog(Option<Arc<Mutex<Record>>>);

impl Default for ReadLog {
    /// A new, empty log that records.
    fn default() -> Self {
        Self::new()
    }
}

impl ReadLog {
    /// A new, empty log that records.
    pub fn new() -> Self {
        Self(Some(Arc::default()))
    }

    /// A log that records nothing: for reads that are not a run's inputs.
    pub fn off() -> Self {
        Self(None)
    }

    /// Whether reads into this log are recorded.
    pub fn is_on(&self) -> bool {
        self.0.is_some()
    }

    /// Every file recorded so far, in order.
    pub fn reads(&self) -> Vec<FileRead> {
        self.with(|r| r.reads.clone()).unwrap_or_default()
    }

    /// Reads past [`MAX_RECORDED_READS`], not listed by [`ReadLog::reads`].
    pub fn not_recorded(&self) -> usize {
        self.with(|r| r.dropped).unwrap_or(0)
    }

    /// Records `reads` as read by this run too (a sweep's tasks into the
    /// sweep's log).
    pub fn extend(&self, reads: &[FileRead]) {
        for r in reads {
            self.note(&r.path, r.bytes, r.sha256.clone());
        }
    }

    fn with<T>(&self, f: impl FnOnce(&mut Record) -> T) -> Option<T> {
        // A poisoned lock still holds the reads made before the panic.
        let m = self.0.as_ref()?;
        let mut g = m.lock().unwrap_or_else(|p| p.into_inner());
        Some(f(&mut g))
    }

    fn note(&self, path: &Path, bytes: u64, sha256: Option<String>) {
        self.with(|r| {
            if r.reads.len() < MAX_RECORDED_READS {
                r.reads.push(FileRead {
                    path: path.to_path_buf(),
                    bytes,
                    sha256,
                });
            } else {
                r.dropped += 1;
            }
        });
    }
}

/// `text` from an input as a message quotes it: control characters
/// (a NUL, a carriage return, an escape sequence) spelled out, so the
/// fault is visible — a row `1,2<NUL>` was quoted as `found '1,2'`, which
/// looks valid on a terminal.
pub fn shown(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return text.into();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// SHA-256 of `bytes`, hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    Sha256::digest(bytes)
        .iter()
        .fold(String::with_capacity(64), |mut s, x| {
            let _ = write!(s, "{x:02x}");
            s
        })
}

/// Largest text input (scene TOML, spectrum CSV, sensor TOML), bytes.
pub const MAX_TEXT_FILE_BYTES: u64 = 256 << 20;
/// Largest mesh input (OBJ), bytes.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// Largest image or array input (TIFF, NPY: radiance tiles, frames), bytes.
pub const MAX_IMAGE_FILE_BYTES: u64 = 4 << 30;

/// The regular file `path` opened for streaming (hashing), refused like
/// [`read_bounded`]; reads stop at `max_bytes + 1` bytes. `reads` notes
/// the file (unhashed).
pub fn open_bounded(
    path: &Path,
    max_bytes: u64,
    reads: &ReadLog,
) -> std::io::Result<std::io::Take<std::fs::File>> {
    let meta = check_regular(path, max_bytes)?;
    let f = std::fs::File::open(path)?.take(max_bytes + 1);
    reads.note(path, meta.len(), None);
    Ok(f)
}

/// Refuses a directory, a non-regular file or one over `max_bytes`.
fn check_regular(path: &Path, max_bytes: u64) -> std::io::Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "is a directory, not a file",
        ));
    }
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "is not a regular file (a device, FIFO or socket)",
        ));
    }
    if meta.len() > max_bytes {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "is {} bytes, more than the {max_bytes}-byte limit for this kind of input",
                meta.len()
            ),
        ));
    }
    Ok(meta)
}

/// The bytes of the regular file `path`, at most `max_bytes` of them;
/// `reads` notes the file with the hash of those bytes.
pub fn read_bounded(path: &Path, max_bytes: u64, reads: &ReadLog) -> std::io::Result<Vec<u8>> {
    let meta = check_regular(path, max_bytes)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // `take` holds the limit even if the file grows while it is read.
    std::fs::File::open(path)?
        .take(max_bytes + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("grew past the {max_bytes}-byte limit while being read"),
        ));
    }
    if reads.is_on() {
        reads.note(path, bytes.len() as u64, Some(sha256_hex(&bytes)));
    }
    Ok(bytes)
}

/// The UTF-8 text of the regular file `path` (see [`read_bounded`]); a
/// byte that is not UTF-8 is reported with its line and column.
pub fn read_text(path: &Path, max_bytes: u64, reads: &ReadLog) -> std::io::Result<String> {
    let bytes = read_bounded(path, max_bytes, reads)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let b = e.as_bytes();
        let line = 1 + b[..at].iter().filter(|&&c| c == b'\n').count();
        let col = 1 + at
            - b[..at]
                .iter()
                .rposition(|&c| c == b'\n')
                .map_or(0, |p| p + 1);
        Error::new(
            ErrorKind::InvalidData,
            format!(
                "line {line}, column {col}: byte 0x{:02x} is not UTF-8 text",
                b[at]
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directories_devices_and_oversized_files_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let off = ReadLog::off();
        let e = read_text(dir.path(), 10, &off).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = read_text(Path::new("/dev/zero"), 10, &off).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let f = dir.path().join("big.csv");
        std::fs::write(&f, vec![b'1'; 11]).unwrap();
        let e = read_text(&f, 10, &off).unwrap_err();
        assert!(e.to_string().contains("limit"), "{e}");
        assert_eq!(read_text(&f, 11, &off).unwrap().len(), 11);
    }

    #[test]
    fn reads_are_recorded_in_their_own_log_with_the_hash_of_the_bytes_read() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.csv");
        std::fs::write(&f, b"abc").unwrap();
        let log = ReadLog::new();
        let other = ReadLog::new();
        read_text(&f, 10, &log).unwrap();
        read_text(&f, 10, &ReadLog::off()).unwrap();
        open_bounded(&f, 10, &log.clone()).unwrap();
        let got = log.reads();
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(other.reads().is_empty() && ReadLog::off().reads().is_empty());
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            got[0].sha256.as_deref(),
            Some("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad")
        );
        assert_eq!((got[0].bytes, got[1].bytes), (3, 3));
        assert_eq!(got[1].sha256, None);
        other.extend(&got);
        assert_eq!(other.reads(), got);
    }

    #[test]
    fn a_log_keeps_at_most_its_limit_and_counts_the_rest() {
        let log = ReadLog::new();
        let one = FileRead {
            path: "x".into(),
            bytes: 1,
            sha256: None,
        };
        log.extend(&vec![one; MAX_RECORDED_READS + 3]);
        assert_eq!(log.reads().len(), MAX_RECORDED_READS);
        assert_eq!(log.not_recorded(), 3);
    }

    #[test]
    fn a_bad_byte_names_its_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("s.toml");
        std::fs::write(&f, b"a = 1\nb = 2\nc = \xff\n").unwrap();
        let e = read_text(&f, 100, &ReadLog::off()).unwrap_err();
        assert!(e.to_string().contains("line 3, column 5"), "{e}");
    }
}
