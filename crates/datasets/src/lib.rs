//! Public data sets shipped inside gearcomp so tests, demos and benchmarks run offline.
//!
//! * FL_THERMAL: a real 46.3-hour machine-tool spindle thermal test (CAIVIAC/FL_THERMAL,
//!   commit 293b225, MIT licence in `data/FL_THERMAL_LICENSE`): 11,115 rows every 15 s,
//!   `time_s, spindle_rpm, ch1_um … ch5_um, t1_c … t16_c`. See `data/FL_THERMAL_README.md`.

use std::io::{Error, ErrorKind};

const FL_THERMAL_GZ: &[u8] = include_bytes!("../data/fl_thermal.csv.gz");

/// The licence text of the FL_THERMAL data (MIT).
pub const FL_THERMAL_LICENSE: &str = include_str!("../data/FL_THERMAL_LICENSE");

/// The FL_THERMAL CSV text (decompressed from the embedded copy).
pub fn fl_thermal_csv() -> std::io::Result<String> {
    gunzip_text(FL_THERMAL_GZ)
}

/// The embedded FL_THERMAL as its gzip members: per member a reader of its text, inflated
/// as it is read, and the text's length in bytes (its trailer's). Each member holds whole
/// lines, the first one starting with the header. A member whose text differs from its
/// trailer's length or CRC-32 ends in an `InvalidData` read error instead of its end.
pub fn fl_thermal_pieces() -> std::io::Result<Vec<(impl std::io::Read + Send, usize)>> {
    Ok(members(FL_THERMAL_GZ)?
        .into_iter()
        .map(|m| {
            let size = m.size;
            (MemberReader::new(m), size)
        })
        .collect())
}

/// A gzip member read as its text (inflated as it is read, checked at its end).
struct MemberReader<'a> {
    member: Member<'a>,
    inflate: flate2::Decompress,
    crc: flate2::Crc,
    done: bool,
}

impl<'a> MemberReader<'a> {
    fn new(member: Member<'a>) -> Self {
        Self {
            member,
            inflate: flate2::Decompress::new(false),
            crc: flate2::Crc::new(),
            done: false,
        }
    }
}

impl std::io::Read for MemberReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let bad = |what: String| Error::new(ErrorKind::InvalidData, format!("gzip: {what}"));
        if self.done || buf.is_empty() {
            return Ok(0);
        }
        let d = &mut self.inflate;
        let (in0, out0) = (d.total_in(), d.total_out());
        let input = usize::try_from(in0)
            .ok()
            .and_then(|k| self.member.body.get(k..))
            .ok_or_else(|| bad("inflate read past its input".into()))?;
        let status = d
            .decompress(input, buf, flate2::FlushDecompress::None)
            .map_err(|e| bad(e.to_string()))?;
        let n = usize::try_from(d.total_out() - out0).unwrap_or(usize::MAX);
        let chunk = buf
            .get(..n)
            .ok_or_else(|| bad("inflate wrote past its output".into()))?;
        self.crc.update(chunk);
        if status == flate2::Status::StreamEnd {
            self.done = true;
            if d.total_out() != self.member.size as u64
                || d.total_in() != self.member.body.len() as u64
                || self.crc.sum() != self.member.crc
            {
                return Err(bad("length or CRC-32 differs from the trailer".into()));
            }
        } else if n == 0 && d.total_in() == in0 {
            return Err(bad("truncated member".into()));
        }
        if n == 0 && !self.done {
            // Input consumed without output yet (block headers): read on.
            return self.read(buf);
        }
        Ok(n)
    }
}

/// One gzip member: its deflate data, and the CRC-32 and length of its text (trailer).
struct Member<'a> {
    body: &'a [u8],
    crc: u32,
    size: usize,
}

