//! The catalog `tables/index.json`: every built table with its schema, size, checksum and
//! origin. Rebuilt from the directory contents (so shards and concurrent builds converge) under
//! an exclusive lock on `<dir>/.lock`, and written atomically. A table is listed when it is
//! sealed as written ([`crate::table::verify_sealed`]: header rules, compressed payload size,
//! SHA-256 and zstd frame); decompressing every table on every build is left to `verify`. A
//! table the rebuilding process has just written itself is listed from what it wrote
//! ([`rebuild_with`]) while the file at its path is still that file, and a table the previous
//! catalog listed is listed from its entry while the file keeps the stamp recorded in
//! [`STAMPS_FILE`] ([`Listed`]); every other file is read.

use crate::error::IoError;
use crate::table::format::write_atomic;
use crate::table::{FORMAT_MAJOR, FORMAT_MINOR, FileStamp, MAGIC, TableError};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why the catalog could not be rebuilt.
#[derive(Debug, thiserror::Error)]
pub enum CatalogError {
    /// Reading the directory or writing `index.json`.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The header of a table that verified a moment before (the error names the file).
    #[error(transparent)]
    Table(#[from] TableError),
    /// A symlinked catalog, lock or work path in the output directory, or a lock that cannot
    /// be taken.
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
    stamp: FileStamp,
}

impl FreshTable {
    /// The table `header` just written at `path` (in the format version it was written as).
    pub fn new(path: &Path, header: &crate::table::Header, w: crate::table::WrittenTable) -> Self {
        let file = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        FreshTable {
            entry: CatalogEntry::new(
                file,
                header,
                header.format_version(),
                w.size_bytes,
                w.file_sha256,
            ),
            stamp: w.stamp,
        }
    }
}

/// The format line of the catalogs this build writes.
fn catalog_format() -> String {
    format!("scatterbake-catalog/1 (tables in formats 1.0 to {FORMAT_MAJOR}.{FORMAT_MINOR})")
}

/// Beside `index.json`: the stamp (size, modification time, device, inode) and whole-file
/// SHA-256 of every file the catalog lists, as it was when listed. Kept out of `index.json`,
/// whose content depends only on the tables (a sharded build's catalog equals an unsharded
/// one's), while stamps belong to one directory on one file system.
pub const STAMPS_FILE: &str = ".catalog-stamps.json";

/// Largest `index.json` or stamps file read back (bytes): about 40 000 tables. A larger or
/// unreadable one is ignored, and every table is read instead.
const MAX_INDEX_BYTES: u64 = 64 << 20;

/// One file's stamp in [`STAMPS_FILE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct StampRecord {
    stamp: FileStamp,
    sha256: String,
}

/// The content of [`STAMPS_FILE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Stamps {
    format: String,
    files: std::collections::BTreeMap<String, StampRecord>,
}

/// `path` parsed as JSON, or `None` when missing, unreadable, larger than [`MAX_INDEX_BYTES`]
/// or not of type `T`.
fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    let file = crate::table::open_regular(path).ok()?;
    let mut bytes = Vec::new();
    file.take(MAX_INDEX_BYTES + 1)
        .read_to_end(&mut bytes)
        .ok()?;
    if bytes.len() as u64 > MAX_INDEX_BYTES {
        return None;
    }
    serde_json::from_slice(&bytes).ok()
}

/// The entries of the catalog already in a directory with their files' stamps, to list the
/// files that have not changed since without reading them. An entry counts only when the
/// stamps file records the same SHA-256 for it; nothing counts when either file is missing,
/// unreadable, too large or of another format: then every file is read.
#[derive(Debug, Default)]
pub struct Listed {
    entries: HashMap<String, (CatalogEntry, FileStamp)>,
}

