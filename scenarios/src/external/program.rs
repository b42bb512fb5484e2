//! Runs an outside estimator's program: its argv in its `{out}` folder, stdin empty, stdout and
//! stderr into one log file, in a process group of its own that is killed whole when the time
//! limit passes (a script's children die with it). The wall clock is read only to enforce the
//! limit and to report the time taken; nothing the run produces depends on it.

use std::fs::File;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use wait_timeout::ChildExt;

/// How the program ended.
#[derive(Clone, Debug, PartialEq)]
pub enum ProgramEnd {
    /// It exited with this status.
    Exited(i32),
    /// A signal ended it (a crash: SIGSEGV, SIGABRT …).
    Signalled(i32),
    /// It ran past the time limit and was killed.
    TimedOut,
    /// It could not be started.
    NotStarted(String),
}

impl ProgramEnd {
    /// Whether it exited with status 0.
    pub fn succeeded(&self) -> bool {
        *self == ProgramEnd::Exited(0)
    }

    /// In words: `exited with status 0`, `was killed by signal 11 (SIGSEGV)` …
    pub fn describe(&self, limit_s: f64) -> String {
        match self {
            ProgramEnd::Exited(c) => format!("exited with status {c}"),
            ProgramEnd::Signalled(s) => format!("was killed by signal {s}{}", signal_name(*s)),
            ProgramEnd::TimedOut => {
                format!("ran past its time limit of {limit_s} s and was killed")
            }
            ProgramEnd::NotStarted(e) => format!("could not be started: {e}"),
        }
    }
}

/// ` (SIGSEGV)` for the signals a crash or a kill gives, else nothing.
fn signal_name(s: i32) -> &'static str {
    match s {
        libc::SIGSEGV => " (SIGSEGV)",
        libc::SIGABRT => " (SIGABRT)",
        libc::SIGBUS => " (SIGBUS)",
        libc::SIGFPE => " (SIGFPE)",
        libc::SIGILL => " (SIGILL)",
        libc::SIGKILL => " (SIGKILL)",
        libc::SIGTERM => " (SIGTERM)",
        _ => "",
    }
}

/// A finished program.
#[derive(Clone, Debug)]
pub struct ProgramRun {
    /// How it ended.
    pub end: ProgramEnd,
    /// Wall time it took (s; for the report only).
    pub wall_s: f64,
}

/// Runs `argv` in `cwd` with its output in `log`, for at most `limit`.
pub fn run_program(argv: &[String], cwd: &Path, log: &Path, limit: Duration) -> ProgramRun {
    let started = Instant::now();
    let done = |end| ProgramRun {
        end,
        wall_s: started.elapsed().as_secs_f64(),
    };
    let (program, args) = match argv.split_first() {
        Some(split) => split,
        None => return done(ProgramEnd::NotStarted("an empty command".into())),
    };
    let out = match File::create(log) {
        Ok(f) => f,
        Err(e) => {
            return done(ProgramEnd::NotStarted(format!(
                "cannot write its log {}: {e}",
                log.display()
            )));
        }
    };
    let err = match out.try_clone() {
        Ok(f) => f,
        Err(e) => return done(ProgramEnd::NotStarted(format!("cannot share its log: {e}"))),
    };
    let spawned = Command::new(program)
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .process_group(0)
        .spawn();
    let mut child = match spawned {
        Ok(c) => c,
        Err(e) => return done(ProgramEnd::NotStarted(format!("`{program}`: {e}"))),
    };
    let pgid = child.id() as libc::pid_t;
    let status = child.wait_timeout(limit);
    let end = match status {
        Ok(Some(s)) => match (s.code(), s.signal()) {
            (Some(c), _) => ProgramEnd::Exited(c),
            (None, Some(sig)) => ProgramEnd::Signalled(sig),
            (None, None) => ProgramEnd::Signalled(0),
        },
        Ok(None) => {
            kill_group(pgid);
            let _ = child.wait();
            ProgramEnd::TimedOut
        }
        Err(e) => {
            kill_group(pgid);
            let _ = child.wait();
            ProgramEnd::NotStarted(format!("waiting for it failed: {e}"))
        }
    };
    done(end)
}

/// Kills the process group `pgid` (the program and every child it started).
fn kill_group(pgid: libc::pid_t) {
    // SAFETY: kill(2) with a negative pid signals the process group; it has no memory effects.
    unsafe {
        libc::kill(-pgid, libc::SIGKILL);
    }
}

/// The last `max` bytes of `log` (from a line start when one is near), for a report.
pub fn log_tail(log: &Path, max: usize) -> String {
    let Ok(bytes) = std::fs::read(log) else {
        return String::new();
    };
    let start = bytes.len().saturating_sub(max);
    let tail = String::from_utf8_lossy(&bytes[start..]).into_owned();
    match (start > 0, tail.find('\n')) {
        (true, Some(i)) if i + 1 < tail.len() => tail[i + 1..].to_string(),
        _ => tail,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(script: &str, limit_s: f64) -> (ProgramRun, String) {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("log.txt");
        let argv = ["sh", "-c", script].map(String::from);
        let run = run_program(&argv, dir.path(), &log, Duration::from_secs_f64(limit_s));
        (run, std::fs::read_to_string(&log).unwrap_or_default())
    }

    #[test]
    fn a_program_exits_crashes_or_is_killed_past_its_limit() {
        let (r, log) = sh("echo out; echo err >&2; exit 3", 30.0);
        assert_eq!(r.end, ProgramEnd::Exited(3));
        assert_eq!(log, "out\nerr\n");
        let (r, _) = sh("kill -SEGV $$", 30.0);
        assert_eq!(r.end, ProgramEnd::Signalled(libc::SIGSEGV));
        assert!(r.end.describe(1.0).contains("SIGSEGV"));
        // A child of the program holds the log open: the whole group dies at the limit.
        let (r, _) = sh("sleep 30 & sleep 30", 0.3);
        assert_eq!(r.end, ProgramEnd::TimedOut);
        assert!(r.wall_s < 10.0, "{}", r.wall_s);
        let dir = tempfile::tempdir().unwrap();
        let r = run_program(
            &["/no/such/program".to_string()],
            dir.path(),
            &dir.path().join("log"),
            Duration::from_secs(5),
        );
        assert!(matches!(r.end, ProgramEnd::NotStarted(_)), "{:?}", r.end);
    }

    #[test]
    fn a_log_tail_starts_at_a_line() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("log");
        std::fs::write(&log, "aaaa\nbbbb\ncccc\n").unwrap();
        assert_eq!(log_tail(&log, 8), "cccc\n");
        assert_eq!(log_tail(&log, 100), "aaaa\nbbbb\ncccc\n");
    }
}
