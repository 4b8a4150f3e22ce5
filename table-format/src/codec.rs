//! How a payload stores its values (`docs/table-format.md`, "16-bit values" and "Derived
//! channels"): 32-bit floats, or 16-bit codes of non-negative floats with an optional
//! previous-row predictor; channels derived from two stored ones. The same rules serve the
//! writer and the reader, so the writer cannot produce a file the reader refuses.

use crate::model::{Header, PreviousRow};

/// `layout.dtype` of 32-bit floats.
pub const DTYPE_F32: &str = "f32le";
/// `layout.dtype` of 16-bit codes (format 2.0).
pub const DTYPE_TOP16: &str = "f32-top16le";
/// `layout.predictor.kind` of the previous-row predictor.
pub const PREVIOUS_ROW: &str = "previous-row";
/// `derived.op` of the mean of two channels.
pub const MEAN: &str = "mean";
/// `derived.op` of (a − b)/(a + b).
pub const NORMALIZED_DIFFERENCE: &str = "normalized-difference";
/// Codes from this one on have all exponent bits set: infinite or NaN.
pub const FIRST_NON_FINITE_CODE: u16 = 0xFF00;
/// Largest relative error of [`top16_round`] on a normal value: half a unit of the 8 kept
/// mantissa bits, 2^−9.
pub const TOP16_MAX_RELATIVE_ERROR: f64 = 1.0 / 512.0;

/// The 16-bit code of `v`: bits 30–15 of its f32, rounded to nearest by adding 2^14 to the bits
/// first (halfway cases away from zero). `v` must be finite and ≥ 0 (−0 gives the code of +0);
/// a value whose code would be infinite (≥ 0xFF00) is refused.
pub fn top16_code(v: f32) -> Result<u16, String> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!(
            "value {v} cannot be stored as f32-top16le (must be finite and ≥ 0)"
        ));
    }
    let bits = if v == 0.0 { 0 } else { v.to_bits() };
    let code = (bits + (1 << 14)) >> 15;
    if code >= u32::from(FIRST_NON_FINITE_CODE) {
        return Err(format!(
            "value {v} cannot be stored as f32-top16le (it rounds to an infinite code)"
        ));
    }
    Ok(code as u16)
}

/// The value of a code: `f32::from_bits(code << 15)` (not finite from [`FIRST_NON_FINITE_CODE`]).
pub fn top16_value(code: u16) -> f32 {
    f32::from_bits(u32::from(code) << 15)
}

/// `v` as a reader of a `f32-top16le` payload sees it.
pub fn top16_round(v: f32) -> Result<f32, String> {
    top16_code(v).map(top16_value)
}

/// `v` rounded to nearest with `bits` (≤ 23) of its 23 mantissa bits kept (ties away from zero
/// in the magnitude); finite values stay finite (a value that would round to infinity is
/// returned unchanged). With `bits ≤ 8` and `v` finite and ≥ 0 the result is stored exactly by
/// a `f32-top16le` code whose low `8 − bits` bits are zero: a writer can keep fewer bits, and
/// compress better, while every reader decodes the codes unchanged. Relative error at most
/// 2^−(bits+1) for a normal value.
pub fn round_mantissa(v: f32, bits: u32) -> f32 {
    if bits >= 23 || !v.is_finite() {
        return v;
    }
    let drop = 23 - bits;
    let b = v.to_bits();
    let rounded = (b + (1 << (drop - 1))) & !((1u32 << drop) - 1);
    let r = f32::from_bits(rounded);
    if r.is_finite() { r } else { v }
}

/// The operation of a derived channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DerivedOp {
    /// f32(0.5 · (f64 a + f64 b)).
    Mean,
    /// f32((f64 a − f64 b) / (f64 a + f64 b)), 0 when f64 a + f64 b = 0.
    NormalizedDifference,
}

impl DerivedOp {
    fn parse(op: &str) -> Option<Self> {
        match op {
            MEAN => Some(DerivedOp::Mean),
            NORMALIZED_DIFFERENCE => Some(DerivedOp::NormalizedDifference),
            _ => None,
        }
    }

    /// The derived value from the two stored ones (exactly as every reader computes it).
    pub fn apply(self, a: f32, b: f32) -> f32 {
        let (a, b) = (f64::from(a), f64::from(b));
        match self {
            DerivedOp::Mean => (0.5 * (a + b)) as f32,
            DerivedOp::NormalizedDifference => {
                let sum = a + b;
                if sum == 0.0 {
                    0.0
                } else {
                    ((a - b) / sum) as f32
                }
            }
        }
    }
}

/// Where a channel's values come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Source {
    /// The stored channel with this index (among the stored ones).
    Stored(usize),
    /// `op` of the stored channels with these indices.
    Derived(DerivedOp, usize, usize),
}

