//! DirectDraw Surface files with the DX10 extended header, as the engine LUT exports write them:
//! one mip, 2-D (`TEXTURE2D`) or 3-D (`TEXTURE3D`, with the DDS volume flags) resources, texels
//! x fastest, then y (row 0 = v = 0, the D3D/Vulkan convention), then z, in one of a few
//! uncompressed DXGI formats ([`DxgiFormat`]).

/// The DXGI formats the exports write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DxgiFormat {
    /// `DXGI_FORMAT_R32G32B32A32_FLOAT` (2), 16 bytes per texel.
    R32G32B32A32Float,
    /// `DXGI_FORMAT_R16G16B16A16_FLOAT` (10), 8 bytes per texel.
    R16G16B16A16Float,
    /// `DXGI_FORMAT_R32_FLOAT` (41), 4 bytes per texel.
    R32Float,
    /// `DXGI_FORMAT_R9G9B9E5_SHAREDEXP` (67), 4 bytes per texel: three 9-bit mantissas and a
    /// shared 5-bit exponent ([`rgb9e5`]).
    R9G9B9E5SharedExp,
}

impl DxgiFormat {
    const ALL: [DxgiFormat; 4] = [
        DxgiFormat::R32G32B32A32Float,
        DxgiFormat::R16G16B16A16Float,
        DxgiFormat::R32Float,
        DxgiFormat::R9G9B9E5SharedExp,
    ];

    /// The `DXGI_FORMAT` value.
    pub fn code(self) -> u32 {
        match self {
            DxgiFormat::R32G32B32A32Float => 2,
            DxgiFormat::R16G16B16A16Float => 10,
            DxgiFormat::R32Float => 41,
            DxgiFormat::R9G9B9E5SharedExp => 67,
        }
    }

    /// Bytes per texel.
    pub fn bytes_per_texel(self) -> usize {
        match self {
            DxgiFormat::R32G32B32A32Float => 16,
            DxgiFormat::R16G16B16A16Float => 8,
            DxgiFormat::R32Float | DxgiFormat::R9G9B9E5SharedExp => 4,
        }
    }

    /// The `DXGI_FORMAT_…` name.
    pub fn name(self) -> &'static str {
        match self {
            DxgiFormat::R32G32B32A32Float => "DXGI_FORMAT_R32G32B32A32_FLOAT",
            DxgiFormat::R16G16B16A16Float => "DXGI_FORMAT_R16G16B16A16_FLOAT",
            DxgiFormat::R32Float => "DXGI_FORMAT_R32_FLOAT",
            DxgiFormat::R9G9B9E5SharedExp => "DXGI_FORMAT_R9G9B9E5_SHAREDEXP",
        }
    }
}

/// One uncompressed texture: `size = [width, height, depth]` (depth 1 for 2-D) and its texels'
/// bytes in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct DdsImage {
    pub size: [usize; 3],
    pub format: DxgiFormat,
    pub data: Vec<u8>,
}

