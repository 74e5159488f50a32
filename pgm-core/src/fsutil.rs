//! Writing files so that a reader never sees half of one.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically: into a temporary sibling `.NAME.PID.tmp`
/// (hidden, named after the process so that it cannot be a file of the user's), flushed
/// to disk, then renamed over `path`. A reader sees the old file or the new one, never
/// a mix; on failure the temporary file is removed and `path` is untouched.
///
/// # Errors
/// [`Error::InvalidParameter`] when `path` names no file (`/`, `..`), [`Error::Io`]
/// naming the file that could not be written or renamed.
pub fn write_atomically(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    let path = path.as_ref();
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    let file_name = path.file_name().ok_or_else(|| Error::InvalidParameter {
        name: "output file path",
        value: path.display().to_string(),
        expected: "a path naming a file",
    })?;
    let mut temporary_name = std::ffi::OsString::from(".");
    temporary_name.push(file_name);
    temporary_name.push(format!(".{}.tmp", std::process::id()));
    let temporary: PathBuf = path.with_file_name(temporary_name);
    let write = || -> Result<()> {
        let mut file = std::fs::File::create(&temporary).map_err(io(&temporary))?;
        file.write_all(bytes).map_err(io(&temporary))?;
        file.sync_all().map_err(io(&temporary))?;
        std::fs::rename(&temporary, path).map_err(io(path))
    };
    let result = write();
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("pgm-fsutil-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w.json");
        std::fs::write(&path, "old").unwrap();
        // A user's file with the old fixed temporary name is never touched.
        std::fs::write(dir.join("w.json.tmp"), "mine").unwrap();
        write_atomically(&path, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(
            std::fs::read_to_string(dir.join("w.json.tmp")).unwrap(),
            "mine"
        );
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // A directory that does not exist: an error naming the temporary file, nothing written.
        let missing = dir.join("no-such-dir").join("w.json");
        let e = write_atomically(&missing, b"x").unwrap_err().to_string();
        assert!(e.contains("no-such-dir"), "{e}");
        assert!(write_atomically("/", b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
