//! Byte-level reading, writing and verification of `.sbt` files. See `docs/table-format.md`.
//!
//! ```text
//! offset  size  field
//! 0       8     magic  "SBTABLE\0"
//! 8       2     format major (u16 LE)
//! 10      2     format minor (u16 LE)
//! 12      4     flags (u32 LE, 0 in v1.0)
//! 16      8     header length H in bytes (u64 LE)
//! 24      32    SHA-256 of bytes [0, 24) followed by the H header bytes
//! 56      H     header: UTF-8 JSON object
//! 56+H    C     payload: one zstd frame (C = header.payload.compressed_bytes)
//! ```
//! The file ends exactly after the payload.

use crate::codec::{DTYPE_F32, DTYPE_TOP16, PREVIOUS_ROW, Storage, storage_of};
use crate::model::{
    Header, Layout, PayloadInfo, Predictor, Provenance, Table, TableContent, ValueEncoding,
};
use crate::validate::{check_axis_coords, check_axis_count, check_symmetry};
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::{Path, PathBuf};

/// File magic.
pub const MAGIC: [u8; 8] = *b"SBTABLE\0";
/// Newest format major version this build reads and writes (it reads 1.x, 2.x and 3.x; it
/// writes 1.0, 2.0 for a table whose values are 16-bit codes or that has derived channels, and
/// 3.0 for a table with a symmetric axis). Readers refuse a newer major.
pub const FORMAT_MAJOR: u16 = 3;
/// Format minor version written by this build. Readers accept any minor of a known major and
/// ignore the header fields a newer minor adds.
pub const FORMAT_MINOR: u16 = 0;
pub(crate) const PREAMBLE: usize = 56;

/// Everything that can be wrong with a table file.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a scatterbake table (bad magic bytes {found:02x?})")]
    BadMagic { path: PathBuf, found: Vec<u8> },
    #[error("{path}: file truncated: {what}")]
    Truncated { path: PathBuf, what: String },
    #[error(
        "{path}: table format version {major}.{minor} is newer than this reader (supports 1.x to {FORMAT_MAJOR}.x); upgrade scatterbake"
    )]
    NewerMajor {
        path: PathBuf,
        major: u16,
        minor: u16,
    },
    #[error("{path}: header checksum mismatch (file is corrupt)")]
    HeaderChecksum { path: PathBuf },
    #[error("{path}: header is not valid: {message}")]
    BadHeader { path: PathBuf, message: String },
    #[error("{path}: payload {which} checksum mismatch (file is corrupt)")]
    PayloadChecksum { path: PathBuf, which: &'static str },
    #[error("{path}: payload cannot be decompressed: {message}")]
    Decompress { path: PathBuf, message: String },
    #[error("{path}: {extra} unexpected bytes after the payload")]
    TrailingBytes { path: PathBuf, extra: u64 },
    #[error("{path}: {message}")]
    Limit { path: PathBuf, message: String },
    #[error("{path}: cannot open the entry: {message}")]
    Entry { path: PathBuf, message: String },
    #[error("table content is inconsistent: {0}")]
    Inconsistent(String),
    #[error("{path}: tensor-train table is not valid: {message}")]
    TensorTrain { path: PathBuf, message: String },
    #[error("{path}: payload value is not valid: {message}")]
    BadValue { path: PathBuf, message: String },
}