/// The members of a gzip file (RFC 1952 §2.2: a series of members). A member whose header
/// carries the extra subfield `GC` (4 bytes, little-endian: the member's total length,
/// written by `data/split_members.py`) is followed by the next member; one without it must
/// be the last and ends at the end of the file.
fn members(gz: &[u8]) -> std::io::Result<Vec<Member<'_>>> {
    let bad = |what: &str| Error::new(ErrorKind::InvalidData, format!("gzip: {what}"));
    let byte = |k: usize| gz.get(k).copied().ok_or_else(|| bad("truncated header"));
    let word = |k: usize| -> std::io::Result<u32> {
        Ok(u32::from_le_bytes([
            byte(k)?,
            byte(k + 1)?,
            byte(k + 2)?,
            byte(k + 3)?,
        ]))
    };
    let mut out = Vec::new();
    let mut at = 0;
    while at < gz.len() || out.is_empty() {
        if gz.len() < at + 18 || gz[at] != 0x1f || gz[at + 1] != 0x8b || gz[at + 2] != 8 {
            return Err(bad("not a deflate gzip member"));
        }
        let flags = gz[at + 3];
        if flags & 0xe0 != 0 {
            return Err(bad("reserved header flags set"));
        }
        let mut i = at + 10;
        let mut member_len = None;
        if flags & 4 != 0 {
            let xlen = usize::from(byte(i)?) | usize::from(byte(i + 1)?) << 8;
            let end = i + 2 + xlen;
            let mut k = i + 2;
            while k + 4 <= end {
                let len = usize::from(byte(k + 2)?) | usize::from(byte(k + 3)?) << 8;
                if (byte(k)?, byte(k + 1)?, len) == (b'G', b'C', 4) {
                    member_len = Some(word(k + 4)? as usize);
                }
                k += 4 + len;
            }
            if k != end {
                return Err(bad("malformed extra field"));
            }
            i = end;
        }
        for bit in [8u8, 16] {
            if flags & bit != 0 {
                let end = gz.get(i..).and_then(|r| r.iter().position(|&b| b == 0));
                i += end.ok_or_else(|| bad("unterminated header field"))? + 1;
            }
        }
        if flags & 2 != 0 {
            i += 2;
        }
        let member_end = match member_len {
            Some(len) => at
                .checked_add(len)
                .filter(|&e| e <= gz.len())
                .ok_or_else(|| bad("member length past the end"))?,
            None => gz.len(),
        };
        let body = gz
            .get(i..member_end.saturating_sub(8))
            .filter(|_| member_end >= i + 8)
            .ok_or_else(|| bad("truncated"))?;
        let size = word(member_end - 4)? as usize;
        // Deflate expands at most 1032:1: a larger stated length is damage, not a buffer
        // to allocate.
        if size > body.len().saturating_mul(1032) {
            return Err(bad("stated length impossible for the data"));
        }
        out.push(Member {
            body,
            crc: word(member_end - 8)?,
            size,
        });
        at = member_end;
    }
    Ok(out)
}

/// Inflates one member into `out` (exactly its trailer's length) and checks its CRC-32.
fn inflate_member(m: &Member, out: &mut [u8]) -> Result<(), String> {
    let mut d = flate2::Decompress::new(false);
    let status = d
        .decompress(m.body, out, flate2::FlushDecompress::Finish)
        .map_err(|e| e.to_string())?;
    let mut sum = flate2::Crc::new();
    sum.update(out);
    if status != flate2::Status::StreamEnd
        || d.total_out() != out.len() as u64
        || d.total_in() != m.body.len() as u64
        || sum.sum() != m.crc
    {
        return Err("length or CRC-32 differs from the trailer".into());
    }
    Ok(())
}

