//! The structure of a payload's zstd frame (RFC 8878), checked as the compressed bytes stream
//! past: exactly one frame, no dictionary, a declared content size equal to the header's, and
//! its last block (and content checksum, if flagged) ending exactly at the end of the payload
//! (`docs/table-format.md`, "Reading and verification", step 6). The check keeps a few bytes of
//! state, so a payload need not be held in memory to be checked.

/// Magic number of a zstd frame (little-endian `0xFD2FB528`).
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];
/// Longest field the walker collects: the 8-byte frame content size.
const FIELD_MAX: usize = 8;

/// What the walker expects next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    /// Magic and frame header descriptor (5 bytes).
    Start,
    /// The frame content size (1, 2, 4 or 8 bytes).
    ContentSize,
    /// A 3-byte block header.
    BlockHeader,
    /// After the last block (and the content checksum): nothing may follow.
    End,
}

/// Streaming check of one zstd frame: [`FrameWalker::feed`] the payload's bytes in order (in
/// pieces of any size), then [`FrameWalker::finish`]. The first broken rule, in the order of the
/// bytes, is the error; its message is the same whatever the pieces.
#[derive(Debug, Clone)]
pub(crate) struct FrameWalker {
    content_size: u64,
    part: Part,
    /// Offset (in the payload) where the next field starts, or where the frame ends (`End`).
    next: u64,
    /// Bytes of the field being collected and how many it needs.
    field: [u8; FIELD_MAX],
    have: usize,
    need: usize,
    /// Bytes fed so far.
    fed: u64,
    checksum: bool,
    error: Option<String>,
}

fn truncated() -> String {
    "the zstd frame is truncated".to_string()
}

impl FrameWalker {
    /// A walker for a frame that must declare `content_size` bytes.
    pub(crate) fn new(content_size: u64) -> Self {
        FrameWalker {
            content_size,
            part: Part::Start,
            next: 0,
            field: [0; FIELD_MAX],
            have: 0,
            need: 5,
            fed: 0,
            checksum: false,
            error: None,
        }
    }

    /// True once a rule is broken (the rest of the payload cannot repair it).
    pub(crate) fn failed(&self) -> bool {
        self.error.is_some()
    }

    /// The next bytes of the payload.
    pub(crate) fn feed(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() && self.error.is_none() && self.part != Part::End {
            if self.fed < self.next {
                let skip = (self.next - self.fed).min(bytes.len() as u64) as usize;
                self.fed += skip as u64;
                bytes = &bytes[skip..];
                continue;
            }
            let take = (self.need - self.have).min(bytes.len());
            self.field[self.have..self.have + take].copy_from_slice(&bytes[..take]);
            self.have += take;
            self.fed += take as u64;
            bytes = &bytes[take..];
            if self.have == self.need {
                self.have = 0;
                if let Err(e) = self.field_done() {
                    self.error = Some(e);
                }
            }
        }
        self.fed += bytes.len() as u64;
    }

    /// Interpret a complete field and say what comes next.
    fn field_done(&mut self) -> Result<(), String> {
        let f = self.field;
        match self.part {
            Part::Start => self.frame_header(f[..4] == ZSTD_MAGIC, f[4]),
            Part::ContentSize => {
                let mut le = [0u8; 8];
                le[..self.need].copy_from_slice(&f[..self.need]);
                let mut declared = u64::from_le_bytes(le);
                if self.need == 2 {
                    declared += 256;
                }
                if declared != self.content_size {
                    return Err(format!(
                        "zstd frame declares {declared} content bytes, payload.uncompressed_bytes \
                         says {}",
                        self.content_size
                    ));
                }
                self.expect(Part::BlockHeader, self.fed, 3);
                Ok(())
            }
            Part::BlockHeader => {
                let bh = u32::from(f[0]) | u32::from(f[1]) << 8 | u32::from(f[2]) << 16;
                let stored = match (bh >> 1) & 3 {
                    0 | 2 => u64::from(bh >> 3),
                    1 => 1,
                    _ => return Err("zstd block of reserved type".into()),
                };
                let after = self.fed + stored;
                if bh & 1 == 1 {
                    let end = after + if self.checksum { 4 } else { 0 };
                    self.expect(Part::End, end, 0);
                } else {
                    self.expect(Part::BlockHeader, after, 3);
                }
                Ok(())
            }
            Part::End => Ok(()),
        }
    }