impl Listed {
    /// The catalog `<dir>/index.json` and its stamps, if they are ones this build writes.
    pub fn load(dir: &Path) -> Self {
        let format = catalog_format();
        let catalog = read_json::<Catalog>(&dir.join("index.json")).filter(|c| c.format == format);
        let stamps = read_json::<Stamps>(&dir.join(STAMPS_FILE)).filter(|s| s.format == format);
        let (Some(catalog), Some(mut stamps)) = (catalog, stamps) else {
            return Listed::default();
        };
        let entries = catalog
            .tables
            .into_iter()
            .filter_map(|e| {
                let r = stamps.files.remove(&e.file)?;
                (r.sha256 == e.sha256 && r.stamp.identifies())
                    .then(|| (e.file.clone(), (e, r.stamp)))
            })
            .collect();
        Listed { entries }
    }

    /// The entry of the file at `path` when the file still has the stamp it was listed with.
    pub fn unchanged(&self, path: &Path) -> Option<&CatalogEntry> {
        let file = path.file_name()?.to_string_lossy();
        let (entry, stamp) = self.entries.get(file.as_ref())?;
        let now = FileStamp::of(&std::fs::metadata(path).ok()?);
        (now == *stamp).then_some(entry)
    }
}

/// Rebuild `<dir>/index.json` from the `.sbt` files in `dir`. Returns the catalog.
pub fn rebuild(dir: &Path) -> Result<Catalog, CatalogError> {
    rebuild_with(dir, &[])
}

/// [`rebuild`] reading and verifying every file, whatever the stamps of the previous catalog
/// say (`scatterbake catalog --full`).
pub fn rebuild_reading_all(dir: &Path) -> Result<Catalog, CatalogError> {
    rebuild_listing(dir, &[], |_| Listed::default())
}

/// [`rebuild`], taking the entries of `fresh` tables (written by this process) as they are when
/// their files still carry the stamps they were written with, and the entries of the catalog
/// already in `dir` for the files that still carry the stamps listed there; every other file is
/// read and verified. Listing a seed-resolution table without reading it saves reading and
/// hashing its 0.3 GB, and a shard of a job array writing into a shared directory reads only
/// the tables written since the last catalog.
pub fn rebuild_with(dir: &Path, fresh: &[FreshTable]) -> Result<Catalog, CatalogError> {
    rebuild_listing(dir, fresh, Listed::load)
}

/// The rebuild, taking the previous catalog's entries from `listed` (read under the lock).
fn rebuild_listing(
    dir: &Path,
    fresh: &[FreshTable],
    listed: impl FnOnce(&Path) -> Listed,
) -> Result<Catalog, CatalogError> {
    std::fs::create_dir_all(dir).map_err(IoError::doing("creating the catalog directory", dir))?;
    crate::workdir::check_out_dir(dir)?;
    let _lock = crate::workdir::lock_out_dir(dir)?;
    let listed = listed(dir);
    let mut listing = Listing::default();
    for p in table_files(dir)? {
        let file = p.file_name().expect("file").to_string_lossy().into_owned();
        let stamp = std::fs::metadata(&p).ok().map(|m| FileStamp::of(&m));
        let known = fresh
            .iter()
            .find(|f| f.entry.file == file && stamp.as_ref() == Some(&f.stamp))
            .map(|f| &f.entry)
            .or_else(|| listed.unchanged(&p));
        match (known, stamp) {
            (Some(e), Some(stamp)) => listing.add(e.clone(), stamp),
            _ => match read_entry(&p, file.clone()) {
                Ok((e, stamp)) => listing.add(e, stamp),
                Err(why) => listing.invalid.push((file, why)),
            },
        }
    }
    let catalog = Catalog {
        format: catalog_format(),
        tables: listing.tables,
        invalid: listing.invalid,
    };
    write_catalog(dir, &catalog, listing.stamps)?;
    Ok(catalog)
}

/// The `.sbt` files in `dir`, sorted.
fn table_files(dir: &Path) -> Result<Vec<PathBuf>, CatalogError> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(IoError::doing("listing", dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "sbt") && p.is_file())
        .collect();
    files.sort();
    Ok(files)
}

