//! Reading and verification of `.sbt` files (see `docs/table-format.md`, "Reading and
//! verification"). The file is streamed: the magic is checked from the first 8 bytes, the
//! header is read only after its declared length is checked against the limit and the file
//! size, and the payload is decompressed in fixed-size chunks, so memory is bounded by the data
//! actually present (and by [`ReadLimits`]), never by a size the file declares.

pub use crate::validate::MAX_AXES;

use crate::codec::{PayloadDecoder, Storage, storage_of};
use crate::entry::{entry_header, entry_values};
use crate::format::{FORMAT_MAJOR, MAGIC, PREAMBLE, TableError};
use crate::frame::FrameWalker;
use crate::model::{AxisPoints, Header, Table};
use crate::validate::{check_axis_coords, check_axis_count, check_uniform_params};
use serde::de::{DeserializeSeed, MapAccess, SeqAccess, Visitor};
use sha2::{Digest, Sha256};
use std::fmt;
use std::io::Read;
use std::path::Path;

/// Largest header accepted (64 MiB).
pub const MAX_HEADER_BYTES: u64 = 64 << 20;
/// Default largest uncompressed payload (4 GiB); raise it with [`ReadLimits`].
pub const DEFAULT_MAX_PAYLOAD_BYTES: u64 = 4 << 30;
/// Deepest nesting of JSON arrays/objects in a header.
pub const MAX_JSON_DEPTH: usize = 64;
/// Decompression chunk (bytes); a multiple of 4.
const CHUNK: usize = 1 << 16;

/// Resource limits of a read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadLimits {
    /// Largest `payload.uncompressed_bytes` accepted (default [`DEFAULT_MAX_PAYLOAD_BYTES`]).
    pub max_payload_bytes: u64,
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits {
            max_payload_bytes: DEFAULT_MAX_PAYLOAD_BYTES,
        }
    }
}

/// Count of non-finite and negative samples per channel, gathered while verifying.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ValueStats {
    /// NaN samples per channel.
    pub nan: Vec<u64>,
    /// ±infinite samples per channel.
    pub infinite: Vec<u64>,
    /// Negative (finite, < 0) samples per channel.
    pub negative: Vec<u64>,
}

impl ValueStats {
    /// Count one sample `v` of channel `ch`.
    fn count(&mut self, ch: usize, v: f32) {
        if v.is_nan() {
            self.nan[ch] += 1;
        } else if v.is_infinite() {
            self.infinite[ch] += 1;
        } else if v < 0.0 {
            self.negative[ch] += 1;
        }
    }
}

/// Result of [`verify_file`]: the verified header and the value statistics.
#[derive(Debug, Clone)]
pub struct Verified {
    pub header: Header,
    pub values: ValueStats,
}

