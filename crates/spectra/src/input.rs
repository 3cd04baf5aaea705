//! Bounded reads of input files (scenes, spectra, OBJ, sensor files).
//!
//! A path that is a directory, a device (`/dev/zero`), a FIFO or larger
//! than its limit is refused before anything is read, with a message that
//! says which, so a bad path can never read forever or exhaust memory.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// Largest text input (scene TOML, spectrum CSV, sensor TOML), bytes.
pub const MAX_TEXT_FILE_BYTES: u64 = 256 << 20;
/// Largest mesh input (OBJ), bytes.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// Largest image or array input (TIFF, NPY: radiance tiles, frames), bytes.
pub const MAX_IMAGE_FILE_BYTES: u64 = 4 << 30;

/// The regular file `path` opened for streaming (hashing), refused like
/// [`read_bounded`]; reads stop at `max_bytes + 1` bytes.
pub fn open_bounded(path: &Path, max_bytes: u64) -> std::io::Result<std::io::Take<std::fs::File>> {
    check_regular(path, max_bytes)?;
    Ok(std::fs::File::open(path)?.take(max_bytes + 1))
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
    fn a_bad_byte_names_its_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("s.toml");
        std::fs::write(&f, b"a = 1\nb = 2\nc = \xff\n").unwrap();
        let e = read_text(&f, 100).unwrap_err();
        assert!(e.to_string().contains("line 3, column 5"), "{e}");
    }
}
