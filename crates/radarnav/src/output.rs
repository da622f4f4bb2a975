//! Output files written whole or not at all (DESIGN §12).
//!
//! A file is written under a temporary name beside it (`<name>.partial`) and renamed when it
//! is complete, so a run that fails (disk full, an error, a kill) never leaves a file that
//! looks whole. Small files go through [`write_whole`]; files that grow during a run (the
//! trajectory, scan logs, MCAP) are [`Staged`] and renamed together when the run finishes.

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

/// Suffix of a file still being written.
pub const PARTIAL: &str = ".partial";

/// `path` with [`PARTIAL`] appended.
pub fn partial(path: &Path) -> PathBuf {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(PARTIAL);
    PathBuf::from(tmp)
}

/// Writes `bytes` to `path` whole: to [`partial`] first, renamed when complete; on failure
/// the temporary file is removed. The error is the OS error (the caller names the file).
pub fn write_whole(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = partial(path);
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Files being written under their temporary names, renamed by [`Staged::commit`]; those
/// never committed are removed when the set is dropped.
#[derive(Debug, Default)]
pub struct Staged {
    files: Vec<PathBuf>,
}

impl Staged {
    /// Creates the temporary file of `path` and remembers it.
    pub fn create(&mut self, path: &Path) -> io::Result<File> {
        let file = File::create(partial(path))?;
        self.files.push(path.to_owned());
        Ok(file)
    }

    /// Renames every file to its final name; returns them. On an error, the path is the
    /// file that could not be renamed.
    pub fn commit(&mut self) -> Result<Vec<PathBuf>, (PathBuf, io::Error)> {
        let mut done = Vec::new();
        while let Some(path) = self.files.first().cloned() {
            std::fs::rename(partial(&path), &path).map_err(|e| (path.clone(), e))?;
            self.files.remove(0);
            done.push(path);
        }
        Ok(done)
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        for path in &self.files {
            let _ = std::fs::remove_file(partial(path));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn staged_files_appear_whole_on_commit_and_vanish_when_dropped() {
        let dir = std::env::temp_dir().join(format!("radarnav-staged-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
        let mut s = Staged::default();
        writeln!(s.create(&a).unwrap(), "x").unwrap();
        assert!(!a.exists() && partial(&a).exists());
        assert_eq!(s.commit().unwrap(), vec![a.clone()]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "x\n");
        {
            let mut s = Staged::default();
            writeln!(s.create(&b).unwrap(), "y").unwrap();
        }
        assert!(!b.exists() && !partial(&b).exists());
        write_whole(&b, b"z").unwrap();
        assert_eq!(std::fs::read(&b).unwrap(), b"z");
        assert!(write_whole(&dir.join("no/such/dir"), b"z").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