fn bad(path: &Path, message: impl Into<String>) -> TableError {
    TableError::BadHeader {
        path: path.into(),
        message: message.into(),
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> TableError + '_ {
    move |source| TableError::Io {
        path: path.into(),
        source,
    }
}

fn read_up_to(f: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match f.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Read exactly `n` bytes without allocating more than is actually read.
fn read_exact_vec(f: &mut impl Read, n: u64) -> std::io::Result<Vec<u8>> {
    let mut v = Vec::new();
    f.take(n).read_to_end(&mut v)?;
    Ok(v)
}

/// Preamble, header bytes and parsed header.
struct HeaderPart {
    header: Header,
    header_len: u64,
    storage: Storage,
}

fn read_header_part(
    r: &mut impl Read,
    file_len: Option<u64>,
    path: &Path,
    limits: &ReadLimits,
) -> Result<HeaderPart, TableError> {
    let mut pre = [0u8; PREAMBLE];
    let n = read_up_to(r, &mut pre[..8]).map_err(io_err(path))?;
    if n < 8 || pre[..8] != MAGIC {
        return Err(TableError::BadMagic {
            path: path.into(),
            found: pre[..n].to_vec(),
        });
    }
    let m = read_up_to(r, &mut pre[8..]).map_err(io_err(path))?;
    if m < PREAMBLE - 8 {
        return Err(TableError::Truncated {
            path: path.into(),
            what: format!("{} bytes, shorter than the {PREAMBLE}-byte preamble", 8 + m),
        });
    }
    let major = u16::from_le_bytes([pre[8], pre[9]]);
    let minor = u16::from_le_bytes([pre[10], pre[11]]);
    if major > FORMAT_MAJOR {
        return Err(TableError::NewerMajor {
            path: path.into(),
            major,
            minor,
        });
    }
    if major == 0 {
        return Err(bad(path, "format major version 0 does not exist"));
    }
    let flags = u32::from_le_bytes(pre[12..16].try_into().expect("4 bytes"));
    if flags != 0 {
        return Err(bad(
            path,
            format!("reserved flags at offset 12 are {flags:#010x}, must be 0"),
        ));
    }
    let hlen = u64::from_le_bytes(pre[16..24].try_into().expect("8 bytes"));
    if hlen > MAX_HEADER_BYTES {
        return Err(TableError::Limit {
            path: path.into(),
            message: format!(
                "header length {hlen} (offset 16) exceeds the limit of {MAX_HEADER_BYTES} bytes"
            ),
        });
    }
    if let Some(len) = file_len
        && PREAMBLE as u64 + hlen > len
    {
        return Err(TableError::Truncated {
            path: path.into(),
            what: format!(
                "header needs {hlen} bytes, {} present",
                len - PREAMBLE as u64
            ),
        });
    }
    let header_bytes = read_exact_vec(r, hlen).map_err(io_err(path))?;
    if (header_bytes.len() as u64) < hlen {
        return Err(TableError::Truncated {
            path: path.into(),
            what: format!("header needs {hlen} bytes, {} present", header_bytes.len()),
        });
    }
    let mut h = Sha256::new();
    h.update(&pre[..24]);
    h.update(&header_bytes);
    if h.finalize().as_slice() != &pre[24..56] {
        return Err(TableError::HeaderChecksum { path: path.into() });
    }
    let header = parse_header_json(&header_bytes, major, minor).map_err(|m| bad(path, m))?;
    let storage = validate_header(&header, major, limits).map_err(|m| bad(path, m))?;
    Ok(HeaderPart {
        header,
        header_len: hlen,
        storage,
    })
}

/// Top-level header fields of formats 1.0, 2.0 and 3.0 (the fields of [`Header`]).
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

/// Parse the JSON header: nesting depth, duplicate keys and unknown top-level fields (in a minor
/// this reader implements) are checked on a first pass, then the typed header is decoded.
fn parse_header_json(bytes: &[u8], major: u16, minor: u16) -> Result<Header, String> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let symmetry_seen = std::cell::Cell::new(false);
    let top = StrictJson {
        depth: 0,
        at: At::Top,
        major,
        symmetry_seen: &symmetry_seen,
    }
    .deserialize(&mut de)
    .map_err(|e| format!("JSON: {e}"))?;
    de.end().map_err(|e| format!("JSON: {e}"))?;
    let Some(keys) = top else {
        return Err("the header is not a JSON object".into());
    };
    // Fields of a newer minor are ignored; a file of a minor this reader implements (1.0, 2.0)
    // has exactly the fields of that version.
    let newer_minor = minor > 0;
    if !newer_minor && let Some(k) = keys.iter().find(|k| !HEADER_FIELDS.contains(&k.as_str())) {
        return Err(format!(
            "unknown field `{k}` in a format {major}.{minor} header (only a newer minor version \
             may add fields)"
        ));
    }
    let mut header: Header = if major < 3 && symmetry_seen.get() {
        // Not a field of 1.x and 2.x: ignored there whatever it holds, like any unknown nested
        // field, so it is removed before the axes are decoded (and their symmetry checked).
        let mut value: serde_json::Value =
            serde_json::from_slice(bytes).map_err(|e| e.to_string())?;
        if let Some(axes) = value.get_mut("axes").and_then(|a| a.as_array_mut()) {
            for a in axes.iter_mut().filter_map(|a| a.as_object_mut()) {
                a.remove("symmetry");
            }
        }
        serde_json::from_value(value).map_err(|e| e.to_string())?
    } else {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())?
    };
    if major == 1 {
        // Not fields of 1.x: a 1.x reader ignores them like any unknown nested field.
        header.layout.predictor = None;
        for c in &mut header.channels {
            c.derived = None;
        }
    }
    Ok(header)
}

