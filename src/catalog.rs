//! The catalog `tables/index.json`: every built table with its schema, size, checksum and
//! origin. Rebuilt from the directory contents (so shards and concurrent builds converge) under
//! an exclusive lock on `<dir>/.lock`, and written atomically. A table is listed when it is
//! sealed as written ([`crate::table::verify_sealed`]: header rules, compressed payload size,
//! SHA-256 and zstd frame); decompressing every table on every build is left to `verify`. A
//! table the rebuilding process has just written itself is listed from what it wrote
//! ([`rebuild_with`]) while the file at its path is still that file.

use crate::error::IoError;
use crate::table::format::write_atomic;
use crate::table::{FORMAT_MAJOR, FORMAT_MINOR, TableError};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Why the catalog could not be rebuilt.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    /// Reading the directory, taking the lock or writing `index.json`.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The header of a table that verified a moment before (the error names the file).
    #[error(transparent)]
    Table(#[from] TableError),
    /// A symlinked catalog, lock or work path in the output directory.
    #[error(transparent)]
    Workdir(#[from] crate::workdir::WorkdirError),
    /// The catalog does not encode as JSON.
    #[error("encoding the catalog {}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
}

/// Byte range of the format version (major, minor: u16 little-endian) in a table file.
const VERSION_BYTES: std::ops::Range<usize> = 8..12;

/// One catalog entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CatalogEntry {
    /// Table name (file stem).
    pub name: String,
    /// File name relative to the catalog.
    pub file: String,
    /// Schema, e.g. `mie-phase/1`.
    pub schema: String,
    /// Table format version of the file, `major.minor`.
    pub format_version: String,
    pub description: String,
    /// File size in bytes.
    pub size_bytes: u64,
    /// SHA-256 of the whole file.
    pub sha256: String,
    /// Manifest that produced it.
    pub manifest: Option<String>,
    /// Stage and algorithm version.
    pub stage: Option<String>,
    /// Content key (parameters digest).
    pub parameters_digest: String,
    pub created_utc: String,
}

/// The catalog file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Catalog {
    pub format: String,
    pub tables: Vec<CatalogEntry>,
    /// Files ending in `.sbt` that are not sealed tables (name and reason).
    pub invalid: Vec<(String, String)>,
}

impl CatalogEntry {
    /// The entry of file `file` (name in the catalog's directory) with header `h`, format
    /// version `major.minor`, size and whole-file SHA-256.
    fn new(
        file: String,
        h: &crate::table::Header,
        (major, minor): (u16, u16),
        size_bytes: u64,
        sha256: String,
    ) -> Self {
        CatalogEntry {
            name: file.trim_end_matches(".sbt").to_string(),
            file,
            schema: h.schema.to_string(),
            format_version: format!("{major}.{minor}"),
            description: h.description.clone(),
            size_bytes,
            sha256,
            manifest: h.provenance.manifest.clone(),
            stage: h.provenance.stage.clone(),
            parameters_digest: h.provenance.parameters_digest.clone(),
            created_utc: h.provenance.created_utc.clone(),
        }
    }
}

/// A table this process has just written ([`crate::table::write_table_atomic_sealed`]): its
/// catalog entry and the stamp of the file, so that [`rebuild_with`] lists it without reading
/// it back while the file at its path still has that stamp.
#[derive(Debug, Clone)]
pub struct FreshTable {
    entry: CatalogEntry,
    stamp: crate::table::FileStamp,
}

impl FreshTable {
    /// The table `header` just written at `path` (in the format this build writes).
    pub fn new(path: &Path, header: &crate::table::Header, w: crate::table::WrittenTable) -> Self {
        let file = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        FreshTable {
            entry: CatalogEntry::new(
                file,
                header,
                (FORMAT_MAJOR, FORMAT_MINOR),
                w.size_bytes,
                w.file_sha256,
            ),
            stamp: w.stamp,
        }
    }
}

/// Rebuild `<dir>/index.json` from the `.sbt` files in `dir`. Returns the catalog.
pub fn rebuild(dir: &Path) -> Result<Catalog, CatalogError> {
    rebuild_with(dir, &[])
}

