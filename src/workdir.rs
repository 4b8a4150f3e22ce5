//! Safety of the build's own files inside an output directory: the work directory
//! `<out>/.work/<table>/`, the lock `<out>/.lock` and the catalog `<out>/index.json`.
//!
//! - A build writes and deletes only inside `--out`: each of those paths (and `.work/<table>`)
//!   is refused when it is a symbolic link, since a link would make `remove_dir_all` or a write
//!   act on a directory elsewhere.
//! - Checkpoints carry a hash bound to their task key (SHA-256 over the key, a separator and
//!   the values), so a checkpoint whose values were changed and whose plain SHA-256 was
//!   recomputed, or a checkpoint copied from another task, does not verify.
//! - The exclusive lock on `<out>/.lock` serialises assembly of complete tables and the catalog
//!   rewrite between concurrent builds and shards.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// What can go wrong with the build's files in an output directory.
#[derive(Debug, thiserror::Error)]
pub enum WorkdirError {
    #[error(
        "{path} is a symbolic link; refusing to write or delete through it (a build only writes \
         inside its output directory)"
    )]
    Symlink { path: PathBuf },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Ok when `path` does not exist or is not a symbolic link.
pub fn refuse_symlink(path: &Path) -> Result<(), WorkdirError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(WorkdirError::Symlink { path: path.into() }),
        Ok(_) => Ok(()),
        Err(e) => gone_is_fine(e, path),
    }
}

/// Ok for "not found" and "directory not empty" (a directory a concurrent build is writing
/// into); any other I/O error names `path`.
fn gone_is_fine(e: std::io::Error, path: &Path) -> Result<(), WorkdirError> {
    match e.kind() {
        std::io::ErrorKind::NotFound | std::io::ErrorKind::DirectoryNotEmpty => Ok(()),
        _ => Err(WorkdirError::Io {
            path: path.into(),
            source: e,
        }),
    }
}

/// Refuse symbolic links at the build's own paths of `out`: `.work`, `.lock`, `index.json`.
pub fn check_out_dir(out: &Path) -> Result<(), WorkdirError> {
    for name in [".work", ".lock", "index.json"] {
        refuse_symlink(&out.join(name))?;
    }
    Ok(())
}

/// Remove a table's work directory `<out>/.work/<table>` (missing is fine), refusing when it or
/// `.work` is a symbolic link. A concurrent build may write a checkpoint into it while it is
/// being removed ("directory not empty"): the table is already written, so the directory is
/// left for the next build to clean up.
pub fn remove_table_work_dir(work_dir: &Path) -> Result<(), WorkdirError> {
    if let Some(parent) = work_dir.parent() {
        refuse_symlink(parent)?;
    }
    refuse_symlink(work_dir)?;
    std::fs::remove_dir_all(work_dir).or_else(|e| gone_is_fine(e, work_dir))
}

/// Hash of a checkpoint's values bound to its task key.
pub fn checkpoint_hash(task_key: &str, values: &[f32]) -> String {
    let mut h = Sha256::new();
    h.update(b"scatterbake checkpoint\0");
    h.update(task_key.as_bytes());
    h.update([0u8]);
    for v in values {
        h.update(v.to_le_bytes());
    }
    hex::encode(h.finalize())
}

/// An exclusive lock on `<out>/.lock`, released on drop.
pub struct OutLock {
    _file: std::fs::File,
}

/// Take the exclusive lock on `<out>/.lock` (blocking), refusing a symbolic link.
pub fn lock_out_dir(out: &Path) -> Result<OutLock, WorkdirError> {
    let path = out.join(".lock");
    refuse_symlink(&path)?;
    let io = |source| WorkdirError::Io {
        path: path.clone(),
        source,
    };
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(io)?;
    file.lock().map_err(io)?;
    Ok(OutLock { _file: file })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn symlinked_work_dir_is_refused_and_its_target_kept() {
        let d = tempfile::tempdir().unwrap();
        let outside = d.path().join("outside");
        std::fs::create_dir_all(&outside).unwrap();
        std::fs::write(outside.join("keep.txt"), "x").unwrap();
        let out = d.path().join("out");
        std::fs::create_dir_all(&out).unwrap();
        std::os::unix::fs::symlink(&outside, out.join(".work")).unwrap();
        assert!(matches!(
            check_out_dir(&out),
            Err(WorkdirError::Symlink { .. })
        ));
        let e = remove_table_work_dir(&out.join(".work").join("t")).unwrap_err();
        assert!(e.to_string().contains(".work is a symbolic link"), "{e}");
        assert!(outside.join("keep.txt").exists());
    }

    #[test]
    fn checkpoint_hash_is_bound_to_the_key() {
        let v = [1.0f32, 2.0];
        assert_ne!(checkpoint_hash("a", &v), checkpoint_hash("b", &v));
        assert_ne!(checkpoint_hash("a", &v), checkpoint_hash("a", &[1.0, 3.0]));
    }
}