/// A catalog being listed: its entries, the invalid files, and the stamps of the listed files.
#[derive(Default)]
struct Listing {
    tables: Vec<CatalogEntry>,
    invalid: Vec<(String, String)>,
    stamps: std::collections::BTreeMap<String, StampRecord>,
}

impl Listing {
    /// List `entry`, whose file has `stamp`.
    fn add(&mut self, entry: CatalogEntry, stamp: FileStamp) {
        let record = StampRecord {
            stamp,
            sha256: entry.sha256.clone(),
        };
        self.stamps.insert(entry.file.clone(), record);
        self.tables.push(entry);
    }
}

/// The entry of the table file `p` (named `file` in the catalog) from reading and verifying
/// it, with the stamp of what was read; `Err(why)` when it cannot be read or is not sealed.
///
/// The file streams once: through the sealed check (header, payload size and SHA-256, zstd
/// frame) on this thread and, in 1 MiB chunks, through the whole file's SHA-256 on another, so
/// memory stays a few MB whatever the table's size.
fn read_entry(p: &Path, file: String) -> Result<(CatalogEntry, FileStamp), String> {
    // The stamp of what is read: taken from the open file, so that a file renamed into place
    // meanwhile is never listed under the stamp of the one it replaced.
    let mut f = crate::table::open_regular(p).map_err(|e| e.to_string())?;
    let meta = f.metadata().map_err(|e| e.to_string())?;
    let stamp = FileStamp::of(&meta);
    // A file that does not start with the table magic is refused from its first 8 bytes,
    // whatever its size, with the reader's own message.
    let mut first = Vec::new();
    (&mut f)
        .take(MAGIC.len() as u64)
        .read_to_end(&mut first)
        .map_err(|e| e.to_string())?;
    if first != MAGIC {
        let refused = crate::table::verify_sealed_bytes(&first, p);
        return Err(refused.map_or_else(|e| e.to_string(), |_| "not a table".into()));
    }
    let (sealed, preamble, file_sha) = stream_sealed(first, f, meta.len(), p);
    let h = sealed.map_err(|e| e.to_string())?;
    let v = &preamble[VERSION_BYTES];
    let version = (
        u16::from_le_bytes([v[0], v[1]]),
        u16::from_le_bytes([v[2], v[3]]),
    );
    Ok((
        CatalogEntry::new(file, &h, version, meta.len(), file_sha),
        stamp,
    ))
}

/// The sealed check of the table whose first bytes `first` were read from `rest` (`len` bytes
/// in all), the file's first 16 bytes and the whole file's SHA-256 (hex), hashed on a second
/// thread as the bytes are read.
fn stream_sealed(
    first: Vec<u8>,
    rest: std::fs::File,
    len: u64,
    p: &Path,
) -> (Result<crate::table::Header, TableError>, Vec<u8>, String) {
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(4);
    std::thread::scope(|s| {
        let hasher = s.spawn(move || {
            let mut h = Sha256::new();
            for chunk in rx {
                h.update(&chunk);
            }
            hex::encode(h.finalize())
        });
        let tee = Tee {
            inner: std::io::Cursor::new(first).chain(rest),
            tx,
            preamble: Vec::new(),
        };
        let mut r = std::io::BufReader::with_capacity(1 << 20, tee);
        let sealed = crate::table::verify_sealed_stream(&mut r, len, p);
        let Tee { preamble, tx, .. } = r.into_inner();
        drop(tx);
        (sealed, preamble, hasher.join().expect("the hashing thread"))
    })
}

/// A reader that hands a copy of every chunk it reads to a channel and keeps the first 16
/// bytes (the preamble up to the header length).
struct Tee<R> {
    inner: R,
    tx: std::sync::mpsc::SyncSender<Vec<u8>>,
    preamble: Vec<u8>,
}

impl<R: Read> Read for Tee<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        let keep = (16 - self.preamble.len().min(16)).min(n);
        self.preamble.extend_from_slice(&buf[..keep]);
        if n > 0 {
            // The hashing thread ends only when this reader is dropped.
            let _ = self.tx.send(buf[..n].to_vec());
        }
        Ok(n)
    }
}