/// zstd level of payloads up to [`MULTITHREAD_PAYLOAD_BYTES`].
const ZSTD_LEVEL: i32 = 9;
/// zstd level of larger payloads. Measured on a 1.14 GB seed-resolution ray-traced table with
/// the zstd command line (`zstd -b1 -e9 -T2`): level 9 compresses at 174 MB/s to 84.6 MB,
/// level 3 at 800 MB/s to 91.7 MB (+8 %), so level 3 saves ~5 s of CPU per such table for
/// 8 % of disk. On a later seed table (`zstd -b1 -e4 -T2`): level 1 at 1447 MB/s to 173.9 MB,
/// level 3 at 1057 MB/s to 174.3 MB; level 1 is faster and no larger (the seed build's table:
/// 168 MB at level 1, 170 MB at level 3).
const ZSTD_LEVEL_LARGE: i32 = 1;
/// zstd level of larger payloads whose samples compress to within
/// [`FAST_LEVEL_MAX_SIZE_RATIO`] of [`ZSTD_LEVEL_LARGE`]'s size at it: where a payload
/// compresses through repeated values, the fast level finds the same matches and costs no disk;
/// where it compresses through the entropy coding of level 1 (noisy values, long runs of
/// zeros between them), level 1 stays. Measured with the zstd command line (one thread) on
/// two seed-resolution ray-traced payloads: the four contract channels (415 MB) at level 1 in
/// 1.05 s to 277.8 MB, at level −1 in 0.72 s to 273.3 MB; eleven channels (1.14 GB, the
/// per-order channels mostly zeros) at level 1 in 2.49 s to 356.0 MB, at level −1 in 1.90 s to
/// 419.3 MB (+18 %: level 1 kept).
const ZSTD_LEVEL_FAST: i32 = -1;
/// See [`ZSTD_LEVEL_FAST`].
const FAST_LEVEL_MAX_SIZE_RATIO: f64 = 1.03;
/// Samples taken by [`large_payload_level`]: this many slices of [`LEVEL_SAMPLE_VALUES`] values,
/// spread evenly over the payload.
const LEVEL_SAMPLES: usize = 4;
const LEVEL_SAMPLE_VALUES: usize = 1 << 20;
/// Payloads above this many bytes are compressed by [`ZSTD_WORKERS`] zstd worker threads at
/// [`ZSTD_LEVEL_LARGE`].
const MULTITHREAD_PAYLOAD_BYTES: usize = 64 << 20;
/// A fixed worker count, so the compressed bytes do not depend on the machine.
const ZSTD_WORKERS: u32 = 2;
/// Values converted to little-endian bytes per step of the streaming compressor (1 MiB).
const PAYLOAD_CHUNK_VALUES: usize = 1 << 18;

/// `f` of the little-endian bytes of `data`, chunk by chunk: the values' own bytes on a
/// little-endian target (no copy), converted chunk by chunk elsewhere.
fn for_each_le_chunk<E>(data: &[f32], mut f: impl FnMut(&[u8]) -> Result<(), E>) -> Result<(), E> {
    // Used only on big-endian targets, where the values are converted chunk by chunk.
    let mut buf = Vec::new();
    for chunk in data.chunks(PAYLOAD_CHUNK_VALUES) {
        let bytes: &[u8] = if cfg!(target_endian = "little") {
            // SAFETY: an `f32` is 4 plain bytes with no padding or invalid bit patterns as
            // `u8`, `u8` has alignment 1, and the length covers exactly the chunk's values; on
            // a little-endian target these are the values' LE bytes, without a copy.
            unsafe { std::slice::from_raw_parts(chunk.as_ptr().cast::<u8>(), chunk.len() * 4) }
        } else {
            buf.clear();
            buf.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
            &buf
        };
        f(bytes)?;
    }
    Ok(())
}

/// zstd level of a payload above [`MULTITHREAD_PAYLOAD_BYTES`]: [`ZSTD_LEVEL_FAST`] when
/// samples of it compress at that level to at most [`FAST_LEVEL_MAX_SIZE_RATIO`] times their
/// size at [`ZSTD_LEVEL_LARGE`], else [`ZSTD_LEVEL_LARGE`]. Depends on the values only, so the
/// same table always gets the same bytes. The samples (16 MiB) cost ≈ 0.05 s.
fn large_payload_level(data: &[f32]) -> Result<i32, std::io::Error> {
    let n = LEVEL_SAMPLE_VALUES.min(data.len() / LEVEL_SAMPLES);
    let (mut fast, mut large) = (0usize, 0usize);
    for s in 0..LEVEL_SAMPLES {
        let start = (2 * s + 1) * data.len() / (2 * LEVEL_SAMPLES) - n / 2;
        let mut sample = Vec::with_capacity(4 * n);
        let Ok(()) = for_each_le_chunk::<std::convert::Infallible>(&data[start..start + n], |b| {
            sample.extend_from_slice(b);
            Ok(())
        });
        fast += zstd::bulk::compress(&sample, ZSTD_LEVEL_FAST)?.len();
        large += zstd::bulk::compress(&sample, ZSTD_LEVEL_LARGE)?.len();
    }
    Ok(if fast as f64 <= FAST_LEVEL_MAX_SIZE_RATIO * large as f64 {
        ZSTD_LEVEL_FAST
    } else {
        ZSTD_LEVEL_LARGE
    })
}

/// Work on fewer bytes than this is done on the calling thread: starting a thread costs more
/// than it saves.
const JOIN_MIN_BYTES: usize = 1 << 20;

