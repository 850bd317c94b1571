//! Atomic file output: a reader never sees a half-written image, and a failed write leaves
//! neither an output file nor a temporary one behind.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The temporary files of the process's writes in progress, for [`abandon_writes`].
static WRITES: Writes = Writes(Mutex::new(Vec::new()));

/// A register of temporary files. A write holds its lock only while it creates and
/// registers its file, and while it renames and unregisters it, so whoever holds the lock
/// sees every temporary file there is, and no write starts or ends meanwhile.
struct Writes(Mutex<Vec<PathBuf>>);

impl Writes {
    fn lock(&self) -> MutexGuard<'_, Vec<PathBuf>> {
        // Each change under the lock is one push or one removal: a panic cannot leave the
        // list half-changed.
        self.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn write(&self, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        self.produce(path, |tmp, _| tmp.write_all(bytes))
    }

    /// A new temporary file for a write to `path`, registered.
    fn register(&self, path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
        refuse_special_file(path)?;
        let mut pending = self.lock();
        let tmp = temporary_file_for(path)?;
        pending.push(tmp.path().to_path_buf());
        Ok(tmp)
    }

    /// Unregisters `temps`, returning the lock: while it is held, no exit can abandon them,
    /// so they are renamed (or, dropped, removed) before one does.
    fn unregister<'a>(
        &self,
        temps: impl IntoIterator<Item = &'a tempfile::NamedTempFile>,
    ) -> MutexGuard<'_, Vec<PathBuf>> {
        let mut pending = self.lock();
        for tmp in temps {
            if let Some(i) = pending.iter().position(|p| p == tmp.path()) {
                pending.swap_remove(i);
            }
        }
        pending
    }

    /// [`produce_atomically`] in this register.
    fn produce(&self, path: &Path, make: impl FnOnce(&mut File, &Path) -> std::io::Result<()>) -> std::io::Result<()> {
        let mut tmp = self.register(path)?;
        let tmp_path = tmp.path().to_path_buf();
        let written = make(tmp.as_file_mut(), &tmp_path).and_then(|()| tmp.as_file().sync_all());
        let _held = self.unregister([&tmp]);
        // On failure the temporary file is dropped, which removes it.
        written?;
        tmp.persist(path).map_err(|e| e.error)?;
        Ok(())
    }

    /// [`write_set_atomically`] in this register.
    fn write_set(&self, files: &[(PathBuf, Vec<u8>)]) -> Result<(), SetWriteError> {
        let mut temps = Vec::with_capacity(files.len());
        let mut failure = None;
        for (path, bytes) in files {
            let written = self.register(path).and_then(|mut tmp| {
                let written = tmp.write_all(bytes).and_then(|()| tmp.as_file().sync_all());
                temps.push(tmp);
                written
            });
            if let Err(cause) = written {
                failure = Some(SetWriteError { path: path.clone(), cause, renamed: Vec::new() });
                break;
            }
        }
        let _held = self.unregister(&temps);
        if let Some(failure) = failure {
            // Dropped (under the lock, as no exit then finds them unregistered), the
            // temporary files are removed.
            drop(temps);
            return Err(failure);
        }
        let mut renamed = Vec::with_capacity(files.len());
        for (tmp, (path, _)) in temps.into_iter().zip(files) {
            if let Err(e) = tmp.persist(path) {
                return Err(SetWriteError { path: path.clone(), cause: e.error, renamed });
            }
            renamed.push(path.clone());
        }
        Ok(())
    }

    /// Creates the temporary file a write to `path` would make, and removes it: whether the
    /// directory takes new files. Under the lock, so an exit that abandons the writes in
    /// progress never finds the probe half done.
    fn probe(&self, path: &Path) -> std::io::Result<()> {
        let _held = self.lock();
        // Dropping the file removes it.
        temporary_file_for(path).map(drop)
    }

    fn abandon(&self) -> MutexGuard<'_, Vec<PathBuf>> {
        let mut pending = self.lock();
        for path in pending.drain(..) {
            let _ = std::fs::remove_file(path);
        }
        pending
    }
}

/// Writes `bytes` to a temporary file in `path`'s directory, flushes it to disk, then
/// renames it over `path`. On any error the temporary file is removed and `path` is left
/// as it was. Errors are the plain OS errors (the caller names `path`).
///
/// Where `path` is a symbolic link, the link is replaced by the new file and the file it
/// named is left as it was (as `sed -i` does): following it would write wherever the link
/// points, which in a shared directory is someone else's choice. A FIFO, device or socket
/// at `path` is refused (`InvalidInput`) rather than replaced by a regular file.
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
    WRITES.write(path, bytes)
}

