//! Atomic file output: a reader never sees a half-written image, and a failed write leaves
//! neither an output file nor a temporary one behind.

use std::fs::File;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to a temporary file in `path`'s directory, flushes it to disk, then
/// renames it over `path`. On any error the temporary file is removed and `path` is left
/// as it was. Errors are the plain OS errors (the caller names `path`).
///
/// The temporary file is `tempfile`'s (`.NAME.XXXXXX.lumen.tmp`: hidden, named after the
/// target so a file left by a killed process says where it came from, random so that
/// concurrent writes never collide), removed on drop unless persisted. It is opened by
/// [`tempfile::Builder::make_in`] with the ordinary `create_new` options rather than
/// `tempfile_in`, for two reasons: the image gets the usual permissions (umask) instead
/// of 0600, and errors stay plain (`tempfile_in` appends the temporary path to them).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("note.txt");
/// lumen::image::write_atomically(&path, b"hello").unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"hello");
/// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
/// ```
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".lumen.tmp")
        .make_in(dir, |p| File::options().write(true).create_new(true).open(p))?;
    tmp.as_file_mut().write_all(bytes)?;
    tmp.as_file().sync_all()?;
    // On failure the returned file is dropped, which removes it.
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::ErrorKind;

    #[test]
    fn replaces_and_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        std::fs::write(&path, b"old").unwrap();
        write_atomically(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        // Renaming onto a directory fails: the directory stays, no temporary file remains.
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        std::fs::write(sub.join("x"), b"x").unwrap();
        let e = write_atomically(&sub, b"data").unwrap_err();
        assert!(!e.to_string().contains(".tmp"), "{e}");
        assert!(sub.is_dir());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // A missing directory is reported as the OS reports it.
        let e = write_atomically(&dir.path().join("none/a.bin"), b"x").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NotFound);
    }
}