/// `(a(), b())`, the two side by side (`b` on a scoped thread) when they work on at least
/// [`JOIN_MIN_BYTES`] bytes, one after the other otherwise. A panic in either is propagated.
fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
    bytes: usize,
) -> (A, B) {
    if bytes < JOIN_MIN_BYTES {
        return (a(), b());
    }
    std::thread::scope(|s| {
        let b = s.spawn(b);
        let a = a();
        let b = b.join().unwrap_or_else(|e| std::panic::resume_unwind(e));
        (a, b)
    })
}

/// A `Vec<u8>` sink that hashes what is written to it.
struct HashingVec {
    bytes: Vec<u8>,
    sha: Sha256,
}

impl Write for HashingVec {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.sha.update(buf);
        self.bytes.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The compressed payload of a table with the SHA-256 (hex) of its compressed and of its
/// uncompressed bytes, and its uncompressed size.
struct CompressedPayload {
    bytes: Vec<u8>,
    sha256_compressed: String,
    sha256_uncompressed: String,
    uncompressed_bytes: u64,
}

/// One zstd frame of `data` as f32 LE, streamed in chunks (no full byte copy of the payload),
/// with its checksums; the compressed bytes are hashed as the encoder emits them. The hash of
/// the uncompressed bytes and the compression run side by side
/// ([`join`]): SHA-256 of a 1.14 GB seed payload takes ≈ 1 s on one core, as long as its
/// compression, and one after the other they took 1.4 s of the build's wall time.
fn compress_payload(data: &[f32]) -> Result<CompressedPayload, TableError> {
    let err = |e: std::io::Error| TableError::Inconsistent(e.to_string());
    let raw_len = std::mem::size_of_val(data);
    let level = if raw_len > MULTITHREAD_PAYLOAD_BYTES {
        large_payload_level(data).map_err(err)?
    } else {
        ZSTD_LEVEL
    };
    compress_chunks(raw_len, level, |f| for_each_le_chunk(data, f))
}

/// [`compress_payload`] of payload bytes already encoded (16-bit codes, or the stored channels
/// of a table with derived ones): level 9, or level 1 on worker threads above
/// [`MULTITHREAD_PAYLOAD_BYTES`].
fn compress_bytes(raw: &[u8]) -> Result<CompressedPayload, TableError> {
    let level = if raw.len() > MULTITHREAD_PAYLOAD_BYTES {
        ZSTD_LEVEL_LARGE
    } else {
        ZSTD_LEVEL
    };
    compress_chunks(raw.len(), level, |f| {
        raw.chunks(4 * PAYLOAD_CHUNK_VALUES).try_for_each(f)
    })
}

/// One zstd frame of the `raw_len` bytes `each` hands out in order (it may be called twice:
/// for the hash and for the compression), at `level`, with the checksums.
fn compress_chunks(
    raw_len: usize,
    level: i32,
    each: impl Fn(&mut dyn FnMut(&[u8]) -> std::io::Result<()>) -> std::io::Result<()> + Sync,
) -> Result<CompressedPayload, TableError> {
    let err = |e: std::io::Error| TableError::Inconsistent(e.to_string());
    let large = raw_len > MULTITHREAD_PAYLOAD_BYTES;
    let compress = || -> Result<HashingVec, TableError> {
        let sink = HashingVec {
            bytes: Vec::new(),
            sha: Sha256::new(),
        };
        let mut enc = zstd::stream::Encoder::new(sink, level).map_err(err)?;
        enc.include_checksum(true)
            .and_then(|_| enc.include_contentsize(true))
            .and_then(|_| enc.set_pledged_src_size(Some(raw_len as u64)))
            .map_err(err)?;
        if large {
            enc.multithread(ZSTD_WORKERS).map_err(err)?;
        }
        each(&mut |bytes| enc.write_all(bytes)).map_err(err)?;
        enc.finish().map_err(err)
    };
    let hash = || {
        let mut sha = Sha256::new();
        each(&mut |bytes| {
            sha.update(bytes);
            Ok(())
        })
        .map(|()| hex::encode(sha.finalize()))
    };
    let (sha256_uncompressed, compressed) = join(hash, compress, raw_len);
    let (sha256_uncompressed, compressed) = (sha256_uncompressed.map_err(err)?, compressed?);
    Ok(CompressedPayload {
        bytes: compressed.bytes,
        sha256_compressed: hex::encode(compressed.sha.finalize()),
        sha256_uncompressed,
        uncompressed_bytes: raw_len as u64,
    })
}

impl Table {
    /// Build a table from stage content and provenance (computes layout and checksums on write).
    pub fn from_content(content: TableContent, provenance: Provenance) -> Result<Self, TableError> {
        check_axis_count(content.axes.len()).map_err(TableError::Inconsistent)?;
        if content.channels.is_empty() {
            return Err(TableError::Inconsistent(
                "a table needs at least one channel".into(),
            ));
        }
        for a in &content.axes {
            check_axis_coords(a)
                .and_then(|()| check_symmetry(a))
                .map_err(TableError::Inconsistent)?;
        }
        if content.data.len() != content.expected_len() {
            return Err(TableError::Inconsistent(format!(
                "data has {} values, axes × channels imply {}",
                content.data.len(),
                content.expected_len()
            )));
        }
        let n_stored = content
            .channels
            .iter()
            .filter(|c| c.derived.is_none())
            .count();
        let mut shape: Vec<usize> = content.axes.iter().map(|a| a.len()).collect();
        shape.push(n_stored);
        let mut axis_order: Vec<String> = content.axes.iter().map(|a| a.name.clone()).collect();
        axis_order.push("channel".into());
        let (dtype, predictor) = match content.encoding {
            ValueEncoding::F32 => (DTYPE_F32, None),
            ValueEncoding::Top16 { predictor } => (
                DTYPE_TOP16,
                predictor.map(|p| Predictor {
                    kind: PREVIOUS_ROW.into(),
                    stride: p.stride,
                    block: p.block,
                }),
            ),
        };
        let header = Header {
            schema: content.schema,
            description: content.description,
            axes: content.axes,
            channels: content.channels,
            layout: Layout {
                order: "row-major".into(),
                axis_order,
                dtype: dtype.into(),
                shape,
                predictor,
            },
            attributes: content.attributes,
            provenance,
            payload: PayloadInfo {
                compression: "zstd".into(),
                compressed_bytes: 0,
                uncompressed_bytes: 0,
                sha256_compressed: String::new(),
                sha256_uncompressed: String::new(),
            },
        };
        let mut data = content.data;
        let storage = storage_of(&header, FORMAT_MAJOR).map_err(TableError::Inconsistent)?;
        if !storage.is_plain() {
            // The values as every reader will return them.
            crate::codec::decoded_values(&mut data, &storage).map_err(TableError::Inconsistent)?;
        }
        Ok(Table { header, data })
    }

