//! Reading a file whole, only where it is a regular file.
//!
//! Images, meshes and the pipeline cache are read in one piece. A FIFO, a device or a
//! socket under such a name would hang the read (a FIFO without a writer) or never end it
//! (`/dev/zero`, read until memory runs out): those are refused with a clear error before
//! anything is read. (Scripts may come from pipes, `lumen render <(...)`: SceneLang reads
//! them with a size limit instead, `scenelang::MAX_SCRIPT_BYTES`.)

use std::io::{Error, ErrorKind};
use std::path::Path;

/// The whole contents of the regular file at `path` (symbolic links followed); an
/// `InvalidInput` error for anything else that exists there.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("a.bin");
/// std::fs::write(&path, b"bytes").unwrap();
/// assert_eq!(lumen::regular_file::read(&path).unwrap(), b"bytes");
/// assert!(lumen::regular_file::read(dir.path()).is_err()); // a directory
/// # #[cfg(unix)]
/// # {
/// let e = lumen::regular_file::read(std::path::Path::new("/dev/zero")).unwrap_err();
/// assert!(e.to_string().contains("not a regular file"));
/// # }
/// ```
pub fn read(path: &Path) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(Error::new(ErrorKind::IsADirectory, "it is a directory"));
    }
    refuse_special(meta.file_type())?;
    std::fs::read(path)
}

/// The error for a FIFO, device or socket (`InvalidInput`); regular files, directories and
/// symbolic links pass (callers that follow links ask about what they point at). Reading
/// here and writing in `image::write_atomically` refuse the same kinds in the same words.
pub(crate) fn refuse_special(ty: std::fs::FileType) -> std::io::Result<()> {
    if ty.is_file() || ty.is_dir() || ty.is_symlink() {
        return Ok(());
    }
    Err(Error::new(ErrorKind::InvalidInput, "it is not a regular file (a FIFO, device or socket)"))
}
