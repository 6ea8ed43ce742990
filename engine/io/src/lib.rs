//! Reading the user's input files safely: every loader of the engine and the demo reads its files through
//! [`read`] or [`read_to_string`], runs parsers that may panic through [`catch_quiet`], and cuts input it echoes
//! in a message with [`excerpt`] / [`shorten`].
//!
//! - Only regular files are read. A FIFO would block the open (and the read) forever, a character device such as
//!   `/dev/zero` or `/dev/urandom` never ends, a folder is no file: each is refused up front, by name. Symbolic
//!   links are followed to what they point at (a link to `/dev/zero` is refused as `/dev/zero` is; a link loop is
//!   an error from the system).
//! - Every kind of file has a size [`Limit`], checked against the file's length before anything is read and again
//!   while reading (a file that grows past it is refused, so nothing reads without bound).
//! - The file is opened with `O_NONBLOCK` and checked again through the open handle, so a FIFO put in the place of
//!   a checked file cannot block the open either.
//!
//! A small crate of its own because the sphere-file loader (crate `engine-blockers`) and the engine's loaders
//! (crate `engine`, which depends on it) both need it, and neither is the place of the other's files.

use std::io::Read;
use std::path::{Path, PathBuf};

mod folder;
mod quiet;
mod text;

pub use folder::ModelFolder;
pub use quiet::{catch_quiet, contained_panics};
pub use text::{escape_controls, excerpt, quote, shorten, MAX_EXCERPT_CHARS, MAX_LINE_CHARS, MAX_WORD_CHARS};

/// The largest file of one kind that is read, and what the kind is called in messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limit {
    pub bytes: u64,
    pub what: &'static str,
}

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

impl Limit {
    /// OBJ, glTF (its JSON), GLB and a glTF's external buffers: 1 GiB. Every mesh lives in memory as f32
    /// positions, normals and indices (and on the GPU); a model this large is far beyond what the techniques
    /// shade interactively.
    pub const MESH: Limit = Limit { bytes: GIB, what: "mesh files (OBJ, glTF, GLB, glTF buffers)" };
    /// `.mtl` material libraries: 16 MiB (a few hundred bytes per material).
    pub const MATERIAL_LIBRARY: Limit = Limit { bytes: 16 * MIB, what: "material libraries (.mtl)" };
    /// Scene descriptions (`.toml`): 16 MiB (a scene file is a few kB).
    pub const SCENE: Limit = Limit { bytes: 16 * MIB, what: "scene files (.toml)" };
    /// Sphere files (`.spheres.json`): 64 MiB (4096 spheres, the most a fit makes, take about 400 kB).
    pub const SPHERES: Limit = Limit { bytes: 64 * MIB, what: "sphere files (.spheres.json)" };
    /// Environment maps (`.exr`, `.hdr`): 2 GiB, a 16384 × 8192 map (the largest the loader takes) as
    /// uncompressed f32 RGBA.
    pub const ENVIRONMENT: Limit = Limit { bytes: 2 * GIB, what: "environment maps (.exr, .hdr)" };
    /// Material-map PNGs: 256 MiB.
    pub const IMAGE: Limit = Limit { bytes: 256 * MIB, what: "material-map images (.png)" };
}

impl std::fmt::Display for Limit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = self.bytes;
        if b >= GIB && b.is_multiple_of(GIB) {
            write!(f, "{} GiB", b / GIB)
        } else if b >= MIB && b.is_multiple_of(MIB) {
            write!(f, "{} MiB", b / MIB)
        } else {
            write!(f, "{b} bytes")
        }
    }
}

/// Why an input file was not read. The message always starts with the file.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("{path}: {message}")]
    Refused { path: PathBuf, message: String },
}

impl InputError {
    fn refused(path: &Path, message: impl Into<String>) -> Self {
        InputError::Refused { path: path.to_path_buf(), message: message.into() }
    }

    pub(crate) fn io(path: &Path, e: std::io::Error) -> Self {
        match e.kind() {
            std::io::ErrorKind::NotFound => InputError::NotFound { path: path.to_path_buf() },
            _ => Self::refused(path, format!("cannot read: {e}")),
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            InputError::NotFound { path } | InputError::Refused { path, .. } => path,
        }
    }

    /// What is wrong, without the file.
    pub fn message(&self) -> String {
        match self {
            InputError::NotFound { .. } => "file not found".into(),
            InputError::Refused { message, .. } => message.clone(),
        }
    }
}

/// What a file that is not a regular file is, in words (`None`: a regular file).
fn not_regular(t: &std::fs::FileType) -> Option<&'static str> {
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

fn check_metadata(path: &Path, meta: &std::fs::Metadata, limit: Limit) -> Result<(), InputError> {
    if let Some(kind) = not_regular(&meta.file_type()) {
        return Err(InputError::refused(
            path,
            format!("is {kind}, not a regular file (input files must be regular files)"),
        ));
    }
    if meta.len() > limit.bytes {
        return Err(InputError::refused(
            path,
            format!("is {} bytes, more than the {limit} limit for {}", meta.len(), limit.what),
        ));
    }
    Ok(())
}