/// Write `<dir>/index.json`, then the stamps of its files beside it ([`STAMPS_FILE`]).
fn write_catalog(
    dir: &Path,
    catalog: &Catalog,
    stamps: std::collections::BTreeMap<String, StampRecord>,
) -> Result<(), CatalogError> {
    let json_error = |path: &Path| {
        let path = path.to_path_buf();
        move |source| CatalogError::Json { path, source }
    };
    let index = dir.join("index.json");
    let mut json = serde_json::to_vec_pretty(catalog).map_err(json_error(&index))?;
    json.push(b'\n');
    write_atomic(&index, &json).map_err(IoError::doing("writing", &index))?;
    // After the catalog: a crash between the two leaves stamps whose SHA-256 no longer match
    // the changed entries, which are then read again.
    let stamps_path = dir.join(STAMPS_FILE);
    let stamps = Stamps {
        format: catalog.format.clone(),
        files: stamps,
    };
    let json = serde_json::to_vec(&stamps).map_err(json_error(&stamps_path))?;
    write_atomic(&stamps_path, &json).map_err(IoError::doing("writing", &stamps_path))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::henyey_greenstein_table;
    use crate::table::write_table_atomic_sealed;

    /// The catalog of `dir` from reading every table (none listed from an earlier catalog).
    fn full_read(dir: &Path) -> Catalog {
        let all = rebuild_reading_all(dir).unwrap();
        let _ = std::fs::remove_file(dir.join(STAMPS_FILE));
        assert_eq!(rebuild(dir).unwrap(), all);
        all
    }

    /// A fresh table's entry is the entry a full read of the file gives; once the file at its
    /// path is another (a concurrent build replaced it), the file is read instead.
    #[test]
    fn a_huge_non_table_is_refused_from_its_magic() {
        let dir = tempfile::tempdir().unwrap();
        // 3 GiB of zeros, sparse on disk: listed as invalid from its first 8 bytes (reading it
        // whole, as the catalog did, would take 3 GiB of memory)
        let f = std::fs::File::create(dir.path().join("zeros.sbt")).unwrap();
        f.set_len(3 << 30).unwrap();
        std::fs::write(dir.path().join("short.sbt"), b"SBT").unwrap();
        let c = rebuild(dir.path()).unwrap();
        assert!(c.tables.is_empty());
        assert_eq!(c.invalid.len(), 2, "{:?}", c.invalid);
        for (file, why) in &c.invalid {
            assert!(
                why.contains("magic") || why.contains("truncated"),
                "{file}: {why}"
            );
        }
        assert!(
            c.invalid
                .iter()
                .any(|(f, w)| f == "zeros.sbt" && w.contains("magic"))
        );
    }

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
        let read = full_read(dir.path());
        assert_eq!(listed, read);
        assert_eq!(read.tables.len(), 1);
        assert_eq!(read.tables[0].format_version, "1.0");
        assert_eq!(
            read.tables[0].sha256,
            hex::encode(Sha256::digest(std::fs::read(&path).unwrap()))
        );
        // Replaced by another table under the same name: the stale fresh entry is not used.
        let mut other = henyey_greenstein_table(&[500.0], &[2.0], |_, _| 0.7, 19, 0.1);
        write_table_atomic_sealed(&mut other, &path).unwrap();
        let listed = rebuild_with(dir.path(), &fresh).unwrap();
        assert_eq!(listed, full_read(dir.path()));
        assert_ne!(listed.tables[0].sha256, fresh[0].entry.sha256);
    }

    /// A rebuild lists the files the catalog already lists with their current stamps from the
    /// catalog, and reads the others: a table replaced under its name, a file changed in place
    /// (bytes overwritten: it is listed as invalid), a new table. The result equals a full read
    /// after each change.
    #[test]
    fn a_rebuild_reads_only_the_files_changed_since_the_catalog() {
        use std::io::{Seek, SeekFrom, Write};
        let dir = tempfile::tempdir().unwrap();
        let table = |name: &str, g: f64| {
            let mut t = henyey_greenstein_table(&[450.0], &[1.0], move |_, _| g, 19, 0.1);
            write_table_atomic_sealed(&mut t, &dir.path().join(name)).unwrap();
        };
        table("a.sbt", 0.3);
        table("b.sbt", 0.5);
        let first = rebuild(dir.path()).unwrap();
        assert_eq!(first.tables.len(), 2);
        // Unchanged files: listed from the catalog, which is the full read's.
        assert_eq!(rebuild(dir.path()).unwrap(), first);
        let listed = Listed::load(dir.path());
        assert!(listed.unchanged(&dir.path().join("a.sbt")).is_some());

        // Replaced (a new inode), and a new file: both read.
        table("a.sbt", 0.7);
        table("c.sbt", 0.1);
        assert!(listed.unchanged(&dir.path().join("a.sbt")).is_none());
        let second = rebuild(dir.path()).unwrap();
        assert_eq!(second.tables.len(), 3);
        assert_ne!(second.tables[0].sha256, first.tables[0].sha256);
        assert_eq!(second.tables[1], first.tables[1]);
        assert_eq!(second, full_read(dir.path()));
        let second = rebuild(dir.path()).unwrap();

        // Overwritten in place, same size: the modification time moves, the file is read and
        // found corrupt. (Sleep past the file system's timestamp granularity.)
        std::thread::sleep(std::time::Duration::from_millis(20));
        let b = dir.path().join("b.sbt");
        let len = std::fs::metadata(&b).unwrap().len();
        let mut f = std::fs::OpenOptions::new().write(true).open(&b).unwrap();
        f.seek(SeekFrom::Start(len - 4)).unwrap();
        f.write_all(&[0xff; 4]).unwrap();
        drop(f);
        let third = rebuild(dir.path()).unwrap();
        assert_eq!(third.tables.len(), 2, "{third:?}");
        assert_eq!(third.invalid.len(), 1);
        assert_eq!(third.invalid[0].0, "b.sbt");
        assert_eq!(third, full_read(dir.path()));
        assert_eq!(second.tables[0], third.tables[0]);

        // Bytes overwritten with the modification time set back: the status change time
        // moved (no user can set it back), so the file is read again and found corrupt.
        let c = dir.path().join("c.sbt");
        let meta = std::fs::metadata(&c).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        let mut f = std::fs::OpenOptions::new().write(true).open(&c).unwrap();
        f.seek(SeekFrom::Start(meta.len() - 4)).unwrap();
        f.write_all(&[0xff; 4]).unwrap();
        f.set_modified(meta.modified().unwrap()).unwrap();
        drop(f);
        assert!(Listed::load(dir.path()).unchanged(&c).is_none());
        let fourth = rebuild(dir.path()).unwrap();
        assert_eq!(fourth.invalid.len(), 2, "{fourth:?}");
        assert_eq!(fourth, full_read(dir.path()));

        // Stamps that are not JSON, or whose SHA-256 is not the entry's, are not used.
        std::fs::write(dir.path().join(STAMPS_FILE), b"{not json").unwrap();
        assert!(Listed::load(dir.path()).entries.is_empty());
        rebuild(dir.path()).unwrap();
        let stamps_path = dir.path().join(STAMPS_FILE);
        let edited = std::fs::read_to_string(&stamps_path)
            .unwrap()
            .replace(&third.tables[0].sha256, &"0".repeat(64));
        std::fs::write(&stamps_path, edited).unwrap();
        let listed = Listed::load(dir.path());
        assert!(listed.unchanged(&dir.path().join("a.sbt")).is_none());
        std::fs::write(dir.path().join("index.json"), b"{not json").unwrap();
        assert!(Listed::load(dir.path()).entries.is_empty());
        assert_eq!(rebuild(dir.path()).unwrap().invalid.len(), 2);
    }
}