/// The payload's encoding as the header declares it, checked against every rule.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Storage {
    /// Bytes per stored value: 4 (`f32le`) or 2 (`f32-top16le`).
    pub item_bytes: u64,
    pub predictor: Option<PreviousRow>,
    /// Per header channel.
    pub sources: Vec<Source>,
    pub n_stored: usize,
}

impl Storage {
    /// True for the encoding of format 1.0: f32 values, every channel stored.
    pub fn is_plain(&self) -> bool {
        self.item_bytes == 4 && self.n_stored == self.sources.len()
    }
}

/// The storage a header declares, for a file of format major `major`: in 1.x only `f32le` with
/// every channel stored (`predictor` and `derived` are not fields of 1.x and were dropped);
/// in 2.0 also `f32-top16le`, a predictor and derived channels, each rule checked.
pub(crate) fn storage_of(h: &Header, major: u16) -> Result<Storage, String> {
    let top16 = major >= 2 && h.layout.dtype == DTYPE_TOP16;
    if h.layout.order != "row-major" || (h.layout.dtype != DTYPE_F32 && !top16) {
        return Err(format!(
            "unsupported layout {} / {}",
            h.layout.order, h.layout.dtype
        ));
    }
    let (sources, n_stored) = channel_sources(h)?;
    let predictor = match &h.layout.predictor {
        None => None,
        Some(_) if !top16 => {
            return Err(format!(
                "layout.predictor needs layout.dtype `{DTYPE_TOP16}` (this layout is `{}`)",
                h.layout.dtype
            ));
        }
        Some(p) => {
            if p.kind != PREVIOUS_ROW {
                return Err(format!(
                    "layout.predictor.kind `{}` is not `{PREVIOUS_ROW}`",
                    p.kind
                ));
            }
            let row = PreviousRow {
                stride: p.stride,
                block: p.block,
            };
            check_predictor(h, row, n_stored)?;
            Some(row)
        }
    };
    Ok(Storage {
        item_bytes: if top16 { 2 } else { 4 },
        predictor,
        sources,
        n_stored,
    })
}

/// Stored channels are those without `derived`, in header order; a derived one names two of
/// them (by name, the names of such a table being unique).
fn channel_sources(h: &Header) -> Result<(Vec<Source>, usize), String> {
    let mut stored = std::collections::HashMap::new();
    let any_derived = h.channels.iter().any(|c| c.derived.is_some());
    let mut names = std::collections::HashSet::new();
    for c in &h.channels {
        if any_derived && !names.insert(c.name.as_str()) {
            return Err(format!(
                "channel names must be unique in a table with derived channels (`{}` twice)",
                c.name
            ));
        }
        if c.derived.is_none() {
            let k = stored.len();
            stored.insert(c.name.as_str(), k);
        }
    }
    let mut sources = Vec::with_capacity(h.channels.len());
    for c in &h.channels {
        let Some(d) = &c.derived else {
            sources.push(Source::Stored(stored[c.name.as_str()]));
            continue;
        };
        let op = DerivedOp::parse(&d.op).ok_or_else(|| {
            format!(
                "channel `{}`: derived.op `{}` is not `{MEAN}` or `{NORMALIZED_DIFFERENCE}`",
                c.name, d.op
            )
        })?;
        let [a, b] = d.of.as_slice() else {
            return Err(format!(
                "channel `{}`: derived.of must name two channels ({} given)",
                c.name,
                d.of.len()
            ));
        };
        let index = |n: &String| {
            stored.get(n.as_str()).copied().ok_or_else(|| {
                format!(
                    "channel `{}`: derived.of names `{n}`, which is not a stored channel of \
                     the table",
                    c.name
                )
            })
        };
        sources.push(Source::Derived(op, index(a)?, index(b)?));
    }
    Ok((sources, stored.len()))
}

/// 1 ≤ stride ≤ block, block a multiple of stride, block = (product of the last k axes) × the
/// stored channels for some k ≥ 1.
fn check_predictor(h: &Header, p: PreviousRow, n_stored: usize) -> Result<(), String> {
    let PreviousRow { stride, block } = p;
    if stride == 0 {
        return Err("layout.predictor.stride is 0; it must be at least 1".into());
    }
    if stride > block {
        return Err(format!(
            "layout.predictor.stride {stride} exceeds layout.predictor.block {block}"
        ));
    }
    if !block.is_multiple_of(stride) {
        return Err(format!(
            "layout.predictor.block {block} is not a multiple of layout.predictor.stride {stride}"
        ));
    }
    let mut sizes = Vec::new();
    let mut size = n_stored as u64;
    for a in h.axes.iter().rev() {
        let Some(s) = size.checked_mul(a.len() as u64) else {
            break;
        };
        size = s;
        sizes.push(size);
    }
    if !sizes.contains(&block) {
        return Err(format!(
            "layout.predictor.block {block} is not the values of the last axes of the table \
             (one of {sizes:?}: the product of the last k ≥ 1 axis lengths times {n_stored} \
             stored channels)"
        ));
    }
    Ok(())
}

