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

use super::{Header, Layout, PayloadInfo, Provenance, Table, TableContent};
use sha2::{Digest, Sha256};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// File magic.
pub const MAGIC: [u8; 8] = *b"SBTABLE\0";
/// Format major version written by this build. Readers refuse a newer major.
pub const FORMAT_MAJOR: u16 = 1;
/// Format minor version written by this build. Readers accept any minor of a known major and
/// ignore the header fields a newer minor adds.
pub const FORMAT_MINOR: u16 = 0;
const PREAMBLE: usize = 56;
/// Upper bound on a header, so a corrupt length cannot make us allocate absurdly.
const MAX_HEADER_BYTES: u64 = 256 << 20;
/// Upper bound on an uncompressed payload (16 GiB).
const MAX_PAYLOAD_BYTES: u64 = 16 << 30;

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
        "{path}: table format version {major}.{minor} is newer than this reader (supports {FORMAT_MAJOR}.x); upgrade scatterbake"
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
    #[error("table content is inconsistent: {0}")]
    Inconsistent(String),
}

fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// zstd level of every payload.
const ZSTD_LEVEL: i32 = 9;
/// Payloads above this many bytes are compressed by [`ZSTD_WORKERS`] zstd worker threads.
const MULTITHREAD_PAYLOAD_BYTES: usize = 64 << 20;
/// A fixed worker count, so the compressed bytes do not depend on the machine.
const ZSTD_WORKERS: u32 = 2;
/// Values converted to little-endian bytes per step of the streaming compressor (1 MiB).
const PAYLOAD_CHUNK_VALUES: usize = 1 << 18;

/// One zstd frame of `data` as f32 LE, streamed in chunks (no full byte copy of the payload),
/// with the uncompressed size and SHA-256.
fn compress_payload(data: &[f32]) -> Result<(Vec<u8>, u64, String), TableError> {
    let err = |e: std::io::Error| TableError::Inconsistent(e.to_string());
    let raw_len = std::mem::size_of_val(data);
    let mut enc = zstd::stream::Encoder::new(Vec::new(), ZSTD_LEVEL).map_err(err)?;
    enc.include_checksum(true)
        .and_then(|_| enc.include_contentsize(true))
        .and_then(|_| enc.set_pledged_src_size(Some(raw_len as u64)))
        .map_err(err)?;
    if raw_len > MULTITHREAD_PAYLOAD_BYTES {
        enc.multithread(ZSTD_WORKERS).map_err(err)?;
    }
    let mut sha = Sha256::new();
    let mut buf = Vec::with_capacity(PAYLOAD_CHUNK_VALUES * 4);
    for chunk in data.chunks(PAYLOAD_CHUNK_VALUES) {
        buf.clear();
        buf.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
        sha.update(&buf);
        enc.write_all(&buf).map_err(err)?;
    }
    let compressed = enc.finish().map_err(err)?;
    Ok((compressed, raw_len as u64, hex::encode(sha.finalize())))
}