    /// The format version of the file this table is written as ([`Header::format_version`]).
    pub fn format_version(&self) -> (u16, u16) {
        self.header.format_version()
    }

    /// Serialise to the exact file bytes (fills in the payload section of the header).
    pub fn to_bytes(&mut self) -> Result<Vec<u8>, TableError> {
        let (mut head, compressed) = self.to_parts()?;
        head.extend_from_slice(&compressed);
        Ok(head)
    }

    /// The file's bytes in two parts, preamble and header, then the compressed payload (fills
    /// in the payload section of the header); [`Table::to_bytes`] is their concatenation.
    pub fn to_parts(&mut self) -> Result<(Vec<u8>, Vec<u8>), TableError> {
        let (major, minor) = self.format_version();
        let storage = storage_of(&self.header, major).map_err(TableError::Inconsistent)?;
        let payload = self.compressed_payload(&storage)?;
        self.header.payload = PayloadInfo {
            compression: "zstd".into(),
            compressed_bytes: payload.bytes.len() as u64,
            uncompressed_bytes: payload.uncompressed_bytes,
            sha256_compressed: payload.sha256_compressed,
            sha256_uncompressed: payload.sha256_uncompressed,
        };
        let compressed = payload.bytes;
        let header_json = serde_json::to_vec_pretty(&self.header)
            .map_err(|e| TableError::Inconsistent(e.to_string()))?;
        let mut out = Vec::with_capacity(PREAMBLE + header_json.len());
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&major.to_le_bytes());
        out.extend_from_slice(&minor.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&(header_json.len() as u64).to_le_bytes());
        let mut h = Sha256::new();
        h.update(&out[..24]);
        h.update(&header_json);
        out.extend_from_slice(&h.finalize());
        out.extend_from_slice(&header_json);
        Ok((out, compressed))
    }