/// A serde visitor over any JSON value that refuses duplicate object keys, nesting deeper
/// than [`MAX_JSON_DEPTH`] and an array where the format (of major version `major`) has an
/// object. Returns the keys of the value when it is an object; notes whether an axis has a
/// `symmetry` field.
#[derive(Clone, Copy)]
struct StrictJson<'a> {
    depth: usize,
    at: At,
    major: u16,
    symmetry_seen: &'a std::cell::Cell<bool>,
}

impl StrictJson<'_> {
    /// The visitor of a value at `at`, one level deeper.
    fn nested(self, at: At) -> Self {
        StrictJson {
            depth: self.depth + 1,
            at,
            ..self
        }
    }
}

/// Where a value sits in the header, as far as the objects of the format go: the typed decoder
/// would also build a struct from an array (`"uniform": [0, 1, 3]`), which the format does not
/// allow (and the other readers refuse).
#[derive(Clone, Copy, PartialEq)]
enum At {
    Top,
    Object(&'static str),
    AxisList,
    ChannelList,
    Channel,
    Axis,
    Points,
    Other,
}

impl At {
    fn field(self, key: &str, major: u16) -> At {
        match (self, key) {
            (At::Axis, "symmetry") if major >= 3 => At::Object("axes[].symmetry"),
            (At::Top, "schema") => At::Object("schema"),
            (At::Top, "layout") => At::Object("layout"),
            (At::Top, "payload") => At::Object("payload"),
            (At::Top, "provenance") => At::Object("provenance"),
            (At::Top, "axes") => At::AxisList,
            (At::Top, "channels") => At::ChannelList,
            (At::Object("layout"), "predictor") => At::Object("layout.predictor"),
            (At::Channel, "derived") => At::Object("channels[].derived"),
            (At::Axis, "points") => At::Points,
            (At::Points, "uniform") => At::Object("axes[].points.uniform"),
            _ => At::Other,
        }
    }
    fn element(self) -> At {
        match self {
            At::AxisList => At::Axis,
            At::ChannelList => At::Channel,
            _ => At::Other,
        }
    }
    /// The name of the object this position must hold, if it must hold one.
    fn object_name(self) -> Option<&'static str> {
        match self {
            At::Top => Some("the header"),
            At::Object(name) => Some(name),
            At::Axis => Some("axes[]"),
            At::Channel => Some("channels[]"),
            At::Points => Some("axes[].points"),
            _ => None,
        }
    }
}

impl<'de> DeserializeSeed<'de> for StrictJson<'_> {
    type Value = Option<Vec<String>>;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for StrictJson<'_> {
    type Value = Option<Vec<String>>;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_str<E>(self, _: &str) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_unit<E>(self) -> Result<Self::Value, E> {
        Ok(None)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let depth = self.depth + 1;
        if depth > MAX_JSON_DEPTH {
            return Err(serde::de::Error::custom(format!(
                "nesting deeper than {MAX_JSON_DEPTH} levels"
            )));
        }
        if let Some(name) = self.at.object_name() {
            return Err(serde::de::Error::custom(format!(
                "{name} must be an object, not an array"
            )));
        }
        let at = self.at.element();
        while seq.next_element_seed(self.nested(at))?.is_some() {}
        Ok(None)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let depth = self.depth + 1;
        if depth > MAX_JSON_DEPTH {
            return Err(serde::de::Error::custom(format!(
                "nesting deeper than {MAX_JSON_DEPTH} levels"
            )));
        }
        let mut keys = std::collections::BTreeSet::new();
        let mut order = Vec::new();
        while let Some(k) = map.next_key::<String>()? {
            if !keys.insert(k.clone()) {
                return Err(serde::de::Error::custom(format!("duplicate key `{k}`")));
            }
            if self.at == At::Axis && k == "symmetry" {
                self.symmetry_seen.set(true);
            }
            let at = self.at.field(&k, self.major);
            map.next_value_seed(self.nested(at))?;
            order.push(k);
        }
        Ok(Some(order))
    }
}

