//! The one atomic writer: every report, image and plot gloam writes goes
//! through [`write_atomic`].

use std::path::{Path, PathBuf};

/// A file that could not be written (or encoded), naming it: `PATH: why`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct FileError {
    pub path: PathBuf,
    pub message: String,
}

impl FileError {
    pub fn new(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        Self {
            path: path.into(),
            message: message.to_string(),
        }
    }
}

/// An encoder's failure on the file (or stream) `path` names.
#[derive(Debug, thiserror::Error)]
#[error("encoding {}", path.display())]
pub struct EncodeError {
    pub path: PathBuf,
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

/// Writes bytes atomically: a uniquely named temporary file beside `path`
/// (so two writers never share one), flushed to disk, then renamed over it,
/// so an interrupted run never leaves a half-written report, plot or image.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    use std::io::Write;
    // Only a regular file (or nothing) is replaced: renaming over a device,
    // FIFO or link would destroy something gloam did not create (as root,
    // `/dev/full` once became a 651-byte file).
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        let what = if meta.file_type().is_symlink() {
            Some("a symbolic link")
        } else if meta.is_dir() {
            Some("a directory")
        } else if !meta.is_file() {
            Some("not a regular file (a device, FIFO or socket)")
        } else {
            None
        };
        if let Some(what) = what {
            return Err(FileError::new(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!(
                        "is {what}; gloam writes regular files only and replaces nothing else — name a file path"
                    ),
                ),
            ));
        }
    }
    let dir = match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(d) => {
            std::fs::create_dir_all(d).map_err(|e| FileError::new(d, e))?;
            d
        }
        None => Path::new("."),
    };
    // Mode 0666 less the umask, as `File::create` gives (tempfile's own
    // default is 0600).
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut f = builder
        .tempfile_in(dir)
        .map_err(|e| FileError::new(dir, e))?;
    // Through the plain file: the temporary file's own writer adds its
    // random name to an error ("…/.tmpaTYVIX: No space left on device at
    // path …/.tmpaTYVIX"); the file being written is `path`.
    f.as_file_mut()
        .write_all(bytes)
        .and_then(|_| f.as_file().sync_all())
        .map_err(|e| FileError::new(path, e))?;
    f.persist(path)
        .map(|_| ())
        .map_err(|e| FileError::new(path, e.error))
}
