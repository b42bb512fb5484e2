//! Helpers shared by the `vio` CLI tests: run the binary, scratch folders, short scenario
//! texts, and the bad-input assertion (exit 2, file and key named, nothing written).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `vio` binary with `args`.
pub fn vio(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(args)
        .output()
        .expect("run vio")
}

/// Runs the `vio` binary with `args` and requires exit 0 (the message shows its stderr).
pub fn vio_ok(args: &[&str]) -> Output {
    let out = vio(args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The byte ranges of the numbers in `line` (for fuzzers that replace them).
pub fn numbers(line: &str) -> Vec<(usize, usize)> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let inside_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !inside_word {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_alphanumeric() || b"+-.".contains(&b[j])) {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// A fresh scratch folder for one test (`tag` starts its name), removed when dropped.
pub fn scratch(tag: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("vio-{tag}-"))
        .tempdir()
        .expect("a scratch folder")
}

/// The default catalog scenario's text, shortened to `duration_s`, with one loose expectation
/// (`ate_rmse_m ≤ 0.15`).
pub fn default_text(duration_s: f64) -> String {
    let text = scenarios::catalog::get(scenarios::catalog::DEFAULT)
        .unwrap()
        .text;
    assert!(text.contains("duration_s = 60.0"));
    let head = &text[..text.find("[expectations]").unwrap()];
    head.replace("duration_s = 60.0", &format!("duration_s = {duration_s:?}"))
        + "[expectations]\nate_rmse_m = { max = 0.15 }\n"
}

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `vio run` on `text`; asserts exit code 2 and that stderr names `key` and `line`.
pub fn assert_bad(tag: &str, text: &str, key: &str, expect: &[&str]) -> String {
    assert_bad_with(tag, text, &[], key, expect)
}

/// [`assert_bad`] with data `files` `(path relative to the scenario, bytes)` beside the
/// scenario file.
pub fn assert_bad_with(
    tag: &str,
    text: &str,
    files: &[(&str, &[u8])],
    key: &str,
    expect: &[&str],
) -> String {
    let dir = scratch(tag);
    let dir = dir.path();
    for (rel, bytes) in files {
        let path = dir.join(rel);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    let p = write(dir, "bad.toml", text);
    let out = vio(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{tag}: stderr: {stderr}");
    assert!(
        stderr.contains("bad.toml"),
        "{tag}: file not named: {stderr}"
    );
    assert!(
        stderr.contains(key),
        "{tag}: key `{key}` not named: {stderr}"
    );
    for e in expect {
        assert!(stderr.contains(e), "{tag}: `{e}` missing: {stderr}");
    }
    assert!(
        !dir.join("out").exists(),
        "{tag}: wrote output on bad input"
    );
    let _ = std::fs::remove_dir_all(dir);
    stderr
}