/// A gzip file inflated straight into one buffer of the size its trailers state, as UTF-8
/// text: its members (the embedded copy has four) on as many threads at once, each checked
/// against its trailer's length and CRC-32.
fn gunzip_text(gz: &[u8]) -> std::io::Result<String> {
    let bad = |what: &str| Error::new(ErrorKind::InvalidData, format!("gzip: {what}"));
    let members = members(gz)?;
    let total = members.iter().map(|m| m.size).sum();
    let mut out = vec![0u8; total];
    let mut parts: Vec<(&Member, &mut [u8])> = Vec::with_capacity(members.len());
    let mut rest = out.as_mut_slice();
    for m in &members {
        let (part, tail) = rest.split_at_mut(m.size);
        parts.push((m, part));
        rest = tail;
    }
    let results: Vec<Result<(), String>> = std::thread::scope(|s| {
        let mut parts = parts.into_iter();
        let first = parts.next();
        let handles: Vec<_> = parts
            .map(|(m, part)| s.spawn(move || inflate_member(m, part)))
            .collect();
        let mut r = vec![first.map_or(Ok(()), |(m, part)| inflate_member(m, part))];
        r.extend(
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|_| Err("inflate failed".into()))),
        );
        r
    });
    for r in results {
        r.map_err(|e| bad(&e))?;
    }
    String::from_utf8(out).map_err(|e| Error::new(ErrorKind::InvalidData, e))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    #[test]
    fn fl_thermal_has_header_and_all_rows() {
        let text = super::fl_thermal_csv().unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("time_s,spindle_rpm,ch1_um"));
        assert_eq!(header.split(',').count(), 23);
        assert_eq!(lines.filter(|l| !l.trim().is_empty()).count(), 11_115);
        assert!(super::FL_THERMAL_LICENSE.contains("MIT"));
    }

    #[test]
    fn damaged_gzip_is_an_error_not_a_panic() {
        let gz = super::FL_THERMAL_GZ;
        for k in [100, gz.len() / 2, gz.len() - 6] {
            let mut bad = gz.to_vec();
            bad[k] ^= 0x5a;
            assert!(super::gunzip_text(&bad).is_err(), "byte {k}");
        }
        for n in [0, 10, 17, gz.len() - 1] {
            assert!(super::gunzip_text(&gz[..n]).is_err(), "{n} bytes");
        }
        let mut flags = gz.to_vec();
        flags[3] |= 4 | 16;
        assert!(super::gunzip_text(&flags).is_err());
        let mut flags = gz.to_vec();
        flags[3] &= !4;
        assert!(super::gunzip_text(&flags).is_err());
        for k in 10..20 {
            let mut head = gz.to_vec();
            head[k] ^= 0x5a;
            assert!(super::gunzip_text(&head).is_err(), "header byte {k}");
        }
    }

    /// The members read as streams (in reads of 1 B to 1 MB) are the text inflated at once,
    /// piece after piece, each whole lines; a damaged member is a read error.
    #[test]
    fn pieces_read_as_streams_are_the_text() {
        use std::io::Read;
        let text = super::fl_thermal_csv().unwrap();
        for step in [1usize, 7, 4096, 1 << 20] {
            let mut all = Vec::new();
            let pieces = super::fl_thermal_pieces().unwrap();
            assert_eq!(pieces.len(), 4);
            for (mut r, size) in pieces {
                let mut piece = Vec::new();
                let mut buf = vec![0u8; step];
                loop {
                    let n = r.read(&mut buf).unwrap();
                    if n == 0 {
                        break;
                    }
                    piece.extend_from_slice(&buf[..n]);
                }
                assert_eq!(piece.len(), size);
                assert_eq!(piece.last(), Some(&b'\n'));
                all.extend(piece);
                if step > 4096 {
                    break;
                }
            }
            assert!(text.as_bytes().starts_with(&all), "step {step}");
        }
        let members = super::members(super::FL_THERMAL_GZ).unwrap();
        let mut body = members[1].body.to_vec();
        let mid = body.len() / 2;
        body[mid] ^= 0x5a;
        let bad = super::Member {
            body: &body,
            crc: members[1].crc,
            size: members[1].size,
        };
        let mut out = Vec::new();
        assert!(super::MemberReader::new(bad).read_to_end(&mut out).is_err());
        let cut = super::Member {
            body: &members[1].body[..members[1].body.len() - 9],
            crc: members[1].crc,
            size: members[1].size,
        };
        let mut out = Vec::new();
        assert!(super::MemberReader::new(cut).read_to_end(&mut out).is_err());
    }

    /// The embedded copy is several members (inflated at once), and any gzip file of one
    /// member without the length field reads the same: an independent encoder (Python's
    /// zlib through a gzip header written here) gives the same text.
    #[test]
    fn members_inflate_to_the_same_text_as_one_plain_member() {
        let gz = super::FL_THERMAL_GZ;
        let members = super::members(gz).unwrap();
        assert_eq!(members.len(), 4);
        let text = super::gunzip_text(gz).unwrap();
        assert_eq!(text.len(), 4_373_542);
        // The same text as one ordinary member (stored blocks: no compression library).
        let raw = text.as_bytes();
        let mut one = vec![0x1f, 0x8b, 8, 8, 0, 0, 0, 0, 0, 255];
        one.extend_from_slice(b"x.csv\0");
        for (k, block) in raw.chunks(65_535).enumerate() {
            let last = (k + 1) * 65_535 >= raw.len();
            one.push(u8::from(last));
            let n = block.len() as u16;
            one.extend_from_slice(&n.to_le_bytes());
            one.extend_from_slice(&(!n).to_le_bytes());
            one.extend_from_slice(block);
        }
        let mut crc = flate2::Crc::new();
        crc.update(raw);
        one.extend_from_slice(&crc.sum().to_le_bytes());
        one.extend_from_slice(&(raw.len() as u32).to_le_bytes());
        assert_eq!(super::members(&one).unwrap().len(), 1);
        assert!(super::gunzip_text(&one).unwrap() == text);
        // A corrupted stored copy fails its CRC.
        one[100] ^= 1;
        assert!(super::gunzip_text(&one).is_err());
    }
}