    /// The payload of the table's values stored as `storage` says.
    fn compressed_payload(&self, storage: &Storage) -> Result<CompressedPayload, TableError> {
        if storage.is_plain() {
            return compress_payload(&self.data);
        }
        let n = self.header.channels.len();
        if !self.data.len().is_multiple_of(n) {
            return Err(TableError::Inconsistent(format!(
                "data has {} values, not a multiple of the {n} channels",
                self.data.len()
            )));
        }
        let raw = match storage.item_bytes {
            2 => {
                crate::codec::encode_top16(&self.data, storage).map_err(TableError::Inconsistent)?
            }
            _ => {
                let stored = self.data.chunks_exact(n).flat_map(|point| {
                    point
                        .iter()
                        .zip(&self.header.channels)
                        .filter(|(_, c)| c.derived.is_none())
                        .map(|(v, _)| *v)
                });
                stored.flat_map(f32::to_le_bytes).collect()
            }
        };
        compress_bytes(&raw)
    }
}

impl Header {
    /// The format version a table with this header is written as: 3.0 when an axis is
    /// symmetric, else 2.0 when its values are 16-bit codes or it has derived channels, else
    /// 1.0 (each the oldest version that holds the table).
    pub fn format_version(&self) -> (u16, u16) {
        let v2 = self.layout.dtype != DTYPE_F32
            || self.layout.predictor.is_some()
            || self.channels.iter().any(|c| c.derived.is_some());
        if self.axes.iter().any(|a| a.symmetry.is_some()) {
            (3, 0)
        } else if v2 {
            (2, 0)
        } else {
            (1, 0)
        }
    }
}

/// The owner part `<host>.<pid>` of the temporary file names of [`write_atomic`]
/// (`.<file name>.<host>.<pid>.<random>.tmp`): a later build on the same host can tell a file
/// that a killed process left behind from one that is being written.
pub fn temp_file_owner() -> String {
    format!("{}.{}", host_tag(), std::process::id())
}

/// This host's name with only ASCII letters, digits and `-` kept ("host" when unknown).
pub fn host_tag() -> String {
    static TAG: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TAG.get_or_init(|| {
        let raw = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
        let tag: String = raw
            .trim()
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        if tag.is_empty() { "host".into() } else { tag }
    })
    .clone()
}

/// Open `path` for reading only if it is a regular file (following symbolic links), for callers
/// that must not block on or stream from a file planted under a name they own (the build's
/// output directory); the table reader itself accepts any readable file and refuses a non-table
/// from its first 8 bytes (`docs/table-format.md`). A FIFO, a
/// socket, a device or a directory is refused with an `InvalidInput` error naming what it is,
/// without blocking (the file is opened non-blocking, so opening a FIFO that has no writer
/// returns at once) and without reading a byte (a link to `/dev/zero` is refused, not read
/// until memory runs out). The check is made on the opened file, so it cannot be raced.
pub fn open_regular(path: &Path) -> std::io::Result<std::fs::File> {
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let f = opts.open(path)?;
    let kind = f.metadata()?.file_type();
    if kind.is_file() {
        return Ok(f);
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("not a regular file ({})", file_kind(&kind)),
    ))
}

/// The whole of the regular file at `path` ([`open_regular`]).
pub fn read_regular(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    open_regular(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// What a file that is not a regular file is, in words.
fn file_kind(kind: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO";
        }
        if kind.is_socket() {
            return "a socket";
        }
        if kind.is_char_device() || kind.is_block_device() {
            return "a device";
        }
    }
    if kind.is_dir() {
        "a directory"
    } else {
        "not a file"
    }
}

/// Write `bytes` to `path` atomically: a temporary file in the same directory, fsync, rename,
/// fsync of the directory. A crash at any point leaves either the old file or the new one under
/// `path`, never a partial file; the temporary file a crash leaves is named after its host and
/// process ([`temp_file_owner`]) so that the next build removes it.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_parts(path, &[bytes])
}

/// [`write_atomic`] of the concatenation of `parts`, without concatenating them in memory.
pub fn write_atomic_parts(path: &Path, parts: &[&[u8]]) -> std::io::Result<()> {
    write_atomic_parts_stamped(path, parts).map(|_| ())
}

/// Identity of a written file: size, modification time and (on Unix) device, inode and status
/// change time, as the file had them once renamed into place. A file found at the path later
/// with the same stamp is that file, unchanged: writing into a file in place moves its status
/// change time, which (unlike the modification time) no user can set back. Serialised in the
/// catalog's stamps file, `scatterbake::catalog::STAMPS_FILE` (times as seconds and nanoseconds
/// since the Unix epoch).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FileStamp {
    len: u64,
    modified: Option<(u64, u32)>,
    #[cfg(unix)]
    dev_ino: (u64, u64),
    #[cfg(unix)]
    changed: (i64, i64),
}