/// Structural checks of the checksummed header (the same rules in every reader); the payload's
/// storage it declares.
fn validate_header(h: &Header, major: u16, limits: &ReadLimits) -> Result<Storage, String> {
    let storage = storage_of(h, major)?;
    if h.payload.compression != "zstd" {
        return Err(format!(
            "unsupported compression `{}`",
            h.payload.compression
        ));
    }
    check_axis_count(h.axes.len())?;
    if h.channels.is_empty() {
        return Err("a table needs at least one channel".into());
    }
    for a in &h.axes {
        if a.is_empty() {
            return Err(format!("axis `{}` is empty", a.name));
        }
    }
    let mut shape: Vec<usize> = h.axes.iter().map(|a| a.len()).collect();
    shape.push(storage.n_stored);
    if shape != h.layout.shape {
        return Err(format!(
            "layout shape {:?} disagrees with axes/channels {:?}",
            h.layout.shape, shape
        ));
    }
    let names = h
        .axes
        .iter()
        .map(|a| a.name.as_str())
        .chain(std::iter::once("channel"));
    if !names.eq(h.layout.axis_order.iter().map(String::as_str)) {
        return Err(format!(
            "layout axis_order {:?} disagrees with the axis names followed by `channel`",
            h.layout.axis_order
        ));
    }
    let bytes = shape
        .iter()
        .try_fold(storage.item_bytes, |acc, &s| acc.checked_mul(s as u64))
        .ok_or_else(|| format!("shape {shape:?} overflows a 64-bit byte count"))?;
    if bytes != h.payload.uncompressed_bytes {
        return Err(format!(
            "shape {shape:?} implies {bytes} bytes, payload.uncompressed_bytes says {}",
            h.payload.uncompressed_bytes
        ));
    }
    if bytes > limits.max_payload_bytes {
        return Err(format!(
            "payload of {bytes} bytes exceeds the reader limit of {} bytes (raise it to read \
             this table)",
            limits.max_payload_bytes
        ));
    }
    if !storage.is_plain() {
        // The values a read returns: 4 bytes for every channel, derived ones included.
        let decoded = h
            .axes
            .iter()
            .try_fold(4 * h.channels.len() as u64, |acc, a| {
                acc.checked_mul(a.len() as u64)
            });
        match decoded {
            Some(d) if d <= limits.max_payload_bytes => {}
            _ => {
                return Err(format!(
                    "the decoded values ({} bytes: 4 per value of every channel) exceed the \
                     reader limit of {} bytes (raise it to read this table)",
                    decoded.map_or("more than 2^64".into(), |d| d.to_string()),
                    limits.max_payload_bytes
                ));
            }
        }
    }
    // Explicit coordinates are in the header already; the coordinates of a uniform axis are
    // enumerated only once the payload has proved the grid exists (`check_all_coords`).
    for a in &h.axes {
        if let AxisPoints::Uniform { start, step, .. } = a.points {
            check_uniform_params(a, start, step)?;
        } else {
            check_axis_coords(a)?;
        }
    }
    Ok(storage)
}

/// What a read keeps of the payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Keep {
    /// Nothing is decompressed: the compressed payload's size, SHA-256 and frame only.
    Sealed,
    /// Every value is decompressed, hashed and counted; none is kept.
    Nothing,
    /// As `Nothing`, keeping the values `[first, first + count)` of the row-major payload.
    Values { first: u64, count: u64 },
}

/// The compressed payload as the decoder pulls it from the file: every byte is hashed and walked
/// for the frame structure on its way. While `stop_on_frame_error` is set, a broken frame rule
/// ends the read at once, so a frame that is refused anyway is not decompressed further.
struct CompressedStream<R> {
    inner: std::io::Take<R>,
    sha: Sha256,
    frame: FrameWalker,
    read: u64,
    stop_on_frame_error: bool,
}

