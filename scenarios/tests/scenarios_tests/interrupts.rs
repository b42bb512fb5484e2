//! Ctrl-C and SIGTERM: `vio run`, `regress`, `nees` and `bench` stop with exit 130 and write
//! what finished.

use crate::common;

use std::path::PathBuf;

use common::scratch;

/// Starts `vio args` (stderr piped), sends it Ctrl-C (SIGINT) once `ready` says so of what it
/// has printed to stderr so far, and returns its exit code and stderr.
fn ctrl_c(args: &[&str], ready: impl Fn(&str) -> bool) -> (Option<i32>, String) {
    signal(args, "-INT", ready)
}

/// [`ctrl_c`] with another signal (`-TERM`, …).
fn signal(args: &[&str], which: &str, ready: impl Fn(&str) -> bool) -> (Option<i32>, String) {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = stderr.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let mut text = String::new();
    let started = std::time::Instant::now();
    while !ready(&text) {
        assert!(
            started.elapsed().as_secs() < 300,
            "{args:?}: not ready: {text}"
        );
        if let Ok(b) = rx.recv_timeout(std::time::Duration::from_millis(50)) {
            text.push_str(&String::from_utf8_lossy(&b));
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "{args:?} ended before Ctrl-C: {text}"
        );
    }
    let kill = std::process::Command::new("kill")
        .args([which, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let code = child.wait().unwrap().code();
    while let Ok(b) = rx.recv_timeout(std::time::Duration::from_secs(5)) {
        text.push_str(&String::from_utf8_lossy(&b));
    }
    (code, text)
}

/// SIGTERM (a scheduler's or `kill`'s) stops `vio run` as Ctrl-C does: exit 130 with the
/// files of what finished written, where it used to end the process with nothing written.
#[test]
fn sigterm_stops_a_run_like_ctrl_c_and_writes_what_finished() {
    let dir = scratch("run-sigterm");
    let out = dir.path().join("run");
    let (code, err) = signal(
        &["run", "--duration", "60", "--out", out.to_str().unwrap()],
        "-TERM",
        |e| e.contains("% of its time"),
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(report.contains("\"resets\""), "{report}");
    assert!(out.join("estimate.tum").exists());
}

#[test]
fn ctrl_c_stops_regress_nees_and_bench_with_130_saying_what_finished() {
    // regress: once its first scenario is under way; the baseline is not touched.
    let catalog = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("regress");
    let baseline = std::fs::read(catalog.join("baseline.json")).unwrap();
    let (code, err) = ctrl_c(&["regress", "--catalog", catalog.to_str().unwrap()], |e| {
        e.contains("running")
    });
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted after"), "{err}");
    assert_eq!(
        std::fs::read(catalog.join("baseline.json")).unwrap(),
        baseline
    );
    // nees: a second after it starts (no seed may have finished: then nothing is written).
    let dir = scratch("nees-ctrl-c");
    let out = dir.path().join("nees");
    let started = std::time::Instant::now();
    let (code, err) = ctrl_c(
        &[
            "nees",
            "--seeds",
            "6",
            "--duration",
            "4",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
        |_| started.elapsed().as_secs_f64() > 1.0,
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("vio nees: interrupted"), "{err}");
    // bench: during its first scenario (a child process; a terminal's Ctrl-C reaches it too,
    // here only the parent is told): the table and bench.json hold what finished.
    let out = dir.path().join("bench");
    let (code, err) = ctrl_c(&["bench", "--quick", "--out", out.to_str().unwrap()], |e| {
        e.contains("bench ")
    });
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("vio bench: interrupted after"), "{err}");
    let json = std::fs::read_to_string(out.join("bench.json")).unwrap();
    assert!(json.contains("\"rows\""), "{json}");
}