impl FileStamp {
    /// The stamp of `meta`.
    pub fn of(meta: &std::fs::Metadata) -> Self {
        #[cfg(unix)]
        use std::os::unix::fs::MetadataExt;
        let since_epoch = |t: std::time::SystemTime| t.duration_since(std::time::UNIX_EPOCH).ok();
        FileStamp {
            len: meta.len(),
            modified: meta
                .modified()
                .ok()
                .and_then(since_epoch)
                .map(|d| (d.as_secs(), d.subsec_nanos())),
            #[cfg(unix)]
            dev_ino: (meta.dev(), meta.ino()),
            #[cfg(unix)]
            changed: (meta.ctime(), meta.ctime_nsec()),
        }
    }

    /// Whether the stamp identifies a file: it has a modification time (a file system without
    /// one gives stamps that would match any file of the same size).
    pub fn identifies(&self) -> bool {
        self.modified.is_some()
    }
}

/// [`write_atomic_parts`], returning the stamp of the file it renamed into place.
pub fn write_atomic_parts_stamped(path: &Path, parts: &[&[u8]]) -> std::io::Result<FileStamp> {
    write_atomic_streamed(path, |w| {
        parts.iter().try_for_each(|part| w.write_all(part))
    })
}

/// [`write_atomic`] of what `write` writes (through a buffer), without holding it in memory;
/// returns the stamp of the file it renamed into place. An error from `write` leaves no file
/// (the temporary one is removed) and the file at `path`, if any, unchanged.
pub fn write_atomic_streamed(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> std::io::Result<FileStamp> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "table".into());
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}.{}.", temp_file_owner()))
        .suffix(".tmp")
        .tempfile_in(dir)?;
    {
        let mut buffered = std::io::BufWriter::with_capacity(1 << 20, tmp.as_file_mut());
        write(&mut buffered)?;
        buffered.flush()?;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Shipped tables are world-readable like any other build output.
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.as_file().sync_all()?;
    // Stamped once in place (a rename moves the status change time), from the open file: the
    // inode renamed, whatever the path holds by then.
    let file = tmp.persist(path).map_err(|e| e.error)?;
    let stamp = FileStamp::of(&file.metadata()?);
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(stamp)
}

/// Serialise and write a table atomically. Returns the bytes written (for catalogues).
pub fn write_table_atomic(table: &mut Table, path: &Path) -> Result<u64, TableError> {
    write_table_atomic_sealed(table, path).map(|w| w.size_bytes)
}

/// A table file just written by [`write_table_atomic_sealed`].
#[derive(Debug, Clone)]
pub struct WrittenTable {
    /// File size in bytes.
    pub size_bytes: u64,
    /// SHA-256 (hex) of the whole file.
    pub file_sha256: String,
    /// The file's identity when it was renamed into place.
    pub stamp: FileStamp,
}

/// [`write_table_atomic`], also returning the SHA-256 of the whole file (hashed beside the
/// write and its `fsync`, from the bytes in memory) and the file's stamp, so that a catalog can
/// list the table without reading it back.
pub fn write_table_atomic_sealed(
    table: &mut Table,
    path: &Path,
) -> Result<WrittenTable, TableError> {
    let (head, payload) = table.to_parts()?;
    let (stamp, file_sha256) = join(
        || write_atomic_parts_stamped(path, &[&head, &payload]),
        || {
            let mut h = Sha256::new();
            h.update(&head);
            h.update(&payload);
            hex::encode(h.finalize())
        },
        head.len() + payload.len(),
    );
    let stamp = stamp.map_err(|source| TableError::Io {
        path: path.into(),
        source,
    })?;
    Ok(WrittenTable {
        size_bytes: (head.len() + payload.len()) as u64,
        file_sha256,
        stamp,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values that compress through repeats (each repeated four times, as neighbouring
    /// directions of a ray-traced table often are) take the fast level, which finds the same
    /// matches; noisy values, which only the entropy coding of level 1 shrinks, keep level 1.
    #[test]
    fn large_payloads_take_the_fast_level_only_where_it_costs_no_disk() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let noisy: Vec<f32> = (0..1 << 21)
            .map(|_| 1e-3 * (1.0 + (next() >> 40) as f32 / (1u64 << 24) as f32))
            .collect();
        assert_eq!(large_payload_level(&noisy).unwrap(), ZSTD_LEVEL_LARGE);
        let repeated: Vec<f32> = (0..noisy.len()).map(|i| noisy[i / 4]).collect();
        assert_eq!(large_payload_level(&repeated).unwrap(), ZSTD_LEVEL_FAST);
    }
}
