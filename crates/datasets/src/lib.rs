//! Public data sets shipped inside gearcomp so tests, demos and benchmarks run offline.
//!
//! * FL_THERMAL: a real 46.3-hour machine-tool spindle thermal test (CAIVIAC/FL_THERMAL,
//!   commit 293b225, MIT licence in `data/FL_THERMAL_LICENSE`): 11,115 rows every 15 s,
//!   `time_s, spindle_rpm, ch1_um … ch5_um, t1_c … t16_c`. See `data/FL_THERMAL_README.md`.
//!
//! The repository keeps the CSV gzip-compressed (`data/fl_thermal.csv.gz`); the build script
//! inflates it once, and the binary holds the text itself, so a run reads it with no
//! decompression (docs/identification.md, "Performance").

/// The FL_THERMAL CSV text (the repository's `data/fl_thermal.csv.gz`, inflated when the
/// crate is built).
pub const FL_THERMAL_CSV: &str = include_str!(concat!(env!("OUT_DIR"), "/fl_thermal.csv"));

/// The licence text of the FL_THERMAL data (MIT).
pub const FL_THERMAL_LICENSE: &str = include_str!("../data/FL_THERMAL_LICENSE");

/// The FL_THERMAL CSV text ([`FL_THERMAL_CSV`]).
pub fn fl_thermal_csv() -> &'static str {
    FL_THERMAL_CSV
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use std::io::Read;

    #[test]
    fn fl_thermal_has_header_and_all_rows() {
        let text = super::fl_thermal_csv();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("time_s,spindle_rpm,ch1_um"));
        assert_eq!(header.split(',').count(), 23);
        assert_eq!(lines.filter(|l| !l.trim().is_empty()).count(), 11_115);
        assert!(super::FL_THERMAL_LICENSE.contains("MIT"));
    }

    /// The embedded text is the repository's gzip file inflated here, member by member, by
    /// the decoder of one member at a time (not the multi-member reader the build uses),
    /// each member checked against its own trailer's length.
    #[test]
    fn embedded_text_is_the_repository_gzip_inflated() {
        let gz: &[u8] = include_bytes!("../data/fl_thermal.csv.gz");
        let mut rest = gz;
        let mut text = Vec::new();
        let mut members = 0;
        while !rest.is_empty() {
            let mut d = flate2::bufread::GzDecoder::new(rest);
            let mut part = Vec::new();
            d.read_to_end(&mut part).unwrap();
            rest = d.into_inner();
            members += 1;
            text.extend(part);
        }
        assert!(members >= 1);
        assert_eq!(text.len(), 4_373_542);
        assert!(text == super::FL_THERMAL_CSV.as_bytes());
    }
}
