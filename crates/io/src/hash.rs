//! Files by content: a file's size and SHA-256, as every provenance
//! record and manifest lists them.

use std::path::Path;

use serde::Serialize;
use sha2::{Digest, Sha256};

/// An input file and its content hash.
#[derive(Clone, Debug, Serialize)]
pub struct InputFile {
    pub path: String,
    pub bytes: u64,
    pub sha256: String,
}

/// Files larger than this are listed without a hash (a multi-GB frame
/// stack should not stall a run's start).
pub const MAX_HASHED_BYTES: u64 = 1 << 30;

/// `path`'s size and SHA-256 (hex), or None when it cannot be read.
pub fn hash_file(path: &Path) -> Option<InputFile> {
    use std::io::Read;
    let meta = std::fs::metadata(path).ok()?;
    let mut sha256 = String::new();
    // Regular files only: /dev/zero has length 0 and never ends.
    if meta.is_file() && meta.len() <= MAX_HASHED_BYTES {
        let mut f =
            crate::input::open_bounded(path, MAX_HASHED_BYTES, &crate::ReadLog::off()).ok()?;
        let mut h = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let n = f.read(&mut buf).ok()?;
            if n == 0 {
                break;
            }
            h.update(&buf[..n]);
        }
        sha256 = hex(&h.finalize());
    }
    Some(InputFile {
        path: path.display().to_string(),
        bytes: meta.len(),
        sha256,
    })
}

fn hex(b: &[u8]) -> String {
    use std::fmt::Write as _;
    b.iter()
        .fold(String::with_capacity(2 * b.len()), |mut s, x| {
            let _ = write!(s, "{x:02x}");
            s
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_listed_with_its_size_and_hash_and_a_device_without_one() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.csv");
        std::fs::write(&f, b"abc").unwrap();
        let got = hash_file(&f).unwrap();
        assert_eq!(got.bytes, 3);
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            got.sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        if Path::new("/dev/zero").exists() {
            assert_eq!(hash_file(Path::new("/dev/zero")).unwrap().sha256, "");
        }
        assert!(hash_file(&dir.path().join("missing")).is_none());
    }
}