impl<R: Read> Read for CompressedStream<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let stop = || std::io::Error::other("the zstd frame breaks a rule of the format");
        if self.stop_on_frame_error && self.frame.failed() {
            return Err(stop());
        }
        let n = self.inner.read(buf)?;
        self.sha.update(&buf[..n]);
        self.frame.feed(&buf[..n]);
        self.read += n as u64;
        if self.stop_on_frame_error && self.frame.failed() {
            return Err(stop());
        }
        Ok(n)
    }
}

/// The payload's place in the file: its end fits 64 bits and, when the file size is known, the
/// file ends exactly there.
fn check_payload_extent(
    file_len: Option<u64>,
    path: &Path,
    header: &Header,
    header_len: u64,
) -> Result<(), TableError> {
    let p = &header.payload;
    let start = PREAMBLE as u64 + header_len;
    let end = start.checked_add(p.compressed_bytes).ok_or_else(|| {
        bad(
            path,
            format!(
                "payload.compressed_bytes {} overflows the file size",
                p.compressed_bytes
            ),
        )
    })?;
    if let Some(len) = file_len {
        if len < end {
            return Err(payload_truncated(path, header, len - start));
        }
        if len > end {
            return Err(TableError::TrailingBytes {
                path: path.into(),
                extra: len - end,
            });
        }
    }
    Ok(())
}

fn payload_truncated(path: &Path, header: &Header, present: u64) -> TableError {
    TableError::Truncated {
        path: path.into(),
        what: format!(
            "payload needs {} bytes, {present} present",
            header.payload.compressed_bytes
        ),
    }
}

/// Read and verify the payload in one pass over the file (steps 5–7 of
/// `docs/table-format.md`): the compressed bytes stream through their SHA-256 and the frame
/// check into the decoder, the decompressed bytes through their SHA-256, and only the values
/// `keep` asks for stay in memory. The compressed bytes the decoder leaves (after a decoding
/// error or a refused frame) are still read and hashed, so a file breaking several rules is
/// refused by the first in the document's order: size, compressed checksum, frame, decompressed
/// size, decompressed checksum.
fn read_payload(
    r: &mut impl Read,
    file_len: Option<u64>,
    path: &Path,
    header: &Header,
    header_len: u64,
    storage: &Storage,
    keep: Keep,
) -> Result<(Vec<f32>, ValueStats), TableError> {
    let p = &header.payload;
    check_payload_extent(file_len, path, header, header_len)?;
    let mut stream = CompressedStream {
        inner: r.by_ref().take(p.compressed_bytes),
        sha: Sha256::new(),
        frame: FrameWalker::new(p.uncompressed_bytes),
        read: 0,
        stop_on_frame_error: true,
    };
    let decoded = match keep {
        Keep::Sealed => Ok(Decoded::default()),
        _ => decompress(&mut stream, header, storage, keep),
    };
    if let Err(DecodeError::Memory(message)) = &decoded {
        return Err(TableError::Limit {
            path: path.into(),
            message: message.clone(),
        });
    }
    stream.stop_on_frame_error = false;
    std::io::copy(&mut stream, &mut std::io::sink()).map_err(io_err(path))?;
    let CompressedStream {
        sha, frame, read, ..
    } = stream;
    if read < p.compressed_bytes {
        return Err(payload_truncated(path, header, read));
    }
    if file_len.is_none() {
        let extra =
            std::io::copy(&mut r.take(1 << 20), &mut std::io::sink()).map_err(io_err(path))?;
        if extra > 0 {
            return Err(TableError::TrailingBytes {
                path: path.into(),
                extra,
            });
        }
    }
    if hex::encode(sha.finalize()) != p.sha256_compressed {
        return Err(TableError::PayloadChecksum {
            path: path.into(),
            which: "compressed",
        });
    }
    let decompress_err = |message: String| TableError::Decompress {
        path: path.into(),
        message,
    };
    frame.finish().map_err(decompress_err)?;
    let decoded = decoded.map_err(|e| decompress_err(e.into_message()))?;
    if keep != Keep::Sealed && decoded.sha256_uncompressed != p.sha256_uncompressed {
        return Err(TableError::PayloadChecksum {
            path: path.into(),
            which: "uncompressed",
        });
    }
    if let Some(message) = decoded.bad_code {
        return Err(TableError::BadValue {
            path: path.into(),
            message,
        });
    }
    Ok((decoded.data, decoded.stats))
}