/// The codes of the previous row: the code of stored value `i − stride`, kept at `i mod stride`
/// (grown as values arrive, so never larger than the data present).
struct Rows {
    row: PreviousRow,
    ring: Vec<u16>,
}

impl Rows {
    /// The code of stored value `i` from `stored` (the code itself, or its difference to the
    /// code one row earlier); `decode` false turns it around (code → stored).
    fn step(&mut self, i: u64, stored: u16, decode: bool) -> u16 {
        let PreviousRow { stride, block } = self.row;
        let at = (i % stride) as usize;
        let predicted = i % block >= stride;
        let (code, out) = match (predicted, decode) {
            (false, _) => (stored, stored),
            (true, true) => {
                let c = stored.wrapping_add(self.ring[at]);
                (c, c)
            }
            (true, false) => (stored, stored.wrapping_sub(self.ring[at])),
        };
        if at == self.ring.len() {
            self.ring.push(code);
        } else {
            self.ring[at] = code;
        }
        out
    }
}

/// The stored channels of `data` (every channel, header order) as the little-endian bytes of
/// a `f32-top16le` payload (codes through the predictor).
pub(crate) fn encode_top16(data: &[f32], storage: &Storage) -> Result<Vec<u8>, String> {
    let nc = storage.sources.len();
    let mut rows = storage.predictor.map(|row| Rows {
        row,
        ring: Vec::new(),
    });
    let mut out = Vec::with_capacity(data.len() / nc * storage.n_stored * 2);
    let mut i = 0u64;
    for point in data.chunks_exact(nc) {
        for (s, v) in storage.sources.iter().zip(point) {
            if let Source::Stored(_) = s {
                let code = top16_code(*v)?;
                let stored = rows.as_mut().map_or(code, |r| r.step(i, code, false));
                out.extend_from_slice(&stored.to_le_bytes());
                i += 1;
            }
        }
    }
    Ok(out)
}

/// The values of a table as a reader returns them for `storage`: stored channels rounded to
/// their codes (top16), derived channels recomputed from them. Errors name the value.
pub(crate) fn decoded_values(data: &mut [f32], storage: &Storage) -> Result<(), String> {
    let nc = storage.sources.len();
    let mut stored = vec![0f32; storage.n_stored];
    for (p, point) in data.chunks_exact_mut(nc).enumerate() {
        for (c, (s, v)) in storage.sources.iter().zip(point.iter_mut()).enumerate() {
            if let Source::Stored(k) = *s {
                if storage.item_bytes == 2 {
                    *v = top16_round(*v).map_err(|e| format!("point {p}, channel {c}: {e}"))?;
                }
                stored[k] = *v;
            }
        }
        fill_derived(point, &storage.sources, &stored);
    }
    Ok(())
}

/// Every channel of one point from its stored values.
fn fill_derived(point: &mut [f32], sources: &[Source], stored: &[f32]) {
    for (v, s) in point.iter_mut().zip(sources) {
        *v = match *s {
            Source::Stored(k) => stored[k],
            Source::Derived(op, a, b) => op.apply(stored[a], stored[b]),
        };
    }
}

/// Streaming decoder of an encoded payload: fed the decompressed bytes in order (in pieces of
/// any size), it hands every point (all channels, header order) to the caller. The first code
/// that is not a finite value is remembered, not raised, so the payload is still hashed whole
/// and a corrupt file is refused by its checksum first.
pub(crate) struct PayloadDecoder<'a> {
    storage: &'a Storage,
    rows: Option<Rows>,
    /// Bytes of a value split between pieces.
    partial: Vec<u8>,
    /// Stored values decoded so far.
    index: u64,
    stored: Vec<f32>,
    point: Vec<f32>,
    pub bad_code: Option<String>,
}

impl<'a> PayloadDecoder<'a> {
    pub fn new(storage: &'a Storage) -> Self {
        PayloadDecoder {
            storage,
            rows: storage.predictor.map(|row| Rows {
                row,
                ring: Vec::new(),
            }),
            partial: Vec::with_capacity(4),
            index: 0,
            stored: Vec::with_capacity(storage.n_stored),
            point: vec![0.0; storage.sources.len()],
            bad_code: None,
        }
    }

