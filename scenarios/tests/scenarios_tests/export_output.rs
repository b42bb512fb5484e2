//! `vio export`'s output is whole or marked: a second export into a folder another one is
//! writing is refused, an export killed midway (over an older, complete one) leaves a folder
//! `vio euroc` refuses as incomplete, and a bag appears at its path only once complete.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;

use common::{scratch, vio, vio_ok};
use scenarios::dataset::INCOMPLETE_MARKER;
use scenarios::export::out_folder::LOCK_FILE;

#[test]
fn a_second_export_into_a_folder_being_written_is_refused() {
    let dir = scratch("export-lock");
    let out = dir.path().join("asl");
    std::fs::create_dir_all(&out).unwrap();
    // This process holds the folder's lock, as a running export does.
    let lock = std::fs::File::create(out.join(LOCK_FILE)).unwrap();
    lock.lock().unwrap();
    let o = vio(&["export", "--out", out.to_str().unwrap(), "--duration", "1"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("another export is writing into this folder"),
        "{stderr}"
    );
    assert!(!out.join("mav0").exists(), "nothing written");
    // Released (the process that held it ended): the export runs and leaves no marker.
    drop(lock);
    vio_ok(&["export", "--out", out.to_str().unwrap(), "--duration", "1"]);
    assert!(!out.join("mav0").join(INCOMPLETE_MARKER).exists());
    vio_ok(&[
        "euroc",
        out.join("mav0").to_str().unwrap(),
        "--features",
        out.join("features.csv").to_str().unwrap(),
        "--out",
        dir.path().join("run").to_str().unwrap(),
    ]);
}

#[test]
fn an_export_killed_midway_over_an_older_one_leaves_a_folder_vio_euroc_refuses() {
    let dir = scratch("export-killed");
    let out = dir.path().join("asl");
    let out_s = out.to_str().unwrap();
    // An older, complete export: `vio euroc` reads it.
    vio_ok(&["export", "--out", out_s, "--duration", "1"]);
    // A rendered export over it, killed (SIGKILL: no handler runs) once it has started.
    let mut child = Command::new(env!("CARGO_BIN_EXE_vio"))
        .args([
            "export",
            "room_figure8_rendered_stereo_imu",
            "--out",
            out_s,
            "--duration",
            "5",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let marker = out.join("mav0").join(INCOMPLETE_MARKER);
    let started = Instant::now();
    while !marker.exists() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the export never started"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "killed before it finished");
    let o = vio(&[
        "euroc",
        out.join("mav0").to_str().unwrap(),
        "--out",
        dir.path().join("run").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(INCOMPLETE_MARKER), "{stderr}");
    assert!(stderr.contains("did not finish"), "{stderr}");
}

#[test]
fn a_bag_is_at_its_path_only_once_complete() {
    let dir = scratch("export-bag");
    let bag = dir.path().join("run.mcap");
    vio_ok(&[
        "export",
        "--format",
        "mcap",
        "--out",
        bag.to_str().unwrap(),
        "--duration",
        "1",
    ]);
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["run.mcap"], "no partial file left beside it");
    assert!(
        scenarios::dataset::ros2::BagFile::open(&bag)
            .unwrap()
            .contents()
            .is_ok()
    );
}
