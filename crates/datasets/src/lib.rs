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

/// A one-member gzip file (RFC 1952) inflated in one call straight into a buffer of the
/// size its trailer states (no intermediate stream buffer: the decompression dominates
/// reading the data), checked against the trailer's length and CRC-32, as UTF-8 text.
fn gunzip_text(gz: &[u8]) -> std::io::Result<String> {
    let bad = |what: &str| Error::new(ErrorKind::InvalidData, format!("gzip: {what}"));
    if gz.len() < 18 || gz[0] != 0x1f || gz[1] != 0x8b || gz[2] != 8 {
        return Err(bad("not a deflate gzip member"));
    }
    let flags = gz[3];
    let mut i = 10;
    if flags & 4 != 0 {
        i += 2 + (usize::from(gz[i]) | usize::from(gz[i + 1]) << 8);
        if i >= gz.len() {
            return Err(bad("truncated header"));
        }
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
    let body_end = gz.len() - 8;
    let body = gz.get(i..body_end).ok_or_else(|| bad("truncated"))?;
    let word = |k: usize| u32::from_le_bytes([gz[k], gz[k + 1], gz[k + 2], gz[k + 3]]);
    let (crc, size) = (word(body_end), word(body_end + 4) as usize);
    let mut out = Vec::with_capacity(size);
    flate2::Decompress::new(false)
        .decompress_vec(body, &mut out, flate2::FlushDecompress::Finish)
        .map_err(|e| bad(&e.to_string()))?;
    let mut sum = flate2::Crc::new();
    sum.update(&out);
    if out.len() != size || sum.sum() != crc {
        return Err(bad("length or CRC-32 differs from the trailer"));
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
    }
}
