//! Public data sets shipped inside gearcomp so tests, demos and benchmarks run offline.
//!
//! * FL_THERMAL: a real 46.3-hour machine-tool spindle thermal test (CAIVIAC/FL_THERMAL,
//!   commit 293b225, MIT licence in `data/FL_THERMAL_LICENSE`): 11,115 rows every 15 s,
//!   `time_s, spindle_rpm, ch1_um … ch5_um, t1_c … t16_c`. See `data/FL_THERMAL_README.md`.

use std::io::Read;

const FL_THERMAL_GZ: &[u8] = include_bytes!("../data/fl_thermal.csv.gz");

/// The licence text of the FL_THERMAL data (MIT).
pub const FL_THERMAL_LICENSE: &str = include_str!("../data/FL_THERMAL_LICENSE");

/// The FL_THERMAL CSV text (decompressed from the embedded copy).
pub fn fl_thermal_csv() -> std::io::Result<String> {
    let mut out = String::with_capacity(4_500_000);
    flate2::read::GzDecoder::new(FL_THERMAL_GZ).read_to_string(&mut out)?;
    Ok(out)
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
}