/// Check that `path` is (or links to) a regular file no larger than `limit`, without opening it. For files a
/// library opens itself.
pub fn check(path: &Path, limit: Limit) -> Result<u64, InputError> {
    let meta = std::fs::metadata(path).map_err(|e| InputError::io(path, e))?;
    check_metadata(path, &meta, limit)?;
    Ok(meta.len())
}

/// Read the whole of `path`, a regular file of at most `limit` bytes (see the crate doc).
pub fn read(path: &Path, limit: Limit) -> Result<Vec<u8>, InputError> {
    check(path, limit)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // A FIFO swapped in after the check would block a plain open until a writer came; O_NONBLOCK returns at
        // once (and means nothing for the regular file expected here). O_NOCTTY: a terminal never becomes ours.
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let file = options.open(path).map_err(|e| InputError::io(path, e))?;
    // The file opened may not be the file checked: check the handle itself.
    let meta = file.metadata().map_err(|e| InputError::io(path, e))?;
    check_metadata(path, &meta, limit)?;
    read_bounded(file, meta.len(), limit).map_err(|m| InputError::refused(path, m))
}

/// Read `path` as UTF-8 text ([`read`], then the encoding checked).
pub fn read_to_string(path: &Path, limit: Limit) -> Result<String, InputError> {
    let bytes = read(path, limit)?;
    String::from_utf8(bytes).map_err(|e| {
        InputError::refused(
            path,
            format!("is not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()),
        )
    })
}

/// Read `reader` to its end, refusing more than `limit.bytes` (`expected`: the length it announced, for the
/// first allocation). The check while reading: a file may grow after its length was checked.
pub fn read_bounded(reader: impl Read, expected: u64, limit: Limit) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::with_capacity(expected.min(limit.bytes) as usize);
    reader.take(limit.bytes.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > limit.bytes {
        return Err(format!(
            "grew past the {limit} limit for {} while being read (it was {expected} bytes when checked)",
            limit.what
        ));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("engine-io-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d.join(name)
    }

    const TINY: Limit = Limit { bytes: 16, what: "test files" };

    #[test]
    fn regular_files_within_the_limit_are_read() {
        let p = temp("ok.txt");
        std::fs::write(&p, b"hello").unwrap();
        assert_eq!(read(&p, TINY).unwrap(), b"hello");
        assert_eq!(read_to_string(&p, TINY).unwrap(), "hello");
        let p = temp("empty.txt");
        std::fs::write(&p, b"").unwrap();
        assert_eq!(read(&p, TINY).unwrap(), b"");
    }

    #[test]
    fn files_over_the_limit_are_refused_before_reading() {
        let p = temp("big.txt");
        std::fs::write(&p, [b'x'; 17]).unwrap();
        let e = read(&p, TINY).unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(e.contains("17 bytes") && e.contains("16 bytes limit for test files"), "{e}");
    }

    #[test]
    fn the_limit_holds_while_reading() {
        // A reader that announces 4 bytes and never ends (a file that grows as it is read).
        let endless = std::io::repeat(b'z');
        let e = read_bounded(endless, 4, TINY).unwrap_err();
        assert!(e.contains("grew past the 16 bytes limit"), "{e}");
        assert_eq!(read_bounded(&b"0123456789abcdef"[..], 16, TINY).unwrap().len(), 16);
    }

    #[test]
    fn special_files_are_refused_by_kind() {
        let dir = temp("a-folder");
        std::fs::create_dir_all(&dir).unwrap();
        let e = read(&dir, TINY).unwrap_err().to_string();
        assert!(e.contains("is a folder, not a regular file"), "{e}");
        #[cfg(unix)]
        {
            let e = read(Path::new("/dev/zero"), Limit::MESH).unwrap_err().to_string();
            assert!(e.contains("/dev/zero: is a character device"), "{e}");
            let link = temp("zero-link.obj");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
            let e = read(&link, Limit::MESH).unwrap_err().to_string();
            assert!(e.contains("zero-link.obj: is a character device"), "{e}");
            let a = temp("loop-a.obj");
            let b = temp("loop-b.obj");
            let _ = (std::fs::remove_file(&a), std::fs::remove_file(&b));
            std::os::unix::fs::symlink(&b, &a).unwrap();
            std::os::unix::fs::symlink(&a, &b).unwrap();
            let e = read(&a, TINY).unwrap_err().to_string();
            assert!(e.contains("loop-a.obj: cannot read"), "{e}");
            // A FIFO with no writer: a plain open would wait for one forever.
            let fifo = temp("pipe.obj");
            let _ = std::fs::remove_file(&fifo);
            let made = std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
            assert!(made.success());
            let e = read(&fifo, TINY).unwrap_err().to_string();
            assert!(e.contains("pipe.obj: is a FIFO (named pipe), not a regular file"), "{e}");
        }
        let e = read(Path::new("/nonexistent/x.obj"), TINY).unwrap_err();
        assert!(matches!(e, InputError::NotFound { .. }), "{e}");
    }

    #[test]
    fn limits_print_in_binary_units() {
        assert_eq!(Limit::MESH.to_string(), "1 GiB");
        assert_eq!(Limit::SCENE.to_string(), "16 MiB");
        assert_eq!(TINY.to_string(), "16 bytes");
    }
}