/// [`write_atomically`] for content that `make` produces into the temporary file, by any
/// means: through the open file it is given, or through the file's path (for another
/// program to write, as `cli::render`'s video assembly has ffmpeg do). An error from
/// `make` removes the temporary file and leaves `path` as it was.
///
/// ```
/// use std::io::Write;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("a.txt");
/// lumen::image::produce_atomically(&path, |f, _| f.write_all(b"made")).unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"made");
/// let b = dir.path().join("b.txt");
/// let failed = lumen::image::produce_atomically(&b, |_, tmp| {
///     std::fs::write(tmp, b"half")?;
///     Err(std::io::Error::other("the producer failed"))
/// });
/// assert!(failed.is_err());
/// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
/// ```
pub fn produce_atomically(
    path: &Path,
    make: impl FnOnce(&mut File, &Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    WRITES.produce(path, make)
}

/// Why [`write_set_atomically`] failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {cause}", path.display())]
pub struct SetWriteError {
    /// The file whose write (or rename) failed.
    pub path: PathBuf,
    /// The OS error.
    pub cause: std::io::Error,
    /// The files of the set renamed into place before the failure: none unless a rename
    /// failed.
    pub renamed: Vec<PathBuf>,
}

/// [`write_atomically`] for several files, written whole or, where that can be had, not at
/// all: each goes to a temporary file beside its target, and the first rename comes only
/// once every one is written and flushed, so a full disk (the likely failure) replaces
/// nothing. Only a failing rename leaves the files renamed before it
/// ([`SetWriteError::renamed`]).
///
/// ```
/// use std::path::PathBuf;
/// let dir = tempfile::tempdir().unwrap();
/// let (a, b) = (dir.path().join("a.csv"), dir.path().join("missing/b.md"));
/// let err = lumen::image::write_set_atomically(&[(a.clone(), b"1".to_vec()), (b.clone(), b"2".to_vec())]).unwrap_err();
/// assert_eq!((err.path, err.renamed), (b, Vec::<PathBuf>::new()));
/// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
/// lumen::image::write_set_atomically(&[(a.clone(), b"1".to_vec())]).unwrap();
/// assert_eq!(std::fs::read(&a).unwrap(), b"1");
/// ```
pub fn write_set_atomically(files: &[(PathBuf, Vec<u8>)]) -> Result<(), SetWriteError> {
    WRITES.write_set(files)
}

/// Held by [`abandon_writes`]: while it lives, no [`write_atomically`] starts or finishes.
#[must_use = "writes resume when the guard is dropped"]
pub struct WritesAbandoned {
    _held: MutexGuard<'static, Vec<PathBuf>>,
}

/// Removes the temporary files of the [`write_atomically`] calls in progress and keeps any
/// write from starting or finishing while the returned guard lives: for an exit that skips
/// destructors (a second Ctrl-C), which would otherwise leave a writer's temporary file
/// behind. Every output is then either whole or absent.
///
/// ```no_run
/// let _held = lumen::image::abandon_writes();
/// std::process::exit(130);
/// ```
pub fn abandon_writes() -> WritesAbandoned {
    WritesAbandoned { _held: WRITES.abandon() }
}

/// Checks what can be checked of a later [`write_atomically`] to `path` before the work
/// that produces it: its directory exists, `path` is not a directory or a special file and
/// its name is not too long, and the directory takes a new file (the write's temporary
/// file is created there and removed at once: permissions, a read-only file system).
/// Commands call it before long work (a render, a benchmark), so that an output that
/// cannot be written fails at once rather than after hours; a full disk still shows only
/// at the write.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// assert!(lumen::image::check_destination(&dir.path().join("out.png")).is_ok());
/// assert!(lumen::image::check_destination(&dir.path().join("missing/out.png")).is_err());
/// assert!(lumen::image::check_destination(dir.path()).is_err());
/// ```
pub fn check_destination(path: &Path) -> std::io::Result<()> {
    use std::io::{Error, ErrorKind};
    // "out.png/" names a directory (a `Path` drops the separator from its file name, and
    // the write's rename would then fail with "Not a directory", after the work).
    if path.as_os_str().as_encoded_bytes().last().is_some_and(|&b| std::path::is_separator(b as char)) {
        return Err(Error::new(ErrorKind::NotADirectory, "it ends with a path separator, so it names a directory"));
    }
    let dir = directory_of(path);
    if !dir.is_dir() {
        return Err(if dir.exists() {
            Error::new(ErrorKind::NotADirectory, format!("{} is not a directory", dir.display()))
        } else {
            Error::new(ErrorKind::NotFound, format!("directory {} does not exist", dir.display()))
        });
    }
    if path.is_dir() {
        return Err(Error::new(ErrorKind::IsADirectory, "it is a directory"));
    }
    refuse_special_file(path)?;
    WRITES.probe(path)
}

/// A new temporary file beside `path`, named after it (`.NAME.XXXXXX.lumen.tmp`: see
/// [`write_atomically`]); removed when dropped unless persisted.
fn temporary_file_for(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    tempfile::Builder::new()
        .prefix(&format!(".{}.", name_start(&name)))
        .suffix(".lumen.tmp")
        .make_in(directory_of(path), |p| File::options().write(true).create_new(true).open(p))
}

/// An error where `path` is a FIFO, a device or a socket (not followed through a symbolic
/// link: the link is what a write replaces), or cannot be looked up for a reason other
/// than not existing yet: a name longer than the file system takes ("File name too
/// long") fails here, before a render, rather than at its write.
fn refuse_special_file(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) => crate::regular_file::refuse_special(meta.file_type()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Most bytes of the target's name a temporary file's name repeats: the temporary name adds
/// 18 bytes to it (`.`, `.`, six random characters, `.lumen.tmp`), and a target name within
/// the file system's limit (255 bytes on most, 143 on eCryptfs) must not make a temporary
/// name beyond it (a 250-byte name failed with "File name too long" after the render).
const TMP_NAME_BYTES: usize = 100;

/// The start of `name` that a temporary file's name repeats: at most [`TMP_NAME_BYTES`]
/// bytes, cut at a character boundary.
fn name_start(name: &str) -> &str {
    let mut end = name.len().min(TMP_NAME_BYTES);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    &name[..end]
}

/// The directory a file at `path` goes in (`.` for a bare name).
fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::ErrorKind;

    /// A set whose last file cannot be written replaces none of the others, and leaves no
    /// temporary file; a set that can be written is written whole.
    #[test]
    fn a_set_is_written_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let names = |dir: &Path| {
            let mut v: Vec<String> =
                std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
            v.sort();
            v
        };
        let old = dir.path().join("a.csv");
        std::fs::write(&old, b"old").unwrap();
        let set = |last: PathBuf| {
            vec![(old.clone(), b"new".to_vec()), (dir.path().join("b.md"), b"b".to_vec()), (last, b"c".to_vec())]
        };
        let missing = dir.path().join("none/c.png");
        let e = write_set_atomically(&set(missing.clone())).unwrap_err();
        assert_eq!((e.path, e.cause.kind(), e.renamed), (missing, ErrorKind::NotFound, vec![]));
        assert_eq!(names(dir.path()), ["a.csv"]);
        assert_eq!(std::fs::read(&old).unwrap(), b"old");
        write_set_atomically(&set(dir.path().join("c.png"))).unwrap();
        assert_eq!(names(dir.path()), ["a.csv", "b.md", "c.png"]);
        assert_eq!(std::fs::read(&old).unwrap(), b"new");
    }
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

    /// A write in progress when the process exits at once (the guard of `abandon` held)
    /// leaves nothing: its temporary file is removed and it cannot rename it after. A
    /// register of the test's own, so that other tests' writes in this process go on.
    #[test]
    fn abandoned_writes_leave_no_temporary_file() {
        let writes = Writes(Mutex::new(Vec::new()));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.bin");
        let bytes = vec![7u8; 16 << 20];
        let files = || -> Vec<String> {
            std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect()
        };
        let mut caught = false;
        for _ in 0..20 {
            if caught {
                break;
            }
            let _ = std::fs::remove_file(&path);
            std::thread::scope(|s| {
                let writer = s.spawn(|| writes.write(&path, &bytes));
                // Abandon the write once its temporary file exists (or it has finished).
                let held = loop {
                    let started = !writes.lock().is_empty();
                    if started || writer.is_finished() {
                        break writes.abandon();
                    }
                    std::thread::yield_now();
                };
                // Here the process would exit; the writer cannot finish meanwhile.
                std::thread::sleep(std::time::Duration::from_millis(20));
                let now = files();
                assert!(now.is_empty() || now == ["big.bin"], "{now:?}");
                caught |= now.is_empty();
                drop(held);
                // Let go, the writer's rename of its removed file fails, and nothing is left.
                let result = writer.join().unwrap();
                assert_eq!(result.is_ok(), path.exists(), "{result:?}");
                if let Ok(b) = std::fs::read(&path) {
                    assert_eq!(b.len(), bytes.len());
                }
            });
            assert!(writes.lock().is_empty());
            assert!(files().iter().all(|n| n == "big.bin"), "{:?}", files());
        }
        assert!(caught, "no write was caught in progress in 20 tries");
    }

    /// What `check_destination` refuses is what `write_atomically` would fail on, and it
    /// accepts what it would write.
    #[test]
    fn destinations_are_checked_as_the_write_would_find_them() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let cases = [
            (dir.path().join("new.png"), Ok(())),
            (file.clone(), Ok(())),
            (dir.path().join("none/a.png"), Err("does not exist")),
            (file.join("a.png"), Err("is not a directory")),
            (dir.path().to_path_buf(), Err("it is a directory")),
            (dir.path().join("new.png/"), Err("ends with a path separator")),
        ];
        for (path, want) in cases {
            let checked = check_destination(&path);
            match want {
                Ok(()) => {
                    assert!(checked.is_ok(), "{}: {checked:?}", path.display());
                    write_atomically(&path, b"y").unwrap();
                }
                Err(why) => {
                    let e = checked.unwrap_err();
                    assert!(e.to_string().contains(why), "{}: {e}", path.display());
                    assert!(write_atomically(&path, b"y").is_err(), "{}", path.display());
                }
            }
        }
        // A bare file name goes in the working directory, which exists.
        assert!(check_destination(Path::new("out.png")).is_ok());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "the probes leave nothing (file, new.png)");
    }

    /// A directory that takes no new file is refused before the work, even for root, whom
    /// permission bits do not stop: sysfs refuses new files to everyone (permission
    /// denied), procfs has no such entry.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_directory_that_takes_no_new_file_is_refused_before_the_work() {
        for path in ["/sys/lumen-probe.png", "/proc/lumen-probe.png"] {
            let path = Path::new(path);
            if !path.parent().unwrap().is_dir() {
                continue;
            }
            let e = check_destination(path).unwrap_err();
            assert!(matches!(e.kind(), ErrorKind::PermissionDenied | ErrorKind::NotFound), "{}: {e}", path.display());
            assert!(write_atomically(path, b"x").is_err());
        }
        let dir = tempfile::tempdir().unwrap();
        let ro = dir.path().join("ro");
        std::fs::create_dir(&ro).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
            // Root writes there anyway; others are refused at once, as the write would be.
            let (checked, written) = (check_destination(&ro.join("a.png")), write_atomically(&ro.join("a.png"), b"x"));
            assert_eq!(checked.is_ok(), written.is_ok(), "{checked:?} {written:?}");
        }
    }

    /// A file name as long as the file system takes (255 bytes here) is written, though its
    /// temporary file's name could not repeat it whole; one byte more is refused before the
    /// write by `check_destination`, as the write would refuse it.
    #[test]
    fn names_up_to_the_file_systems_limit_are_written() {
        let dir = tempfile::tempdir().unwrap();
        for name in [format!("{}.png", "a".repeat(251)), format!("{}a.pfm", "é".repeat(125))] {
            assert_eq!(name.len(), 255);
            let path = dir.path().join(&name);
            check_destination(&path).unwrap();
            write_atomically(&path, b"image").unwrap();
            assert_eq!(std::fs::read(&path).unwrap(), b"image");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "no temporary file is left");
        let too_long = dir.path().join(format!("{}.png", "b".repeat(252)));
        let e = check_destination(&too_long).unwrap_err();
        assert!(e.to_string().contains("too long"), "{e}");
        assert!(write_atomically(&too_long, b"x").is_err());
        assert_eq!(name_start("é".repeat(60).as_str()).len(), 100);
        assert_eq!(name_start("éa".repeat(40).as_str()).len(), 99, "cut before a split character");
    }

    /// A symbolic link is replaced by the new file (its old target stays as it was), a
    /// dangling one too; a FIFO is refused before and at the write, and stays a FIFO.
    #[cfg(unix)]
    #[test]
    fn links_are_replaced_and_special_files_refused() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.png");
        std::fs::write(&target, b"old").unwrap();
        for (link, to) in [("link.png", target.as_path()), ("dangling.png", Path::new("missing.png"))] {
            let link = dir.path().join(link);
            std::os::unix::fs::symlink(to, &link).unwrap();
            check_destination(&link).unwrap();
            write_atomically(&link, b"new").unwrap();
            assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_file());
            assert_eq!(std::fs::read(&link).unwrap(), b"new");
        }
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert!(!dir.path().join("missing.png").exists());
        let fifo = dir.path().join("fifo.png");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
        for e in [check_destination(&fifo).unwrap_err(), write_atomically(&fifo, b"x").unwrap_err()] {
            assert_eq!(e.kind(), ErrorKind::InvalidInput);
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        assert!(!std::fs::symlink_metadata(&fifo).unwrap().file_type().is_file());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4);
    }
}
