//! Safety of the build's own files inside an output directory: the work directory
//! `<out>/.work/<table>/`, the lock `<out>/.lock` and the catalog `<out>/index.json`.
//!
//! - A build writes and deletes only inside `--out`: each of those paths (and `.work/<table>`)
//!   is refused when it is a symbolic link, since a link would make `remove_dir_all` or a write
//!   act on a directory elsewhere.
//! - Checkpoints carry a keyed hash (HMAC-SHA-256) of their task key and values under a secret
//!   of the output directory, `<out>/.checkpoint-key` (32 random bytes, mode 0600, created by
//!   the first build; `SCATTERBAKE_CHECKPOINT_KEY_FILE` names another file, e.g. one outside a
//!   shared directory). A checkpoint whose values were changed and whose hash was recomputed
//!   without the secret, one copied from another task, and one copied from another output
//!   directory do not verify: they are recomputed, not used.
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
    #[error(
        "{path}: a checkpoint key must be 32 bytes, this file has {len} (remove it: the \
         checkpoints are then recomputed)"
    )]
    CheckpointKey { path: PathBuf, len: usize },
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

/// Remove the temporary files that a killed process left in `dir`: names
/// `.<file>.<host>.<pid>.<random>.tmp` ([`crate::table::format::temp_file_owner`]) written on
/// this host by a process that no longer exists. Files of live processes and of other hosts
/// (a shared directory) are kept. Needs `/proc` (Linux); elsewhere nothing is removed. Returns
/// how many files were removed.
pub fn remove_orphan_temp_files(dir: &Path) -> usize {
    if !Path::new("/proc/self").exists() {
        return 0;
    }
    let host = crate::table::format::host_tag();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
            continue;
        };
        // [random, pid, host, file name]
        let parts: Vec<&str> = inner.rsplitn(4, '.').collect();
        if parts.len() != 4 || parts[2] != host {
            continue;
        }
        let Ok(pid) = parts[1].parse::<u32>() else {
            continue;
        };
        let is_file = e.file_type().is_ok_and(|t| t.is_file());
        if is_file
            && !Path::new("/proc").join(pid.to_string()).exists()
            && std::fs::remove_file(e.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Refuse symbolic links at the build's own paths of `out`: `.work`, `.lock`, `index.json`,
/// `.checkpoint-key`.
pub fn check_out_dir(out: &Path) -> Result<(), WorkdirError> {
    for name in [".work", ".lock", "index.json", CHECKPOINT_KEY_FILE] {
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

/// File of the checkpoint secret in an output directory.
pub const CHECKPOINT_KEY_FILE: &str = ".checkpoint-key";
/// Environment variable naming the checkpoint secret file instead of `<out>/.checkpoint-key`.
pub const CHECKPOINT_KEY_ENV: &str = "SCATTERBAKE_CHECKPOINT_KEY_FILE";
/// Length of the checkpoint secret (bytes).
const CHECKPOINT_KEY_BYTES: usize = 32;
/// Block length of SHA-256 (bytes), for HMAC.
const SHA256_BLOCK: usize = 64;

/// The secret that keys the checkpoint hashes of one output directory.
#[derive(Clone, PartialEq, Eq)]
pub struct CheckpointKey([u8; CHECKPOINT_KEY_BYTES]);

impl std::fmt::Debug for CheckpointKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("CheckpointKey(..)")
    }
}

impl CheckpointKey {
    /// A key from its bytes.
    pub fn from_bytes(bytes: [u8; CHECKPOINT_KEY_BYTES]) -> Self {
        CheckpointKey(bytes)
    }
}

/// The checkpoint secret of `out`: read from `$SCATTERBAKE_CHECKPOINT_KEY_FILE` or
/// `<out>/.checkpoint-key`, or created there (32 bytes from the operating system's random
/// source, mode 0600) when missing. Concurrent builds agree on one key: the file is published
/// by a hard link that fails when another build created it first.
pub fn checkpoint_key(out: &Path) -> Result<CheckpointKey, WorkdirError> {
    let path = std::env::var_os(CHECKPOINT_KEY_ENV)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| out.join(CHECKPOINT_KEY_FILE));
    refuse_symlink(&path)?;
    let io = |source| WorkdirError::Io {
        path: path.clone(),
        source,
    };
    match crate::table::read_regular(&path) {
        Ok(bytes) => return key_from_file(&path, &bytes),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(io(e)),
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tmp = tempfile::Builder::new()
        .prefix(".checkpoint-key.")
        .tempfile_in(dir)
        .map_err(io)?;
    let mut secret = [0u8; CHECKPOINT_KEY_BYTES];
    random_bytes(&mut secret).map_err(io)?;
    {
        use std::io::Write;
        tmp.write_all(&secret).map_err(io)?;
        tmp.as_file().sync_all().map_err(io)?;
    }
    // `tempfile` creates the file with mode 0600 on Unix.
    match std::fs::hard_link(tmp.path(), &path) {
        Ok(()) => Ok(CheckpointKey(secret)),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            let bytes = crate::table::read_regular(&path).map_err(io)?;
            key_from_file(&path, &bytes)
        }
        Err(e) => Err(io(e)),
    }
}