    /// The frame header descriptor: flags, then where the content size is.
    fn frame_header(&mut self, magic_ok: bool, fhd: u8) -> Result<(), String> {
        if !magic_ok {
            return Err("payload does not start with a zstd frame (magic 28 b5 2f fd)".into());
        }
        let fcs_flag = fhd >> 6;
        let single_segment = (fhd >> 5) & 1 == 1;
        if (fhd >> 3) & 1 != 0 {
            return Err("zstd frame header has its reserved bit set".into());
        }
        if fhd & 3 != 0 {
            return Err("zstd frame names a dictionary".into());
        }
        self.checksum = (fhd >> 2) & 1 == 1;
        let fcs_len = match (fcs_flag, single_segment) {
            (0, false) => 0,
            (0, true) => 1,
            (1, _) => 2,
            (2, _) => 4,
            _ => 8,
        };
        if fcs_len == 0 {
            return Err("zstd frame does not declare its content size".into());
        }
        // A window descriptor byte precedes the content size unless the frame is single-segment.
        let at = 5 + u64::from(!single_segment);
        self.expect(Part::ContentSize, at, fcs_len);
        Ok(())
    }

    fn expect(&mut self, part: Part, at: u64, need: usize) {
        self.part = part;
        self.next = at;
        self.need = need;
    }

    /// The verdict once every byte of the payload has been fed.
    pub(crate) fn finish(&self) -> Result<(), String> {
        if let Some(e) = &self.error {
            return Err(e.clone());
        }
        match self.part {
            Part::Start => {
                Err("payload does not start with a zstd frame (magic 28 b5 2f fd)".into())
            }
            Part::ContentSize | Part::BlockHeader => Err(truncated()),
            Part::End => match self.fed.cmp(&self.next) {
                std::cmp::Ordering::Less => Err(truncated()),
                std::cmp::Ordering::Greater => Err(format!(
                    "{} bytes follow the zstd frame (the payload must be exactly one frame)",
                    self.fed - self.next
                )),
                std::cmp::Ordering::Equal => Ok(()),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walker fed the whole payload at once.
    fn check_zstd_frame(payload: &[u8], content_size: u64) -> Result<(), String> {
        let mut w = FrameWalker::new(content_size);
        w.feed(payload);
        w.finish()
    }

    /// The verdict does not depend on how the payload is cut into pieces: every frame of a
    /// small corpus (valid, truncated at every length, trailing bytes, flipped bytes) gets the
    /// same message fed at once and one byte at a time.
    #[test]
    fn verdict_is_independent_of_the_pieces() {
        let raw: Vec<u8> = (0..5000u32).flat_map(|i| (i % 251).to_le_bytes()).collect();
        let frame = zstd::bulk::compress(&raw, 3).unwrap();
        let mut cases = vec![frame.clone()];
        for n in 0..frame.len() {
            cases.push(frame[..n].to_vec());
        }
        let mut longer = frame.clone();
        longer.extend_from_slice(&[0, 1, 2]);
        cases.push(longer);
        for i in 0..frame.len().min(40) {
            let mut c = frame.clone();
            c[i] ^= 0x24;
            cases.push(c);
        }
        for c in &cases {
            let whole = check_zstd_frame(c, raw.len() as u64);
            let mut w = FrameWalker::new(raw.len() as u64);
            for b in c {
                w.feed(std::slice::from_ref(b));
            }
            assert_eq!(w.finish(), whole, "{} bytes", c.len());
        }
        assert_eq!(check_zstd_frame(&frame, raw.len() as u64), Ok(()));
        assert_eq!(
            check_zstd_frame(&frame[..frame.len() - 1], raw.len() as u64),
            Err(truncated())
        );
    }
}