/// What decompressing gave: the kept values, the statistics of all values, and the SHA-256
/// (hex) of every decompressed byte.
#[derive(Debug, Default)]
struct Decoded {
    data: Vec<f32>,
    stats: ValueStats,
    sha256_uncompressed: String,
    /// The first stored code that is not a finite value (`f32-top16le`).
    bad_code: Option<String>,
}

/// Why decompressing stopped.
#[derive(Debug)]
enum DecodeError {
    /// The frame does not decode to the declared bytes (step 7).
    Frame(String),
    /// The kept values could not be allocated.
    Memory(String),
}

impl DecodeError {
    fn into_message(self) -> String {
        match self {
            DecodeError::Frame(m) | DecodeError::Memory(m) => m,
        }
    }
}

/// Decompress the single zstd frame of a payload in [`CHUNK`]-sized pieces, checking its
/// decompressed size against the header, hashing every byte, decoding the values (`storage`),
/// counting non-finite and negative values per channel and keeping the values `keep` asks for
/// (grown as they arrive, never allocated from a declared size; an allocation failure is an
/// error, not an abort).
fn decompress(
    compressed: impl Read,
    header: &Header,
    storage: &Storage,
    keep: Keep,
) -> Result<Decoded, DecodeError> {
    let size = header.payload.uncompressed_bytes;
    let frame_err = DecodeError::Frame;
    let nc = header.channels.len();
    let mut out = Decoded {
        stats: ValueStats {
            nan: vec![0; nc],
            infinite: vec![0; nc],
            negative: vec![0; nc],
        },
        ..Decoded::default()
    };
    // The kept bytes [lo, hi) of the payload.
    let (lo, hi) = match keep {
        Keep::Values { first, count } => (4 * first, 4 * (first + count)),
        _ => (0, 0),
    };
    let mut dec = zstd::stream::read::Decoder::with_buffer(std::io::BufReader::with_capacity(
        CHUNK, compressed,
    ))
    .map_err(|e| frame_err(e.to_string()))?
    .single_frame();
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; CHUNK];
    let mut got = 0u64;
    let mut flat = 0usize;
    let mut decoder = (!storage.is_plain()).then(|| PayloadDecoder::new(storage));
    loop {
        // One byte past the declared size proves the frame holds no more.
        let want = ((size - got).min(CHUNK as u64) as usize).max(1);
        let n = read_up_to(&mut dec, &mut buf[..want]).map_err(|e| frame_err(e.to_string()))?;
        if got == size {
            if n > 0 {
                return Err(frame_err(format!(
                    "payload decompresses to more than the {size} bytes the header says"
                )));
            }
            break;
        }
        if n < want {
            return Err(frame_err(format!(
                "payload decompresses to {} bytes, header says {size}",
                got + n as u64
            )));
        }
        let bytes = &buf[..n];
        hasher.update(bytes);
        let start = got;
        got += n as u64;
        if let Some(dec) = decoder.as_mut() {
            decode_piece(dec, bytes, &mut out, &mut flat, keep)?;
            continue;
        }
        for c in bytes.chunks_exact(4) {
            let v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            out.stats.count(flat % nc, v);
            flat += 1;
        }
        let (a, b) = (start.max(lo), got.min(hi));
        if a < b {
            keep_values(
                &mut out.data,
                &bytes[(a - start) as usize..(b - start) as usize],
            )?;
        }
    }
    out.sha256_uncompressed = hex::encode(hasher.finalize());
    out.bad_code = decoder.and_then(|d| d.bad_code);
    Ok(out)
}