fn key_from_file(path: &Path, bytes: &[u8]) -> Result<CheckpointKey, WorkdirError> {
    let secret: [u8; CHECKPOINT_KEY_BYTES] =
        bytes.try_into().map_err(|_| WorkdirError::CheckpointKey {
            path: path.into(),
            len: bytes.len(),
        })?;
    Ok(CheckpointKey(secret))
}

/// Fill `buf` from the operating system's random source.
fn random_bytes(buf: &mut [u8]) -> std::io::Result<()> {
    use std::io::Read;
    std::fs::File::open("/dev/urandom")?.read_exact(buf)
}

/// Keyed hash (HMAC-SHA-256, RFC 2104) of a checkpoint's values and scalars, bound to its task
/// key. The message is `scatterbake checkpoint 2\0`, the task key, `\0`, the number of values
/// and of scalars (u64 little-endian) and the values and scalars (little-endian).
pub fn checkpoint_hash(
    key: &CheckpointKey,
    task_key: &str,
    values: &[f32],
    scalars: &[f64],
) -> String {
    let mut block = [0u8; SHA256_BLOCK];
    block[..CHECKPOINT_KEY_BYTES].copy_from_slice(&key.0);
    let pad = |byte: u8| block.map(|b| b ^ byte);
    let mut inner = Sha256::new();
    inner.update(pad(0x36));
    inner.update(b"scatterbake checkpoint 2\0");
    inner.update(task_key.as_bytes());
    inner.update([0u8]);
    inner.update((values.len() as u64).to_le_bytes());
    inner.update((scalars.len() as u64).to_le_bytes());
    for v in values {
        inner.update(v.to_le_bytes());
    }
    for v in scalars {
        inner.update(v.to_le_bytes());
    }
    let mut outer = Sha256::new();
    outer.update(pad(0x5c));
    outer.update(inner.finalize());
    hex::encode(outer.finalize())
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
    let mut opts = std::fs::OpenOptions::new();
    // read and write: opening a FIFO so never waits for (or fails for want of) the other end
    opts.create(true).truncate(false).read(true).write(true);
    #[cfg(unix)]
    {
        // non-blocking: a FIFO planted as the lock is refused below instead of waiting for a
        // reader forever
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let file = opts.open(&path).map_err(io)?;
    if !file.metadata().map_err(io)?.is_file() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file; remove it (the build recreates its lock)",
        )));
    }
    file.lock().map_err(io)?;
    Ok(OutLock { _file: file })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// A temporary table file of a process that has exited is removed; those of this process
    /// and of another host are kept, as are other files.
    #[test]
    fn orphan_temp_files_of_dead_processes_are_removed() {
        let d = tempfile::tempdir().unwrap();
        let host = crate::table::format::host_tag();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let me = std::process::id();
        let names = [
            format!(".w.sbt.{host}.{dead}.a1B2c3.tmp"),
            format!(".w.sbt.{host}.{me}.a1B2c3.tmp"),
            format!(".w.sbt.otherhost.{dead}.a1B2c3.tmp"),
            "w.sbt".to_string(),
            ".w.sbt.tmp".to_string(),
        ];
        for n in &names {
            std::fs::write(d.path().join(n), b"x").unwrap();
        }
        assert_eq!(remove_orphan_temp_files(d.path()), 1);
        assert!(!d.path().join(&names[0]).exists());
        for n in &names[1..] {
            assert!(d.path().join(n).exists(), "{n} kept");
        }
        // What write_atomic leaves behind is recognised: the owner part is this host and pid.
        assert_eq!(
            crate::table::format::temp_file_owner(),
            format!("{host}.{me}")
        );
    }

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
    fn checkpoint_hash_is_bound_to_the_secret_the_task_and_the_values() {
        let k = CheckpointKey::from_bytes([1; 32]);
        let v = [1.0f32, 2.0];
        let h = |k: &CheckpointKey, t: &str, v: &[f32], s: &[f64]| checkpoint_hash(k, t, v, s);
        assert_ne!(h(&k, "a", &v, &[]), h(&k, "b", &v, &[]));
        assert_ne!(h(&k, "a", &v, &[]), h(&k, "a", &[1.0, 3.0], &[]));
        assert_ne!(h(&k, "a", &v, &[]), h(&k, "a", &v, &[0.5]));
        // The same bytes split differently between values and scalars.
        let both = h(&k, "a", &[0.0, 0.0], &[]);
        assert_ne!(both, h(&k, "a", &[], &[0.0]));
        let other = CheckpointKey::from_bytes([2; 32]);
        assert_ne!(h(&k, "a", &v, &[]), h(&other, "a", &v, &[]));
    }

    #[test]
    fn checkpoint_hash_is_hmac_sha256() {
        // HMAC (RFC 2104) written out from its definition for a 32-byte key.
        let k = CheckpointKey::from_bytes([0x0b; 32]);
        let mut msg = b"scatterbake checkpoint 2\0t\0".to_vec();
        msg.extend(1u64.to_le_bytes());
        msg.extend(1u64.to_le_bytes());
        msg.extend(1.5f32.to_le_bytes());
        msg.extend(0.25f64.to_le_bytes());
        let mut ipad = vec![0x36u8 ^ 0x0b; 32];
        ipad.extend([0x36u8; 32]);
        let mut opad = vec![0x5cu8 ^ 0x0b; 32];
        opad.extend([0x5cu8; 32]);
        let inner = Sha256::digest([ipad, msg].concat());
        let outer = Sha256::digest([opad, inner.to_vec()].concat());
        assert_eq!(
            checkpoint_hash(&k, "t", &[1.5], &[0.25]),
            hex::encode(outer)
        );
    }

    #[test]
    fn checkpoint_key_is_created_once_and_shared() {
        let d = tempfile::tempdir().unwrap();
        let a = checkpoint_key(d.path()).unwrap();
        let b = checkpoint_key(d.path()).unwrap();
        assert_eq!(a, b);
        let bytes = std::fs::read(d.path().join(CHECKPOINT_KEY_FILE)).unwrap();
        assert_eq!(bytes.len(), 32);
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(d.path().join(CHECKPOINT_KEY_FILE))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o077, 0, "readable by others: {mode:o}");
        std::fs::write(d.path().join(CHECKPOINT_KEY_FILE), b"short").unwrap();
        let e = checkpoint_key(d.path()).unwrap_err();
        assert!(
            e.to_string().contains("must be 32 bytes, this file has 5"),
            "{e}"
        );
    }
}
