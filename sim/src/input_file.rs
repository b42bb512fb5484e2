//! The door every input file of the tools goes through: only regular files are read (a FIFO
//! would block the reader forever, a device could stream without end, a folder is a mistake),
//! and none larger than [`MAX_INPUT_FILE_BYTES`]. The error names what the path is instead.

use std::io;
use std::path::Path;

/// Largest input file read (bytes): a whole EuRoC flight's IMU or ground-truth CSV is tens of
/// MB and an image a few hundred kB; 4 GiB is beyond any input and within the memory of a
/// machine that runs the harness.
pub const MAX_INPUT_FILE_BYTES: u64 = 4 << 30;

/// Checks that `path` is a regular file of readable size, without opening it.
pub fn check(path: &Path) -> io::Result<()> {
    let meta = std::fs::metadata(path)?;
    let kind = meta.file_type();
    if !kind.is_file() {
        let what = if kind.is_dir() {
            "a folder"
        } else {
            "not a regular file (a FIFO, socket or device)"
        };
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{what}: only regular files are read"),
        ));
    }
    if meta.len() > MAX_INPUT_FILE_BYTES {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} bytes, more than the {MAX_INPUT_FILE_BYTES} an input file may hold",
                meta.len()
            ),
        ));
    }
    Ok(())
}

/// [`std::fs::read`] behind [`check`].
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    check(path)?;
    std::fs::read(path)
}

/// [`std::fs::read_to_string`] behind [`check`].
pub fn read_to_string(path: &Path) -> io::Result<String> {
    check(path)?;
    std::fs::read_to_string(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_are_refused_and_regular_files_read() {
        let dir = std::env::temp_dir();
        let err = read(&dir).unwrap_err();
        assert!(err.to_string().contains("a folder"), "{err}");
        let file = dir.join(format!("input_file_test_{}", std::process::id()));
        std::fs::write(&file, b"ok").unwrap();
        assert_eq!(read(&file).unwrap(), b"ok");
        std::fs::remove_file(&file).unwrap();
    }
}