impl Table {
    /// Build a table from stage content and provenance (computes layout and checksums on write).
    pub fn from_content(content: TableContent, provenance: Provenance) -> Result<Self, TableError> {
        if content.axes.is_empty() {
            return Err(TableError::Inconsistent(
                "a table needs at least one axis".into(),
            ));
        }
        if content.channels.is_empty() {
            return Err(TableError::Inconsistent(
                "a table needs at least one channel".into(),
            ));
        }
        for a in &content.axes {
            if a.is_empty() {
                return Err(TableError::Inconsistent(format!(
                    "axis `{}` is empty",
                    a.name
                )));
            }
            let c = a.coords();
            if c.windows(2).any(|w| w[1] <= w[0] || !w[1].is_finite()) || !c[0].is_finite() {
                return Err(TableError::Inconsistent(format!(
                    "axis `{}` is not strictly increasing and finite",
                    a.name
                )));
            }
        }
        if content.data.len() != content.expected_len() {
            return Err(TableError::Inconsistent(format!(
                "data has {} values, axes × channels imply {}",
                content.data.len(),
                content.expected_len()
            )));
        }
        let mut shape: Vec<usize> = content.axes.iter().map(|a| a.len()).collect();
        shape.push(content.channels.len());
        let mut axis_order: Vec<String> = content.axes.iter().map(|a| a.name.clone()).collect();
        axis_order.push("channel".into());
        let header = Header {
            schema: content.schema,
            description: content.description,
            axes: content.axes,
            channels: content.channels,
            layout: Layout {
                order: "row-major".into(),
                axis_order,
                dtype: "f32le".into(),
                shape,
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
        Ok(Table {
            header,
            data: content.data,
        })
    }

    /// Serialise to the exact file bytes (fills in the payload section of the header).
    pub fn to_bytes(&mut self) -> Result<Vec<u8>, TableError> {
        let (compressed, uncompressed_bytes, sha_raw) = compress_payload(&self.data)?;
        self.header.payload = PayloadInfo {
            compression: "zstd".into(),
            compressed_bytes: compressed.len() as u64,
            uncompressed_bytes,
            sha256_compressed: sha256_hex(&compressed),
            sha256_uncompressed: sha_raw,
        };
        let header_json = serde_json::to_vec_pretty(&self.header)
            .map_err(|e| TableError::Inconsistent(e.to_string()))?;
        let mut out = Vec::with_capacity(PREAMBLE + header_json.len() + compressed.len());
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_MAJOR.to_le_bytes());
        out.extend_from_slice(&FORMAT_MINOR.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&(header_json.len() as u64).to_le_bytes());
        let mut h = Sha256::new();
        h.update(&out[..24]);
        h.update(&header_json);
        out.extend_from_slice(&h.finalize());
        out.extend_from_slice(&header_json);
        out.extend_from_slice(&compressed);
        Ok(out)
    }

    /// Open and fully verify a table (header checksum, payload checksums, sizes).
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TableError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| TableError::Io {
            path: path.into(),
            source,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Parse and fully verify table bytes; `path` is only used in error messages.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, TableError> {
        let header = parse_header(bytes, path)?;
        let start = PREAMBLE + header_len(bytes) as usize;
        let p = &header.payload;
        let end = start as u64 + p.compressed_bytes;
        if (bytes.len() as u64) < end {
            return Err(TableError::Truncated {
                path: path.into(),
                what: format!(
                    "payload needs {} bytes, {} present",
                    p.compressed_bytes,
                    bytes.len() - start
                ),
            });
        }
        if (bytes.len() as u64) > end {
            return Err(TableError::TrailingBytes {
                path: path.into(),
                extra: bytes.len() as u64 - end,
            });
        }
        let compressed = &bytes[start..end as usize];
        if sha256_hex(compressed) != p.sha256_compressed {
            return Err(TableError::PayloadChecksum {
                path: path.into(),
                which: "compressed",
            });
        }
        if p.uncompressed_bytes > MAX_PAYLOAD_BYTES {
            return Err(TableError::BadHeader {
                path: path.into(),
                message: format!(
                    "payload of {} bytes is implausibly large",
                    p.uncompressed_bytes
                ),
            });
        }
        // The capacity is only a hint (bounded), so a crafted size cannot force a huge allocation
        // before decompression proves the data exists.
        let mut raw = Vec::with_capacity(
            p.uncompressed_bytes
                .min(p.compressed_bytes.saturating_mul(64)) as usize,
        );
        zstd::stream::Decoder::new(compressed)
            .and_then(|d| d.take(p.uncompressed_bytes + 1).read_to_end(&mut raw))
            .map_err(|e| TableError::Decompress {
                path: path.into(),
                message: e.to_string(),
            })?;
        if raw.len() as u64 != p.uncompressed_bytes {
            return Err(TableError::Decompress {
                path: path.into(),
                message: format!(
                    "payload decompresses to {} bytes, header says {}",
                    raw.len(),
                    p.uncompressed_bytes
                ),
            });
        }
        if sha256_hex(&raw) != p.sha256_uncompressed {
            return Err(TableError::PayloadChecksum {
                path: path.into(),
                which: "uncompressed",
            });
        }
        let data = raw
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Ok(Table { header, data })
    }
}

fn header_len(bytes: &[u8]) -> u64 {
    u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"))
}

/// Parse and verify the preamble and header (not the payload).
fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, TableError> {
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        return Err(TableError::BadMagic {
            path: path.into(),
            found: bytes[..bytes.len().min(8)].to_vec(),
        });
    }
    if bytes.len() < PREAMBLE {
        return Err(TableError::Truncated {
            path: path.into(),
            what: format!(
                "{} bytes, shorter than the {PREAMBLE}-byte preamble",
                bytes.len()
            ),
        });
    }
    let major = u16::from_le_bytes([bytes[8], bytes[9]]);
    let minor = u16::from_le_bytes([bytes[10], bytes[11]]);
    if major > FORMAT_MAJOR {
        return Err(TableError::NewerMajor {
            path: path.into(),
            major,
            minor,
        });
    }
    if major == 0 {
        return Err(TableError::BadHeader {
            path: path.into(),
            message: "format major version 0 does not exist".into(),
        });
    }
    let hlen = header_len(bytes);
    if hlen > MAX_HEADER_BYTES || (PREAMBLE as u64 + hlen) > bytes.len() as u64 {
        return Err(TableError::Truncated {
            path: path.into(),
            what: format!(
                "header needs {hlen} bytes, {} present",
                bytes.len() - PREAMBLE
            ),
        });
    }
    let header_bytes = &bytes[PREAMBLE..PREAMBLE + hlen as usize];
    let mut h = Sha256::new();
    h.update(&bytes[..24]);
    h.update(header_bytes);
    if h.finalize().as_slice() != &bytes[24..56] {
        return Err(TableError::HeaderChecksum { path: path.into() });
    }
    let header: Header =
        serde_json::from_slice(header_bytes).map_err(|e| TableError::BadHeader {
            path: path.into(),
            message: e.to_string(),
        })?;
    // Fields of a newer minor are ignored; a file of a minor this reader implements has exactly
    // the fields of that version.
    let newer_minor = minor > FORMAT_MINOR;
    if !newer_minor {
        reject_unknown_fields(header_bytes, major, minor).map_err(|message| {
            TableError::BadHeader {
                path: path.into(),
                message,
            }
        })?;
    }
    validate_header(&header).map_err(|message| TableError::BadHeader {
        path: path.into(),
        message,
    })?;
    Ok(header)
}

/// Top-level header fields of format 1.0 (the fields of [`Header`]).
const HEADER_FIELDS: [&str; 8] = [
    "schema",
    "description",
    "axes",
    "channels",
    "layout",
    "attributes",
    "provenance",
    "payload",
];

fn reject_unknown_fields(header_bytes: &[u8], major: u16, minor: u16) -> Result<(), String> {
    let fields: std::collections::BTreeMap<String, serde::de::IgnoredAny> =
        serde_json::from_slice(header_bytes).map_err(|e| e.to_string())?;
    match fields.keys().find(|k| !HEADER_FIELDS.contains(&k.as_str())) {
        Some(k) => Err(format!(
            "unknown field `{k}` in a format {major}.{minor} header (only a newer minor version \
             may add fields)"
        )),
        None => Ok(()),
    }
}

fn validate_header(h: &Header) -> Result<(), String> {
    if h.layout.order != "row-major" || h.layout.dtype != "f32le" {
        return Err(format!(
            "unsupported layout {} / {}",
            h.layout.order, h.layout.dtype
        ));
    }
    if h.payload.compression != "zstd" {
        return Err(format!(
            "unsupported compression `{}`",
            h.payload.compression
        ));
    }
    let mut shape: Vec<usize> = h.axes.iter().map(|a| a.len()).collect();
    shape.push(h.channels.len());
    if shape != h.layout.shape {
        return Err(format!(
            "layout shape {:?} disagrees with axes/channels {:?}",
            h.layout.shape, shape
        ));
    }
    let n = shape
        .iter()
        .try_fold(1u64, |acc, &s| acc.checked_mul(s as u64))
        .ok_or("shape overflows")?;
    if n.checked_mul(4) != Some(h.payload.uncompressed_bytes) {
        return Err(format!(
            "shape {:?} implies {} bytes, payload says {}",
            shape,
            n * 4,
            h.payload.uncompressed_bytes
        ));
    }
    Ok(())
}

/// Read and verify only the preamble and header of a table (cheap; used for resume checks and
/// the catalog). The payload is not checked.
pub fn read_header_only(path: &Path) -> Result<Header, TableError> {
    let io = |source| TableError::Io {
        path: path.into(),
        source,
    };
    let mut f = std::fs::File::open(path).map_err(io)?;
    let mut pre = vec![0u8; PREAMBLE];
    let n = read_up_to(&mut f, &mut pre).map_err(io)?;
    pre.truncate(n);
    if n < PREAMBLE {
        return parse_header(&pre, path);
    }
    let hlen = header_len(&pre).min(MAX_HEADER_BYTES + 1);
    let mut rest = vec![0u8; hlen as usize];
    let m = read_up_to(&mut f, &mut rest).map_err(io)?;
    rest.truncate(m);
    pre.extend_from_slice(&rest);
    parse_header(&pre, path)
}

fn read_up_to(f: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        let n = f.read(&mut buf[got..])?;
        if n == 0 {
            break;
        }
        got += n;
    }
    Ok(got)
}

/// Write `bytes` to `path` atomically: a temporary file in the same directory, fsync, rename,
/// fsync of the directory. A crash at any point leaves either the old file or the new one under
/// `path`, never a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
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
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Shipped tables are world-readable like any other build output.
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Serialise and write a table atomically. Returns the bytes written (for catalogues).
pub fn write_table_atomic(table: &mut Table, path: &Path) -> Result<u64, TableError> {
    let bytes = table.to_bytes()?;
    write_atomic(path, &bytes).map_err(|source| TableError::Io {
        path: path.into(),
        source,
    })?;
    Ok(bytes.len() as u64)
}