/// A DDS file this module cannot read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("not a DDS file the engine exports write: {0}")]
pub struct DdsError(pub &'static str);

const DDS_MAGIC: &[u8; 4] = b"DDS ";
/// Bytes before the texels: magic, `DDS_HEADER` (124) and `DDS_HEADER_DXT10` (20).
pub const DDS_HEADER_BYTES: usize = 148;

/// The file bytes of `img` (DX10 header, one mip, `TEXTURE3D` when depth > 1).
pub fn dds_encode(img: &DdsImage) -> Vec<u8> {
    let [w, h, d] = img.size.map(|v| v as u32);
    let volume = img.size[2] > 1;
    let mut out = Vec::with_capacity(DDS_HEADER_BYTES + img.data.len());
    let mut put = |v: u32| out.extend_from_slice(&v.to_le_bytes());
    // DDS_HEADER
    put(u32::from_le_bytes(*DDS_MAGIC));
    put(124);
    // CAPS | HEIGHT | WIDTH | PITCH | PIXELFORMAT (| DEPTH)
    put(0x1 | 0x2 | 0x4 | 0x8 | 0x1000 | if volume { 0x80_0000 } else { 0 });
    put(h);
    put(w);
    put(w * img.format.bytes_per_texel() as u32);
    put(if volume { d } else { 0 });
    put(1);
    for _ in 0..11 {
        put(0);
    }
    // DDS_PIXELFORMAT: FOURCC "DX10"
    put(32);
    put(0x4);
    put(u32::from_le_bytes(*b"DX10"));
    for _ in 0..5 {
        put(0);
    }
    put(0x1000 | if volume { 0x8 } else { 0 });
    put(if volume { 0x20_0000 } else { 0 });
    put(0);
    put(0);
    put(0);
    // DDS_HEADER_DXT10
    put(img.format.code());
    put(if volume { 4 } else { 3 });
    put(0);
    put(1);
    put(0);
    out.extend_from_slice(&img.data);
    out
}

/// Read back a file written by [`dds_encode`].
pub fn dds_decode(b: &[u8]) -> Result<DdsImage, DdsError> {
    let word = |i: usize| -> Result<u32, DdsError> {
        b.get(4 * i..4 * i + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            .ok_or(DdsError("truncated header"))
    };
    if b.get(..4) != Some(DDS_MAGIC.as_slice()) || word(1)? != 124 {
        return Err(DdsError("no DDS magic/header"));
    }
    if word(21)? != u32::from_le_bytes(*b"DX10") {
        return Err(DdsError("no DX10 extended header"));
    }
    let code = word(32)?;
    let format = DxgiFormat::ALL
        .into_iter()
        .find(|f| f.code() == code)
        .ok_or(DdsError("a DXGI format the exports do not write"))?;
    let volume = word(33)? == 4;
    let size = [
        word(4)? as usize,
        word(3)? as usize,
        if volume { word(6)? as usize } else { 1 },
    ];
    let n = size.iter().product::<usize>() * format.bytes_per_texel();
    let data = b
        .get(DDS_HEADER_BYTES..DDS_HEADER_BYTES + n)
        .ok_or(DdsError("truncated texels"))?
        .to_vec();
    Ok(DdsImage { size, format, data })
}

/// Largest value `DXGI_FORMAT_R9G9B9E5_SHAREDEXP` holds: `(511/512)·2¹⁶`.
pub const RGB9E5_MAX: f64 = 65408.0;

/// `DXGI_FORMAT_R9G9B9E5_SHAREDEXP` encoding of a non-negative RGB triple (the rounding rule of
/// the `EXT_texture_shared_exponent` specification): exponent bias 15, 9-bit mantissas without
/// implicit leading one, channels clamped to `[0, RGB9E5_MAX]` (NaN as 0); bits 0–8 red, 9–17
/// green, 18–26 blue, 27–31 the exponent.
pub fn rgb9e5(rgb: [f64; 3]) -> u32 {
    const BIAS: i32 = 15;
    const MANTISSA: i32 = 9;
    let c = rgb.map(|v| {
        if v.is_nan() {
            0.0
        } else {
            v.clamp(0.0, RGB9E5_MAX)
        }
    });
    let max = c[0].max(c[1]).max(c[2]);
    let floor_log2 = if max > 0.0 {
        max.log2().floor() as i32
    } else {
        -BIAS - 1
    };
    let mut exp = floor_log2.max(-BIAS - 1) + 1 + BIAS;
    let unit = |e: i32| 2f64.powi(e - BIAS - MANTISSA);
    if (max / unit(exp) + 0.5).floor() as i32 == 1 << MANTISSA {
        exp += 1;
    }
    let m = c.map(|v| ((v / unit(exp) + 0.5).floor() as u32).min(511));
    m[0] | m[1] << 9 | m[2] << 18 | (exp as u32) << 27
}

/// The RGB triple of an [`rgb9e5`] word: `mantissa · 2^(exponent − 24)`.
pub fn rgb9e5_decode(word: u32) -> [f64; 3] {
    let scale = 2f64.powi((word >> 27) as i32 - 24);
    [0, 9, 18].map(|s| f64::from((word >> s) & 0x1ff) * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb9e5_round_trips_within_half_a_mantissa_step_of_the_largest_channel() {
        // Below 2⁻¹⁵ the exponent stays at its least value: steps of 2⁻²⁴, errors up to 2⁻²⁵.
        for rgb in [
            [1.0, 0.5, 0.25],
            [123.4, 0.001, 7.0],
            [3.0e-6, 1.0e-7, 0.0],
            [65000.0, 1.0, 0.0],
            [0.999_9, 0.999_9, 0.0],
        ] {
            let back = rgb9e5_decode(rgb9e5(rgb));
            let max = rgb.iter().cloned().fold(0.0, f64::max);
            for c in 0..3 {
                assert!(
                    (back[c] - rgb[c]).abs() <= (max / 512.0).max(2f64.powi(-25)),
                    "{rgb:?} → {back:?}"
                );
            }
        }
        assert_eq!(rgb9e5_decode(rgb9e5([0.0; 3])), [0.0; 3]);
        assert_eq!(rgb9e5_decode(rgb9e5([1.0, 2.0, 4.0])), [1.0, 2.0, 4.0]);
    }

    #[test]
    fn header_round_trips_and_bad_files_are_refused() {
        let img = DdsImage {
            size: [3, 2, 4],
            format: DxgiFormat::R9G9B9E5SharedExp,
            data: (0..96).map(|k| k as u8).collect(),
        };
        let bytes = dds_encode(&img);
        assert_eq!(bytes.len(), DDS_HEADER_BYTES + 96);
        assert_eq!(dds_decode(&bytes).unwrap(), img);
        assert!(dds_decode(&bytes[..100]).is_err());
        assert!(dds_decode(&bytes[..DDS_HEADER_BYTES + 10]).is_err());
        assert!(dds_decode(b"PNG file").is_err());
    }
}