/// Feed the decompressed `bytes` of an encoded payload to `dec`: every point decoded is counted
/// and, when `keep` asks for it, kept; `flat` counts the decoded values so far.
fn decode_piece(
    dec: &mut PayloadDecoder,
    bytes: &[u8],
    out: &mut Decoded,
    flat: &mut usize,
    keep: Keep,
) -> Result<(), DecodeError> {
    let (lo, hi) = match keep {
        Keep::Values { first, count } => (first, first + count),
        _ => (0, 0),
    };
    dec.feed(bytes, |point| {
        for (c, &v) in point.iter().enumerate() {
            out.stats.count(c, v);
        }
        let at = *flat as u64;
        *flat += point.len();
        if lo <= at && at < hi {
            out.data.try_reserve(point.len()).map_err(|_| {
                DecodeError::Memory(format!(
                    "cannot allocate memory for {} samples",
                    out.data.len() + point.len()
                ))
            })?;
            out.data.extend_from_slice(point);
        }
        Ok(())
    })
}

/// Append the f32 LE values of `bytes` to `data`, refusing (rather than aborting on) a failed
/// allocation.
fn keep_values(data: &mut Vec<f32>, bytes: &[u8]) -> Result<(), DecodeError> {
    data.try_reserve(bytes.len() / 4).map_err(|_| {
        DecodeError::Memory(format!(
            "cannot allocate memory for {} samples",
            data.len() + bytes.len() / 4
        ))
    })?;
    data.extend(
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
    );
    Ok(())
}

/// Read and verify a table from a stream (every rule of `docs/table-format.md`), keeping the
/// samples of `entry` (`Some(&[])`: every sample; `None`: none, only verifying and counting).
/// `file_len` (when known) lets size errors be reported before anything is read. Returns the
/// file's header.
fn read_table(
    r: &mut impl Read,
    file_len: Option<u64>,
    path: &Path,
    limits: &ReadLimits,
    entry: Option<&[usize]>,
) -> Result<(Header, Vec<f32>, ValueStats), TableError> {
    let HeaderPart {
        header,
        header_len,
        storage,
    } = read_header_part(r, file_len, path, limits)?;
    let keep = match entry {
        None => Keep::Nothing,
        Some(entry) => {
            let (first, count) =
                entry_values(&header, entry).map_err(|message| TableError::Entry {
                    path: path.into(),
                    message,
                })?;
            Keep::Values { first, count }
        }
    };
    let (data, stats) = read_payload(r, file_len, path, &header, header_len, &storage, keep)?;
    for a in &header.axes {
        check_axis_coords(a).map_err(|m| bad(path, m))?;
    }
    Ok((header, data, stats))
}

fn open_file(path: &Path) -> Result<(std::fs::File, Option<u64>), TableError> {
    let f = std::fs::File::open(path).map_err(io_err(path))?;
    let meta = f.metadata().map_err(io_err(path))?;
    let len = meta.is_file().then_some(meta.len());
    Ok((f, len))
}

impl Table {
    /// Open and fully verify a table with the default [`ReadLimits`].
    pub fn open(path: impl AsRef<Path>) -> Result<Self, TableError> {
        Self::open_with_limits(path, &ReadLimits::default())
    }

    /// Open and fully verify a table (every rule of `docs/table-format.md`).
    pub fn open_with_limits(
        path: impl AsRef<Path>,
        limits: &ReadLimits,
    ) -> Result<Self, TableError> {
        Self::open_slice(path, &[], limits)
    }

    /// Open one entry of a table: `entry` fixes the first `entry.len()` axes at these indices
    /// (e.g. `[i_radius, i_wavelength, i_elevation]` of a `raytrace-phase-2d` table). The file is
    /// verified as by [`Table::open_with_limits`] (every checksum over the whole payload, the
    /// limit on the whole payload) while the payload streams past; only the entry's samples are
    /// kept, so memory is bounded by the entry, not the table. The returned table keeps every
    /// axis, a fixed one with its chosen coordinate alone (length 1), so names, units and
    /// [`Table::sample`] work unchanged; `header.payload` describes the file's whole payload.
    /// An empty `entry` opens the whole table. More indices than axes, or an index beyond its
    /// axis, is a [`TableError::Entry`] naming the axis. See `docs/table-format.md`, "Reading one
    /// entry".
    pub fn open_slice(
        path: impl AsRef<Path>,
        entry: &[usize],
        limits: &ReadLimits,
    ) -> Result<Self, TableError> {
        let path = path.as_ref();
        let (f, len) = open_file(path)?;
        let mut r = std::io::BufReader::new(f);
        let (header, data, _) = read_table(&mut r, len, path, limits, Some(entry))?;
        Ok(Table {
            header: entry_header(&header, entry),
            data,
        })
    }