/// [`rebuild`], taking the entries of `fresh` tables (written by this process) as they are when
/// their files still carry the stamps they were written with; every other file is read and
/// verified. Listing a seed-resolution table this way saves reading and hashing its 0.3 GB.
pub fn rebuild_with(dir: &Path, fresh: &[FreshTable]) -> Result<Catalog, CatalogError> {
    std::fs::create_dir_all(dir).map_err(IoError::doing("creating the catalog directory", dir))?;
    crate::workdir::check_out_dir(dir).map_err(CatalogError::from)?;
    let lock_path = dir.join(".lock");
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(IoError::doing("opening lock file", &lock_path))?;
    lock.lock().map_err(IoError::doing("locking", &lock_path))?;
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(IoError::doing("listing", dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "sbt") && p.is_file())
        .collect();
    files.sort();
    let mut tables = Vec::new();
    let mut invalid = Vec::new();
    for p in files {
        let file = p.file_name().expect("file").to_string_lossy().into_owned();
        let known = fresh.iter().find(|f| {
            f.entry.file == file
                && std::fs::metadata(&p).is_ok_and(|m| crate::table::FileStamp::of(&m) == f.stamp)
        });
        if let Some(f) = known {
            tables.push(f.entry.clone());
            continue;
        }
        let bytes = match std::fs::read(&p) {
            Ok(b) => b,
            Err(e) => {
                invalid.push((file, e.to_string()));
                continue;
            }
        };
        // The payload's checksum and the whole file's hash are two passes over the file: one
        // per core (0.50 → 0.35 s for `scatterbake catalog` of one 164 MB seed table).
        let (sealed, file_sha) = rayon::join(
            || crate::table::verify_sealed_bytes(&bytes, &p),
            || hex::encode(Sha256::digest(&bytes)),
        );
        let h = match sealed {
            Ok(h) => h,
            Err(e) => {
                invalid.push((file, e.to_string()));
                continue;
            }
        };
        let v = &bytes[VERSION_BYTES];
        let major = u16::from_le_bytes([v[0], v[1]]);
        let minor = u16::from_le_bytes([v[2], v[3]]);
        tables.push(CatalogEntry::new(
            file,
            &h,
            (major, minor),
            bytes.len() as u64,
            file_sha,
        ));
    }
    let catalog = Catalog {
        format: format!("scatterbake-catalog/1 (tables in format {FORMAT_MAJOR}.{FORMAT_MINOR})"),
        tables,
        invalid,
    };
    let index = dir.join("index.json");
    let mut json = serde_json::to_vec_pretty(&catalog).map_err(|source| CatalogError::Json {
        path: index.clone(),
        source,
    })?;
    json.push(b'\n');
    write_atomic(&index, &json).map_err(IoError::doing("writing", &index))?;
    drop(lock);
    Ok(catalog)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consumers::synthetic::henyey_greenstein_table;
    use crate::table::write_table_atomic_sealed;

    /// A fresh table's entry is the entry a full read of the file gives; once the file at its
    /// path is another (a concurrent build replaced it), the file is read instead.
    #[test]
    fn fresh_tables_are_listed_as_a_full_read_lists_them() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hg.sbt");
        let mut t = henyey_greenstein_table(
            &[450.0, 650.0],
            &[1.0],
            |k, _| 0.3 + 0.2 * k as f64,
            37,
            0.1,
        );
        let written = write_table_atomic_sealed(&mut t, &path).unwrap();
        assert_eq!(written.size_bytes, std::fs::metadata(&path).unwrap().len());
        let fresh = [FreshTable::new(&path, &t.header, written)];
        let listed = rebuild_with(dir.path(), &fresh).unwrap();
        let read = rebuild(dir.path()).unwrap();
        assert_eq!(listed, read);
        assert_eq!(read.tables.len(), 1);
        assert_eq!(
            read.tables[0].sha256,
            hex::encode(Sha256::digest(std::fs::read(&path).unwrap()))
        );
        // Replaced by another table under the same name: the stale fresh entry is not used.
        let mut other = henyey_greenstein_table(&[500.0], &[2.0], |_, _| 0.7, 19, 0.1);
        write_table_atomic_sealed(&mut other, &path).unwrap();
        let listed = rebuild_with(dir.path(), &fresh).unwrap();
        assert_eq!(listed, rebuild(dir.path()).unwrap());
        assert_ne!(listed.tables[0].sha256, fresh[0].entry.sha256);
    }
}
