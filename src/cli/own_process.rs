//! Starting this program (or another) again the way this process was started: the
//! relaunch with other driver settings (`software_driver`), `lumen bench --cold-kernels`'
//! runs in fresh processes, and tests that start `lumen`.

use std::ffi::OsString;
use std::path::Path;
use std::process::Command;

/// The dynamic loader and its own arguments, where this process was started through a
/// loader by hand (as `scripts/newer_lavapipe.sh` runs programs, under another system's
/// loader and libraries); `None` where it was started directly. There `current_exe` is the
/// loader, and only /proc/self/cmdline still holds the loader's arguments (the loader
/// hands the program the arguments that follow its own).
pub fn loader_prefix() -> Option<Vec<OsString>> {
    #[cfg(target_os = "linux")]
    {
        let started = command_line(&std::fs::read("/proc/self/cmdline").ok()?);
        let own = std::env::args_os().count();
        if own >= 1 && started.len() > own {
            return Some(started[..started.len() - own].to_vec());
        }
    }
    None
}

/// A command that starts `program` (without arguments of its own) as this process was
/// started: through the same dynamic loader, with its arguments, where there was one.
pub fn through_own_loader(program: &Path) -> Command {
    command_after(loader_prefix(), program)
}

/// A command that starts this program again, without arguments of its own: its file, or,
/// where a loader ran it, [`through_own_loader`] of the file the loader was given (the
/// program's first argument, as the loader hands it over).
pub fn this_program() -> std::io::Result<Command> {
    if let (Some(prefix), Some(file)) = (loader_prefix(), std::env::args_os().next()) {
        return Ok(command_after(Some(prefix), Path::new(&file)));
    }
    Ok(Command::new(std::env::current_exe()?))
}

/// `program` run through the loader command `prefix` (its file, then its arguments), or
/// directly without one.
fn command_after(prefix: Option<Vec<OsString>>, program: &Path) -> Command {
    match prefix {
        Some(prefix) => {
            let mut cmd = Command::new("/proc/self/exe");
            #[cfg(unix)]
            std::os::unix::process::CommandExt::arg0(&mut cmd, &prefix[0]);
            cmd.args(&prefix[1..]).arg(program);
            cmd
        }
        None => Command::new(program),
    }
}

/// The arguments of a /proc/PID/cmdline: NUL-terminated strings (an empty argument is an
/// empty string between two NULs).
#[cfg(target_os = "linux")]
fn command_line(raw: &[u8]) -> Vec<std::ffi::OsString> {
    use std::os::unix::ffi::OsStrExt;
    let body = raw.strip_suffix(&[0]).unwrap_or(raw);
    if body.is_empty() && raw.len() <= 1 {
        return Vec::new();
    }
    body.split(|b| *b == 0).map(|a| std::ffi::OsStr::from_bytes(a).to_os_string()).collect()
}

#[cfg(test)]
mod tests {
    #[cfg(target_os = "linux")]
    #[test]
    fn command_lines_split_at_their_nuls() {
        use super::command_line;
        let args = |raw: &[u8]| command_line(raw).into_iter().map(|a| a.into_string().unwrap()).collect::<Vec<_>>();
        assert_eq!(args(b"lumen\0render\0a b.sl\0"), ["lumen", "render", "a b.sl"]);
        assert_eq!(args(b"lumen\0\0-o\0"), ["lumen", "", "-o"]);
        assert_eq!(args(b"lumen"), ["lumen"]);
        assert!(args(b"").is_empty());
        assert!(args(b"\0").is_empty());
    }

    /// This program is its own file, or where a loader started it (a cargo runner such as
    /// scripts/newer_lavapipe.sh's), the loader's own file with its arguments and then the
    /// program's.
    #[test]
    fn this_program_is_the_running_file() {
        let cmd = super::this_program().unwrap();
        let args: Vec<_> = cmd.get_args().collect();
        match super::loader_prefix() {
            None => {
                let file = std::path::Path::new(cmd.get_program());
                assert_eq!(file.canonicalize().unwrap(), std::env::current_exe().unwrap().canonicalize().unwrap());
                assert!(args.is_empty());
            }
            Some(prefix) => {
                assert_eq!(cmd.get_program(), "/proc/self/exe");
                assert_eq!(args.len(), prefix.len());
                let program = std::path::Path::new(args[args.len() - 1]);
                assert_eq!(
                    program.file_name(),
                    std::env::args_os().next().as_deref().map(std::path::Path::new).and_then(|p| p.file_name())
                );
            }
        }
    }
}
