//! Where an export writes, whole or marked: one writer at a time in an ASL folder (an OS lock
//! on `OUT/.vio-export.lock`, released when the process ends, however it ends), and the folder
//! marked incomplete until the export finishes (`OUT/mav0/EXPORT_INCOMPLETE`, which `vio euroc`
//! refuses); a bag written beside its path and renamed onto it once complete.

use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Path, PathBuf};

use super::sink::ExportError;

/// The lock file of an ASL export's output folder.
pub const LOCK_FILE: &str = ".vio-export.lock";

use crate::dataset::INCOMPLETE_MARKER;

fn write_error(path: &Path, e: impl std::fmt::Display) -> ExportError {
    ExportError::Write(format!("{}: {e}", path.display()))
}

/// An ASL output folder claimed by this export.
pub(super) struct ClaimedFolder {
    /// Held for the export's life: the lock goes with it.
    _lock: File,
    marker: PathBuf,
}

impl ClaimedFolder {
    /// Locks `out` against a second export and marks its `mav0/` incomplete; refused while
    /// another export holds the lock.
    pub(super) fn claim(out: &Path) -> Result<Self, ExportError> {
        std::fs::create_dir_all(out).map_err(|e| write_error(out, e))?;
        let lock_path = out.join(LOCK_FILE);
        let lock = OpenOptions::new()
            .create(true)
            .write(true)
            .truncate(false)
            .open(&lock_path)
            .map_err(|e| write_error(&lock_path, e))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(ExportError::Write(format!(
                    "{}: another export is writing into this folder now (it holds {LOCK_FILE}): wait for it to end, or export into another --out",
                    out.display()
                )));
            }
            Err(TryLockError::Error(e)) => return Err(write_error(&lock_path, e)),
        }
        let mav0 = out.join("mav0");
        std::fs::create_dir_all(&mav0).map_err(|e| write_error(&mav0, e))?;
        let marker = mav0.join(INCOMPLETE_MARKER);
        std::fs::write(
            &marker,
            "An export into this folder started and has not finished (it was stopped, or it is \
             still running): its files may be partial or mixed with an older export's. `vio \
             euroc` refuses the folder while this file is here; export again to complete it.\n",
        )
        .map_err(|e| write_error(&marker, e))?;
        Ok(Self {
            _lock: lock,
            marker,
        })
    }

    /// The export finished: the folder is whole.
    pub(super) fn complete(self) -> Result<(), ExportError> {
        std::fs::remove_file(&self.marker).map_err(|e| write_error(&self.marker, e))
    }
}

/// Where a bag at `path` is written until it is complete: a hidden sibling named for this
/// process.
pub(super) fn partial_bag_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "bag".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

/// Moves a complete bag from its partial path onto `path`.
pub(super) fn complete_bag(partial: &Path, path: &Path) -> Result<(), ExportError> {
    std::fs::rename(partial, path).map_err(|e| write_error(path, e))
}
