//! What both renderers share about stopping a progressive render early: why it stopped,
//! and the process-wide Ctrl-C flag. Both render in rounds (one sample range over every
//! pixel), check a time limit between rounds and drop an unfinished round on Ctrl-C, so
//! every pixel of a result has the same number of samples.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// Why a progressive render returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StopReason {
    /// All requested samples were taken.
    #[default]
    Completed,
    /// The time limit passed; fewer samples than requested.
    TimeLimit,
    /// The cancel flag was set; the unfinished round was dropped.
    Interrupted,
}

/// A flag set by Ctrl-C, for a render's cancel option. The first Ctrl-C asks the render to
/// stop soon (keeping the completed rounds); a second one exits at once. The handler is
/// installed once per process; later calls return the same flag.
pub fn ctrlc_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = Arc::clone(&flag);
        let installed = ctrlc::set_handler(move || {
            if f.swap(true, Ordering::SeqCst) {
                forced_exit("\ninterrupted twice: exiting", 130);
            }
            crate::diag!("\ninterrupted: keeping the completed rounds (Ctrl-C again to quit now)");
        });
        if let Err(e) = installed {
            crate::diag!("warning: cannot install the Ctrl-C handler ({e}); Ctrl-C will not save partial renders");
        }
        flag
    })
    .clone()
}

/// Ends the process at once with `status`, leaving nothing behind but whole outputs: the
/// writes in progress are abandoned (their temporary files removed, and none starts or
/// finishes meanwhile) and the directories of [`remove_at_forced_exit`] removed, since
/// `exit` runs no destructors.
fn forced_exit(message: &str, status: i32) -> ! {
    let _held = crate::image::abandon_writes();
    for dir in forced_exit_removals().drain(..) {
        let _ = std::fs::remove_dir_all(dir);
    }
    crate::diag!("{message}");
    std::process::exit(status);
}

/// Makes SIGTERM and SIGHUP (a scheduler's or a closed terminal's request to end) end the
/// process as a second Ctrl-C does, with the status a shell reports for the signal
/// (128 + its number), instead of by the signal's default action, which left a write's
/// temporary file and the private runtime directory behind. Unlike Ctrl-C they do not
/// keep the completed rounds: a job ended this way is ended. Starts a thread: call it once
/// the process may have threads (`cli::main`, after its environment changes).
///
/// A signal the process inherited as ignored stays ignored: `nohup` ignores SIGHUP so that
/// a render outlives its terminal.
#[cfg(unix)]
pub fn exit_cleanly_on_termination() {
    use signal_hook::consts::{SIGHUP, SIGTERM};
    let ignored = |signal: libc::c_int| {
        // SAFETY: sigaction with a null new action only reads the current disposition.
        let mut old: libc::sigaction = unsafe { std::mem::zeroed() };
        unsafe { libc::sigaction(signal, std::ptr::null(), &mut old) == 0 && old.sa_sigaction == libc::SIG_IGN }
    };
    let signals: Vec<libc::c_int> = [SIGTERM, SIGHUP].into_iter().filter(|&s| !ignored(s)).collect();
    if signals.is_empty() {
        return;
    }
    match signal_hook::iterator::Signals::new(signals) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    let name = if signal == SIGTERM { "SIGTERM" } else { "SIGHUP" };
                    forced_exit(&format!("\n{name}: exiting"), 128 + signal);
                }
            });
        }
        Err(e) => crate::diag!("warning: cannot handle SIGTERM and SIGHUP ({e}); they will end lumen untidily"),
    }
}

fn forced_exit_removals() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    static DIRS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    DIRS.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Asks for directory `dir` to be removed (with its contents) should a second Ctrl-C or a
/// termination signal end the process, which skips destructors: for what the process made
/// for itself and removes on a normal exit (the private `XDG_RUNTIME_DIR` of
/// `cli::headless`).
pub fn remove_at_forced_exit(dir: PathBuf) {
    forced_exit_removals().push(dir);
}
