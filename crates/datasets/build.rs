//! Inflates the embedded FL_THERMAL (`data/fl_thermal.csv.gz`, kept compressed in the
//! repository) into the build's output directory, where `src/lib.rs` embeds the text as it
//! is: the binary then holds the 4.4 MB CSV itself and reading it costs no decompression at
//! run time (docs/identification.md, "Performance"). The gzip trailers' CRC-32 and lengths
//! are checked by the decoder: a damaged file fails the build, not a run.

use std::io::Read;

fn main() {
    let src = "data/fl_thermal.csv.gz";
    println!("cargo:rerun-if-changed={src}");
    let gz = match std::fs::read(src) {
        Ok(b) => b,
        Err(e) => panic!("read {src}: {e}"),
    };
    // The file may hold several gzip members (RFC 1952 §2.2): one text.
    let mut text = Vec::new();
    if let Err(e) = flate2::read::MultiGzDecoder::new(&gz[..]).read_to_end(&mut text) {
        panic!("inflate {src}: {e}");
    }
    if std::str::from_utf8(&text).is_err() {
        panic!("{src}: the CSV is not UTF-8");
    }
    let out = match std::env::var_os("OUT_DIR") {
        Some(d) => std::path::PathBuf::from(d).join("fl_thermal.csv"),
        None => panic!("OUT_DIR is not set (build scripts run under cargo)"),
    };
    if let Err(e) = std::fs::write(&out, &text) {
        panic!("write {}: {e}", out.display());
    }
}
