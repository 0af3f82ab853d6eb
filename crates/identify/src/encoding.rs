//! The text of a log file as it was written. Most logs are UTF-8 (or ASCII), but Excel's
//! "Unicode text" export is UTF-16 with a byte-order mark, and spreadsheets, PLCs and data
//! loggers in Western Europe and the Americas still write Windows-1252 (`°C` as the byte
//! 0xB0, `µm` as 0xB5), which a UTF-8 reader refuses outright. A file is decoded from its
//! byte-order mark when it has one (UTF-8, UTF-16 LE or BE), as UTF-8 when it is valid
//! UTF-8, and otherwise as Windows-1252, which maps every byte to a character (so nothing
//! is lost and the bytes are read as such a file means them), with a note saying so.

use std::path::Path;

use crate::error::{IdentifyError, Result};

/// A log's text and, when it was not UTF-8, what it was read as (for the notes).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogText {
    /// The decoded text (a UTF-8 byte-order mark kept: the reader removes it).
    pub text: String,
    /// `Some("UTF-16LE")`, `Some("windows-1252")`, …; None for UTF-8.
    pub encoding: Option<&'static str>,
}

/// Decodes the bytes of a log ([module documentation](self)).
pub fn decode(bytes: Vec<u8>) -> LogText {
    if let Some((enc, bom)) = encoding_rs::Encoding::for_bom(&bytes) {
        if enc != encoding_rs::UTF_8 {
            let (text, _) = enc.decode_without_bom_handling(&bytes[bom..]);
            return LogText {
                text: text.into_owned(),
                encoding: Some(enc.name()),
            };
        }
    }
    match String::from_utf8(bytes) {
        Ok(text) => LogText {
            text,
            encoding: None,
        },
        Err(e) => {
            let (text, _) = encoding_rs::WINDOWS_1252.decode_without_bom_handling(e.as_bytes());
            LogText {
                text: text.into_owned(),
                encoding: Some(encoding_rs::WINDOWS_1252.name()),
            }
        }
    }
}

/// Reads and decodes the log at `path` ([`decode`]).
///
/// # Errors
/// The file cannot be read.
pub fn read_log_text(path: &Path) -> Result<LogText> {
    std::fs::read(path)
        .map(decode)
        .map_err(|source| IdentifyError::Io {
            path: path.display().to_string(),
            source,
        })
}

/// Refuses a file named twice, also under two names (`g.csv ./g.csv`): its rows would be one
/// run twice over. A path that cannot be resolved is left to the reader to name.
///
/// # Errors
/// The second name of a file already given.
pub(crate) fn each_file_once(paths: &[std::path::PathBuf]) -> Result<()> {
    let mut seen: Vec<std::path::PathBuf> = Vec::with_capacity(paths.len());
    for p in paths {
        if let Ok(canonical) = std::fs::canonicalize(p) {
            if seen.contains(&canonical) {
                return Err(crate::error::invalid(
                    "--data",
                    p.display(),
                    "each file once (it is named twice)",
                ));
            }
            seen.push(canonical);
        }
    }
    Ok(())
}

/// Reads the CSV logs at `paths` (each decoded by [`decode`]) into one [`Table`] as
/// [`crate::data::read_runs`] reads their texts, with a note first for each file that was
/// not UTF-8.
///
/// # Errors
/// A file cannot be read, or [`crate::data::read_runs`]'s.
pub fn read_log_files(
    paths: &[std::path::PathBuf],
    sel: &crate::data::Selection,
    opts: crate::data::ReadOptions,
) -> Result<crate::data::Table> {
    each_file_once(paths)?;
    let texts: Vec<(LogText, String)> = paths
        .iter()
        .map(|p| Ok((read_log_text(p)?, p.display().to_string())))
        .collect::<Result<_>>()?;
    let refs: Vec<(&str, &str)> = texts
        .iter()
        .map(|(t, n)| (t.text.as_str(), n.as_str()))
        .collect();
    let mut table = crate::data::read_runs(&refs, sel, opts)?;
    let notes = texts.iter().filter_map(|(t, n)| {
        t.encoding.map(|encoding| crate::data::DataIssue::Encoding {
            file: n.clone(),
            encoding,
        })
    });
    table.issues.splice(0..0, notes);
    Ok(table)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Each encoding written here by hand (independent of encoding_rs's encoders) decodes
    /// to the same text.
    #[test]
    fn utf16_and_windows_1252_logs_read_as_their_text() {
        let text = "Zeit [s];Spindel [°C];Weg [µm]\r\n0;20,5;1,25\r\n";
        let utf16le: Vec<u8> = [0xFF, 0xFE]
            .into_iter()
            .chain(text.encode_utf16().flat_map(u16::to_le_bytes))
            .collect();
        let utf16be: Vec<u8> = [0xFE, 0xFF]
            .into_iter()
            .chain(text.encode_utf16().flat_map(u16::to_be_bytes))
            .collect();
        // Windows-1252 of this text: ASCII as is, ° = 0xB0, µ = 0xB5.
        let cp1252: Vec<u8> = text
            .chars()
            .map(|c| match c {
                '°' => 0xB0,
                'µ' => 0xB5,
                c => u8::try_from(u32::from(c)).unwrap(),
            })
            .collect();
        for (bytes, enc) in [
            (utf16le, Some("UTF-16LE")),
            (utf16be, Some("UTF-16BE")),
            (cp1252, Some("windows-1252")),
            (text.as_bytes().to_vec(), None),
        ] {
            let got = decode(bytes);
            assert_eq!(got.text, text);
            assert_eq!(got.encoding, enc);
        }
        let with_bom = decode([&[0xEF, 0xBB, 0xBF][..], text.as_bytes()].concat());
        assert_eq!(with_bom.text, format!("\u{feff}{text}"));
        assert_eq!(with_bom.encoding, None);
    }
}