    /// Parse and fully verify table bytes; `path` is only used in error messages.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, TableError> {
        Self::from_bytes_with_limits(bytes, path, &ReadLimits::default())
    }

    /// [`Table::from_bytes`] with explicit limits.
    pub fn from_bytes_with_limits(
        bytes: &[u8],
        path: &Path,
        limits: &ReadLimits,
    ) -> Result<Self, TableError> {
        Self::from_bytes_slice(bytes, path, &[], limits)
    }

    /// [`Table::open_slice`] of table bytes in memory (`path` only names them in errors).
    pub fn from_bytes_slice(
        bytes: &[u8],
        path: &Path,
        entry: &[usize],
        limits: &ReadLimits,
    ) -> Result<Self, TableError> {
        let mut r = bytes;
        let len = Some(bytes.len() as u64);
        let (header, data, _) = read_table(&mut r, len, path, limits, Some(entry))?;
        Ok(Table {
            header: entry_header(&header, entry),
            data,
        })
    }
}

/// Fully verify a table file without keeping its samples (memory bounded by the header and a
/// fixed buffer), gathering [`ValueStats`].
pub fn verify_file(path: &Path, limits: &ReadLimits) -> Result<Verified, TableError> {
    let (f, len) = open_file(path)?;
    let mut r = std::io::BufReader::new(f);
    let (header, _, values) = read_table(&mut r, len, path, limits, None)?;
    Ok(Verified { header, values })
}

/// Check that a table is sealed as its writer left it, without decompressing: preamble, header
/// and every structural rule of the header, the compressed payload's size and SHA-256, its
/// single zstd frame and the axis coordinates. A table that passes holds exactly the bytes
/// the writer checksummed (accidental damage, truncation and a half-written file are caught);
/// the full check with the uncompressed checksum and the values is [`verify_file`]. Used for
/// "is this table up to date" and the catalog, where decompressing every table on every build
/// cost seconds per large table.
pub fn verify_sealed(path: &Path) -> Result<Header, TableError> {
    let (f, len) = open_file(path)?;
    let mut r = std::io::BufReader::new(f);
    sealed(&mut r, len, path)
}

/// [`verify_sealed`] of table bytes in memory (`path` only names them in errors).
pub fn verify_sealed_bytes(bytes: &[u8], path: &Path) -> Result<Header, TableError> {
    let mut r = bytes;
    sealed(&mut r, Some(bytes.len() as u64), path)
}

/// [`verify_sealed`] of a table read from `r`, a stream of `len` bytes (`path` only names it in
/// errors): the payload streams through its checks, so memory does not grow with the table.
pub fn verify_sealed_stream(
    r: &mut impl Read,
    len: u64,
    path: &Path,
) -> Result<Header, TableError> {
    sealed(r, Some(len), path)
}

fn sealed(r: &mut impl Read, len: Option<u64>, path: &Path) -> Result<Header, TableError> {
    let HeaderPart {
        header,
        header_len,
        storage,
    } = read_header_part(r, len, path, &ReadLimits::default())?;
    read_payload(r, len, path, &header, header_len, &storage, Keep::Sealed)?;
    for a in &header.axes {
        check_axis_coords(a).map_err(|m| bad(path, m))?;
    }
    Ok(header)
}

/// Read and verify only the preamble and header of a table (cheap; used for resume checks and
/// the catalog). The payload is not checked.
pub fn read_header_only(path: &Path) -> Result<Header, TableError> {
    let (f, len) = open_file(path)?;
    let mut r = std::io::BufReader::new(f);
    let header = read_header_part(&mut r, len, path, &ReadLimits::default())?.header;
    for a in &header.axes {
        check_axis_coords(a).map_err(|m| bad(path, m))?;
    }
    Ok(header)
}
