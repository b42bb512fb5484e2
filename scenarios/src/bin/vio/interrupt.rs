//! Ctrl-C for every command that runs for a while: the first sets a flag the work checks (and
//! says what will happen), the second exits at once with 130. SIGTERM (what `kill`, a job
//! scheduler or a container runtime sends) and SIGHUP are handled the same way (`ctrlc`'s
//! `termination` feature), so a stopped run writes what it finished whichever way it is
//! stopped.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set by the first Ctrl-C.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// What the first Ctrl-C prints (the command that installed the handler says it).
static MESSAGE: std::sync::OnceLock<&'static str> = std::sync::OnceLock::new();

/// Installs the handler (once per process) with `message` for the first Ctrl-C; returns the
/// flag it sets.
pub fn on_ctrl_c(message: &'static str) -> &'static AtomicBool {
    if MESSAGE.set(message).is_ok() {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, Ordering::Relaxed) {
                std::process::exit(130);
            }
            eprintln!(
                "\ninterrupted: {} (Ctrl-C again to quit now)",
                MESSAGE.get().copied().unwrap_or("stopping")
            );
        });
    }
    &INTERRUPTED
}

/// Whether Ctrl-C was pressed.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}
