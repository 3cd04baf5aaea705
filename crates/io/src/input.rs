//! Bounded reads of input files (scenes, spectra, OBJ, sensor files).
//!
//! A path that is a directory, a device (`/dev/zero`), a FIFO or larger
//! than its limit is refused before anything is read, with a message that
//! says which, so a bad path can never read forever or exhaust memory.
//!
//! Because every input goes through here, this is also where a run learns
//! what it read: after [`record_reads`], every file opened or read is
//! noted (with the SHA-256 of the bytes read, for whole-file reads), and
//! [`reads`] lists them for the run's provenance. Reads inside
//! [`unrecorded`] (hashing outputs, checking a previous output set) are
//! not inputs and are left out.

use std::cell::{Cell, RefCell};
use std::io::{Error, ErrorKind, Read};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use sha2::{Digest, Sha256};

/// A file read while recording.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileRead {
    /// The path as the reader was given it.
    pub path: PathBuf,
    pub bytes: u64,
    /// SHA-256 (hex) of the bytes read, for a whole-file read; None for a
    /// file opened for streaming (hash it afterwards).
    pub sha256: Option<String>,
}

/// Most reads one run records (a calibration over a stack of frames reads
/// many); later reads are counted in [`reads_not_recorded`].
pub const MAX_RECORDED_READS: usize = 100_000;

struct Record {
    reads: Vec<FileRead>,
    dropped: usize,
}

static RECORD: Mutex<Option<Record>> = Mutex::new(None);

thread_local! {
    static SUPPRESSED: Cell<u32> = const { Cell::new(0) };
    /// Open [`collect_reads`] scopes of this thread, innermost last.
    static COLLECTING: RefCell<Vec<Vec<FileRead>>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` and returns, with its result, the files it read on this thread
/// (whether or not [`record_reads`] is on): what one sweep task read.
pub fn collect_reads<T>(f: impl FnOnce() -> T) -> (T, Vec<FileRead>) {
    struct Pop;
    impl Drop for Pop {
        fn drop(&mut self) {
            COLLECTING.with(|c| c.borrow_mut().pop());
        }
    }
    COLLECTING.with(|c| c.borrow_mut().push(Vec::new()));
    let pop = Pop;
    let t = f();
    let reads = COLLECTING
        .with(|c| c.borrow_mut().last_mut().map(std::mem::take))
        .unwrap_or_default();
    drop(pop);
    (t, reads)
}

/// Starts recording every file this process reads through this module
/// (idempotent). The CLI calls it first thing.
pub fn record_reads() {
    if let Ok(mut r) = RECORD.lock() {
        r.get_or_insert_with(|| Record {
            reads: Vec::new(),
            dropped: 0,
        });
    }
}

/// Every file read since [`record_reads`], in order (repeats included).
pub fn reads() -> Vec<FileRead> {
    RECORD
        .lock()
        .ok()
        .and_then(|r| r.as_ref().map(|r| r.reads.clone()))
        .unwrap_or_default()
}

/// Reads past [`MAX_RECORDED_READS`], not listed by [`reads`].
pub fn reads_not_recorded() -> usize {
    RECORD
        .lock()
        .ok()
        .and_then(|r| r.as_ref().map(|r| r.dropped))
        .unwrap_or(0)
}

/// Runs `f` without recording the reads it makes on this thread (outputs
/// being hashed or checked are not inputs).
pub fn unrecorded<T>(f: impl FnOnce() -> T) -> T {
    struct Restore;
    impl Drop for Restore {
        fn drop(&mut self) {
            SUPPRESSED.with(|s| s.set(s.get().saturating_sub(1)));
        }
    }
    SUPPRESSED.with(|s| s.set(s.get() + 1));
    let _restore = Restore;
    f()
}

fn note(path: &Path, bytes: u64, sha256: Option<String>) {
    if SUPPRESSED.with(|s| s.get()) > 0 {
        return;
    }
    COLLECTING.with(|c| {
        for scope in c.borrow_mut().iter_mut() {
            if scope.len() < MAX_RECORDED_READS {
                scope.push(FileRead {
                    path: path.to_path_buf(),
                    bytes,
                    sha256: sha256.clone(),
                });
            }
        }
    });
    if let Ok(mut r) = RECORD.lock()
        && let Some(r) = r.as_mut()
    {
        if r.reads.len() < MAX_RECORDED_READS {
            r.reads.push(FileRead {
                path: path.to_path_buf(),
                bytes,
                sha256,
            });
        } else {
            r.dropped += 1;
        }
    }
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

fn is_recording() -> bool {
    SUPPRESSED.with(|s| s.get()) == 0
        && (COLLECTING.with(|c| !c.borrow().is_empty()) || RECORD.lock().is_ok_and(|r| r.is_some()))
}

/// Largest text input (scene TOML, spectrum CSV, sensor TOML), bytes.
pub const MAX_TEXT_FILE_BYTES: u64 = 256 << 20;
/// Largest mesh input (OBJ), bytes.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// Largest image or array input (TIFF, NPY: radiance tiles, frames), bytes.
pub const MAX_IMAGE_FILE_BYTES: u64 = 4 << 30;

/// The regular file `path` opened for streaming (hashing), refused like
/// [`read_bounded`]; reads stop at `max_bytes + 1` bytes.
pub fn open_bounded(path: &Path, max_bytes: u64) -> std::io::Result<std::io::Take<std::fs::File>> {
    let meta = check_regular(path, max_bytes)?;
    let f = std::fs::File::open(path)?.take(max_bytes + 1);
    note(path, meta.len(), None);
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

/// The bytes of the regular file `path`, at most `max_bytes` of them.
pub fn read_bounded(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
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
    if is_recording() {
        note(path, bytes.len() as u64, Some(sha256_hex(&bytes)));
    }
    Ok(bytes)
}

/// The UTF-8 text of the regular file `path` (see [`read_bounded`]); a
/// byte that is not UTF-8 is reported with its line and column.
pub fn read_text(path: &Path, max_bytes: u64) -> std::io::Result<String> {
    let bytes = read_bounded(path, max_bytes)?;
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
        let e = read_text(dir.path(), 10).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = read_text(Path::new("/dev/zero"), 10).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let f = dir.path().join("big.csv");
        std::fs::write(&f, vec![b'1'; 11]).unwrap();
        let e = read_text(&f, 10).unwrap_err();
        assert!(e.to_string().contains("limit"), "{e}");
        assert_eq!(read_text(&f, 11).unwrap().len(), 11);
    }

    #[test]
    fn reads_are_recorded_with_the_hash_of_the_bytes_read() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.csv");
        std::fs::write(&f, b"abc").unwrap();
        record_reads();
        read_text(&f, 10).unwrap();
        unrecorded(|| read_text(&f, 10).unwrap());
        let mine: Vec<FileRead> = reads().into_iter().filter(|r| r.path == f).collect();
        assert_eq!(mine.len(), 1, "{mine:?}");
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            mine[0].sha256.as_deref(),
            Some("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad")
        );
        assert_eq!(mine[0].bytes, 3);
        // A scope collects this thread's reads, recording on or not.
        let ((), got) = collect_reads(|| {
            read_text(&f, 10).unwrap();
        });
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].sha256, mine[0].sha256);
    }

    #[test]
    fn a_bad_byte_names_its_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("s.toml");
        std::fs::write(&f, b"a = 1\nb = 2\nc = \xff\n").unwrap();
        let e = read_text(&f, 100).unwrap_err();
        assert!(e.to_string().contains("line 3, column 5"), "{e}");
    }
}