    /// The next decompressed bytes; `point` receives each completed point.
    pub fn feed<E>(
        &mut self,
        mut bytes: &[u8],
        mut point: impl FnMut(&[f32]) -> Result<(), E>,
    ) -> Result<(), E> {
        let item = self.storage.item_bytes as usize;
        while !bytes.is_empty() {
            let take = (item - self.partial.len()).min(bytes.len());
            self.partial.extend_from_slice(&bytes[..take]);
            bytes = &bytes[take..];
            if self.partial.len() < item {
                break;
            }
            let v = self.value();
            self.partial.clear();
            self.stored.push(v);
            if self.stored.len() == self.storage.n_stored {
                fill_derived(&mut self.point, &self.storage.sources, &self.stored);
                self.stored.clear();
                point(&self.point)?;
            }
        }
        Ok(())
    }

    /// The value of the complete item in `partial`.
    fn value(&mut self) -> f32 {
        let b = &self.partial;
        let i = self.index;
        self.index += 1;
        if self.storage.item_bytes == 4 {
            return f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        let stored = u16::from_le_bytes([b[0], b[1]]);
        let code = self
            .rows
            .as_mut()
            .map_or(stored, |r| r.step(i, stored, true));
        if code >= FIRST_NON_FINITE_CODE && self.bad_code.is_none() {
            self.bad_code = Some(format!(
                "stored value {i} decodes to code {code:#06x}, which is not a finite value \
                 (codes from {FIRST_NON_FINITE_CODE:#06x} are refused)"
            ));
        }
        top16_value(code)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With 8 mantissa bits `round_mantissa` is the 16-bit rounding; with fewer, the value is
    /// a code whose low bits are zero (decoded unchanged) within 2^−(bits+1).
    #[test]
    fn fewer_mantissa_bits_are_codes_with_low_bits_zero() {
        let mut x = 1.0e-30f32;
        while x < 1.0e30 {
            assert_eq!(round_mantissa(x, 8), top16_round(x).unwrap(), "{x}");
            for bits in 1..8u32 {
                let r = round_mantissa(x, bits);
                let code = top16_code(r).unwrap();
                assert_eq!(code % (1 << (8 - bits)), 0, "{x} {bits}");
                assert_eq!(top16_value(code), r);
                let rel = ((r as f64 - x as f64) / x as f64).abs();
                assert!(rel <= 0.5f64.powi(bits as i32 + 1), "{x} {bits} {rel}");
            }
            x *= 1.37;
        }
        assert_eq!(round_mantissa(f32::MAX, 4), f32::MAX);
    }

    /// Rounding is to nearest with a relative error of at most 2^−9 on normal values, −0 gives
    /// +0, and only values near f32::MAX are refused.
    #[test]
    fn codes_round_to_nearest_within_the_stated_error() {
        let mut x = 1.0e-30f32;
        while x < 1.0e30 {
            let r = top16_round(x).unwrap();
            assert!(
                ((r as f64 - x as f64) / x as f64).abs() <= TOP16_MAX_RELATIVE_ERROR,
                "{x} {r}"
            );
            x *= 1.0137;
        }
        assert_eq!(top16_code(-0.0).unwrap(), 0);
        assert_eq!(top16_code(1.0).unwrap(), 0x7F00);
        // 1 + 2^-9 is halfway between codes: rounds up.
        assert_eq!(top16_code(1.0 + 1.0 / 512.0).unwrap(), 0x7F01);
        assert_eq!(top16_code(1.0 + 1.0 / 1024.0).unwrap(), 0x7F00);
        assert!(top16_code(f32::MAX).is_err());
        assert!(top16_code(-1.0).is_err() && top16_code(f32::NAN).is_err());
        assert_eq!(top16_value(0xFEFF), f32::from_bits(0x7F7F_8000));
    }

    /// The predictor's encoding and decoding are inverse, in pieces of any size.
    #[test]
    fn predictor_round_trips() {
        let sources = vec![Source::Stored(0), Source::Stored(1)];
        let storage = Storage {
            item_bytes: 2,
            predictor: Some(PreviousRow {
                stride: 6,
                block: 18,
            }),
            sources,
            n_stored: 2,
        };
        let data: Vec<f32> = (0..72).map(|i| (i as f32 * 0.37).sin().abs()).collect();
        let bytes = encode_top16(&data, &storage).unwrap();
        for piece in [1, 3, 64] {
            let mut dec = PayloadDecoder::new(&storage);
            let mut got = Vec::new();
            for chunk in bytes.chunks(piece) {
                let Ok(()) = dec.feed::<std::convert::Infallible>(chunk, |p| {
                    got.extend_from_slice(p);
                    Ok(())
                });
            }
            let want: Vec<f32> = data.iter().map(|&v| top16_round(v).unwrap()).collect();
            assert_eq!(got, want);
            assert!(dec.bad_code.is_none());
        }
    }
}
