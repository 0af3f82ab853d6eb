//! CSV dialects of thermal logs as plants export them: the field delimiter (`,` `;` tab),
//! the decimal separator (`20.125` or `20,125`), a UTF-8 byte-order mark, and a time column
//! of wall-clock time stamps instead of seconds. [`crate::data`] reads every dialect into the
//! same table: a log written in any dialect gives exactly the table of the same log written
//! plainly (comma, decimal point, seconds since the run's first row).
//!
//! Time stamps (ISO 8601 / RFC 3339 date and time with `T` or a space, optional fractional
//! seconds, optional `Z` or `±hh:mm` / `±hhmm` / `±hh` offset; or the day-first
//! `dd.mm.yyyy hh:mm:ss[.fff]`) are parsed with `chrono` into instants: stamps with an offset
//! are compared as instants (mixed offsets are fine), stamps without one as wall time, and a
//! log may not mix both.

use chrono::NaiveDateTime;

/// What to do with a row whose used input cell is empty or NaN (a sensor dropout, or a
/// channel logged at a slower rate than the others). An empty target cell is a row without
/// a measurement in every case (`Table::measured`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MissingCells {
    /// The row is a bad row (an error unless bad rows are skipped).
    #[default]
    Error,
    /// The row is left out, listed, and the run is split there: every model state restarts
    /// at the next row.
    Split,
    /// The cell holds the input's last value in its run (a zero-order hold, as the engine
    /// holds a sensor's last sample between updates): the log of channels written at
    /// different rates, merged into one table with empty cells. Rows before a run's first
    /// value of an input are left out and listed; each held column is counted in one note.
    Hold,
}

/// The dialect of one file, detected from its header and first rows unless forced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dialect {
    /// Field delimiter.
    pub delimiter: u8,
    /// Numbers are written with a decimal comma (`20,125`).
    pub decimal_comma: bool,
}

impl Dialect {
    /// The plain dialect: comma delimiter, decimal point.
    pub const PLAIN: Dialect = Dialect {
        delimiter: b',',
        decimal_comma: false,
    };
}

/// `text` without a leading UTF-8 byte-order mark.
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Name of a delimiter for messages.
pub fn delimiter_name(d: u8) -> &'static str {
    match d {
        b',' => "',' (comma)",
        b';' => "';' (semicolon)",
        b'\t' => "tab",
        _ => "other",
    }
}

/// The delimiter named by `--delimiter`: `,` `;` or tab (`tab` or `\t`).
pub fn parse_delimiter(s: &str) -> crate::Result<u8> {
    match s {
        "," | "comma" => Ok(b','),
        ";" | "semicolon" => Ok(b';'),
        "\t" | "\\t" | "tab" => Ok(b'\t'),
        _ => Err(crate::error::invalid(
            "--delimiter",
            s,
            "',' ';' or 'tab' (the field delimiter of the log)",
        )),
    }
}

/// Excel's delimiter line: a first line `sep=X` (X one of `,` `;` tab): X and the text after
/// that line.
pub fn excel_sep_hint(text: &str) -> Option<(u8, &str)> {
    let (first, rest) = text.split_once('\n').unwrap_or((text, ""));
    let first = first.strip_suffix('\r').unwrap_or(first);
    let d = first
        .strip_prefix("sep=")
        .or_else(|| first.strip_prefix("SEP="))?;
    match d.as_bytes() {
        [c @ (b',' | b';' | b'\t')] => Some((*c, rest)),
        _ => None,
    }
}

/// Counts of `,` `;` and tab outside double quotes in `line`.
fn counts(line: &str) -> [usize; 3] {
    let mut n = [0usize; 3];
    let mut quoted = false;
    for b in line.bytes() {
        match b {
            b'"' => quoted = !quoted,
            b',' if !quoted => n[0] += 1,
            b';' if !quoted => n[1] += 1,
            b'\t' if !quoted => n[2] += 1,
            _ => {}
        }
    }
    n
}

/// The delimiter of a log: the one of `,` `;` tab that appears most often in the header
/// line (outside quotes); on a tie or none, `,` before `;` before tab.
pub fn detect_delimiter(text: &str) -> u8 {
    // The header: the first line that is not blank (title lines are read as blank ones).
    let header = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    let n = counts(header);
    let mut best = 0;
    for k in 1..3 {
        if n[k] > n[best] {
            best = k;
        }
    }
    [b',', b';', b'\t'][best]
}

/// Whether `s` is a number written with a decimal comma: optional sign, digits, one comma,
/// digits, optional exponent (`20,125`, `-0,5`, `1,5E-3`).
fn is_comma_decimal(s: &str) -> bool {
    let s = s.trim();
    // A quoted cell ("20,125") as the csv reader will read it.
    let s = s
        .strip_prefix('"')
        .and_then(|q| q.strip_suffix('"'))
        .unwrap_or(s)
        .trim();
    let s = s.strip_prefix(['+', '-']).unwrap_or(s);
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(p) => (&s[..p], Some(&s[p + 1..])),
        None => (s, None),
    };
    let Some((a, b)) = mant.split_once(',') else {
        return false;
    };
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|c| c.is_ascii_digit());
    let exp_ok = exp.is_none_or(|e| digits(e.strip_prefix(['+', '-']).unwrap_or(e)));
    digits(a) && digits(b) && exp_ok
}

/// Whether a log with delimiter `delim` (`;` or tab) writes its numbers with a decimal
/// comma: some cell of a data line is a number with a decimal comma (the scan stops at the
/// first; a log whose first hours are whole numbers is still found). Never for a comma
/// delimiter.
pub fn detect_decimal_comma(text: &str, delim: u8) -> bool {
    if delim == b',' {
        return false;
    }
    text.lines()
        .skip(1)
        .any(|l| l.split(delim as char).any(is_comma_decimal))
}

/// Why a cell is not a value.
#[derive(Debug, Clone, PartialEq)]
pub enum CellError {
    /// Empty, or NaN: a missing sample.
    Missing(String),
    /// Anything else.
    Bad(String),
}

/// A numeric cell of column `col`: a finite number in the file's decimal separator.
pub fn parse_number(s: &str, col: &str, decimal_comma: bool) -> Result<f64, CellError> {
    let parsed = if decimal_comma {
        if s.contains('.') {
            return Err(CellError::Bad(format!(
                "{col} = {s:?} is not a number with a decimal comma (the log writes its numbers as 20,125; force the form with --decimal-comma or --delimiter)"
            )));
        }
        s.replacen(',', ".", 1).parse::<f64>()
    } else {
        s.parse::<f64>()
    };
    match parsed {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) if v.is_nan() => Err(CellError::Missing(format!("{col} is NaN"))),
        Ok(v) => Err(CellError::Bad(format!("{col} = {v} is not finite"))),
        Err(_) if s.is_empty() => Err(CellError::Missing(format!("{col} is empty"))),
        Err(_) if decimal_comma => Err(CellError::Bad(format!(
            "{col} = {s:?} is not a number (expected a number with a decimal comma, e.g. 20,125)"
        ))),
        Err(_) if is_comma_decimal(s) => Err(CellError::Bad(format!(
            "{col} = {s:?} is not a number (written with a decimal comma: the log's delimiter must be ';' or tab, force the form with --decimal-comma)"
        ))),
        // Text without a digit is most often a logger's or a spreadsheet's mark for a
        // missing sample (#N/A, OVF, ---, Err): say how to read it as one.
        Err(_) if !s.bytes().any(|b| b.is_ascii_digit()) => Err(CellError::Bad(format!(
            "{col} = {s:?} is not a number (a logger's mark for a missing sample? --missing-code={s:?} reads it as an empty cell)"
        ))),
        Err(_) => Err(CellError::Bad(format!("{col} = {s:?} is not a number"))),
    }
}

/// The accepted time-stamp forms, for messages.
pub const TIMESTAMP_FORMS: &str =
    "seconds, a time stamp 2024-03-01 08:00:00[.250][Z|+01:00] (ISO 8601, 'T' or ' '), 2024/03/01 08:00[:00], 01.03.2024 08:00:00, or 01/03/2024 08:00[:00] [AM|PM] (day or month first: --date-order), or a clock or elapsed time h:mm:ss[.250]";

/// The order of day and month in a slash date (`03/01/2024`): spreadsheets and loggers
/// write the day first in most of Europe and the month first in the United States.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DateOrder {
    /// `25/11/2026`.
    DayFirst,
    /// `11/25/2026`.
    MonthFirst,
}

/// The two numbers before the year of a slash date at the start of `s` (`03/01/2024 …`).
fn slash_fields(s: &str) -> Option<(u32, u32)> {
    let mut it = s.split('/');
    let a: u32 = it.next()?.trim().parse().ok()?;
    let b: u32 = it.next()?.trim().parse().ok()?;
    let rest = it.next()?;
    (rest.len() >= 4 && rest.as_bytes()[..4].iter().all(u8::is_ascii_digit)).then_some((a, b))
}

/// Whether `s` starts with a slash date with the year last (`25/11/2026 …`).
pub fn is_slash_date(s: &str) -> bool {
    slash_fields(s).is_some()
}

/// What a file's slash dates say of their order ([`date_order_of`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DatesSay {
    /// No date of the file reads only one way (or the cells are no slash dates).
    Nothing,
    /// Every date that reads only one way reads so: the first of them (line, cell).
    Order(DateOrder, u64, String),
    /// Dates that read only day first and dates that read only month first: the first of
    /// each (line, cell).
    Both((u64, String), (u64, String)),
}

/// The order of a file's slash dates from the ones that read only one way (a first number
/// over 12: day first; a second one over 12: month first), over every cell (line, text) of
/// its date column. A log that starts on the 1st–12th of a month is ambiguous on its first
/// rows only: its later dates name the order, and every date of the file is read so.
pub fn date_order_of<'a>(cells: impl Iterator<Item = (u64, &'a str)>) -> DatesSay {
    let mut dmy: Option<(u64, String)> = None;
    let mut mdy: Option<(u64, String)> = None;
    for (line, cell) in cells {
        let c = cell.trim().trim_matches('"').trim();
        let Some((a, b)) = slash_fields(c) else {
            continue;
        };
        let month = 1..=12;
        let (d, m) = (
            a > 12 && month.contains(&b) && dmy.is_none(),
            b > 12 && month.contains(&a) && mdy.is_none(),
        );
        // The date itself (a DATE column, or the date of a stamp) must be a real one.
        let date = c.split_whitespace().next().unwrap_or("");
        let real = |f: &str| chrono::NaiveDate::parse_from_str(date, f).is_ok();
        if d && real("%d/%m/%Y") {
            dmy = Some((line, c.to_string()));
        }
        if m && real("%m/%d/%Y") {
            mdy = Some((line, c.to_string()));
        }
        if dmy.is_some() && mdy.is_some() {
            break;
        }
    }
    match (dmy, mdy) {
        (Some(d), Some(m)) => DatesSay::Both(d, m),
        (Some((l, c)), None) => DatesSay::Order(DateOrder::DayFirst, l, c),
        (None, Some((l, c))) => DatesSay::Order(DateOrder::MonthFirst, l, c),
        (None, None) => DatesSay::Nothing,
    }
}

/// Whether `s` is a slash date whose day and month could be either way round (both
/// numbers 1–12 and different): only `--date-order` can say which it is.
pub fn is_ambiguous_slash_date(s: &str) -> bool {
    matches!(slash_fields(s.trim()), Some((a, b)) if a != b && (1..=12).contains(&a) && (1..=12).contains(&b))
}

/// A parsed time stamp: nanoseconds since 1970-01-01 00:00 of UTC (with an offset) or of
/// the wall clock (without one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// Nanoseconds since the epoch.
    pub nanos: i64,
    /// The stamp carried a UTC offset (or `Z`): `nanos` is an instant.
    pub has_offset: bool,
}

/// Offset in seconds of a trailing `Z`, `±hh:mm`, `±hhmm` or `±hh` of `s` (after its date),
/// and the text before it.
fn split_offset(s: &str) -> Option<(&str, Option<i64>)> {
    if let Some(body) = s.strip_suffix(['Z', 'z']) {
        return Some((body.trim_end(), Some(0)));
    }
    // The sign of an offset comes after the time part (past the date's own '-').
    let p = match s.rfind(['+', '-']) {
        Some(p) if p >= 11 => p,
        _ => return Some((s, None)),
    };
    let (body, off) = s.split_at(p);
    let sign = if off.starts_with('-') { -1 } else { 1 };
    let digits: String = off[1..].chars().filter(|&c| c != ':').collect();
    if !(digits.len() == 2 || digits.len() == 4) || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    let h: i64 = digits[..2].parse().ok()?;
    let m: i64 = if digits.len() == 4 {
        digits[2..].parse().ok()?
    } else {
        0
    };
    if h > 23 || m > 59 {
        return None;
    }
    Some((body.trim_end(), Some(sign * (h * 3600 + m * 60))))
}

/// Parses a time stamp (see [`TIMESTAMP_FORMS`]); `None` when it is not one, or when it is
/// a slash date whose day and month could be either way round
/// ([`is_ambiguous_slash_date`]; [`parse_timestamp_in`] with an order reads it).
pub fn parse_timestamp(s: &str) -> Option<Stamp> {
    parse_timestamp_in(s, None)
}

/// [`parse_timestamp`] with the order of a slash date's day and month given (`None`: from
/// the date itself, when one of its numbers exceeds 12 or both are equal).
pub fn parse_timestamp_in(s: &str, order: Option<DateOrder>) -> Option<Stamp> {
    let s = s.trim();
    if s.len() < 14 || !s.as_bytes()[0].is_ascii_digit() {
        return None;
    }
    let (body, offset) = split_offset(s)?;
    // Day-first stamps may write fractional seconds with a comma.
    let body = body.replacen(',', ".", 1);
    // Year first with slashes (`2024/03/01 08:00:00`) is what Japanese and Chinese data
    // loggers write: never ambiguous.
    const FORMS: [&str; 8] = [
        "%Y-%m-%d %H:%M:%S%.f",
        "%Y-%m-%dT%H:%M:%S%.f",
        "%d.%m.%Y %H:%M:%S%.f",
        "%Y/%m/%d %H:%M:%S%.f",
        "%Y-%m-%d %H:%M",
        "%Y-%m-%dT%H:%M",
        "%d.%m.%Y %H:%M",
        "%Y/%m/%d %H:%M",
    ];
    const DAY_FIRST: [&str; 4] = [
        "%d/%m/%Y %H:%M:%S%.f",
        "%d/%m/%Y %H:%M",
        "%d/%m/%Y %I:%M:%S%.f %p",
        "%d/%m/%Y %I:%M %p",
    ];
    const MONTH_FIRST: [&str; 4] = [
        "%m/%d/%Y %H:%M:%S%.f",
        "%m/%d/%Y %H:%M",
        "%m/%d/%Y %I:%M:%S%.f %p",
        "%m/%d/%Y %I:%M %p",
    ];
    let slash = match (slash_fields(&body), order) {
        (None, _) => &[][..],
        (Some(_), Some(DateOrder::DayFirst)) => &DAY_FIRST[..],
        (Some(_), Some(DateOrder::MonthFirst)) => &MONTH_FIRST[..],
        (Some((a, b)), None) if a > 12 || a == b => &DAY_FIRST[..],
        (Some((_, b)), None) if b > 12 => &MONTH_FIRST[..],
        (Some(_), None) => return None,
    };
    let naive = FORMS
        .iter()
        .chain(slash)
        .find_map(|f| NaiveDateTime::parse_from_str(&body, f).ok())?;
    let nanos = naive.and_utc().timestamp_nanos_opt()?;
    let nanos = nanos.checked_sub(offset.unwrap_or(0).checked_mul(1_000_000_000)?)?;
    Some(Stamp {
        nanos,
        has_offset: offset.is_some(),
    })
}

/// A clock or elapsed time `h:mm:ss[.fff]` (hours of any count up to 9 999 999, minutes and
/// seconds below 60; a decimal comma when the file writes one): seconds since 0:00:00.
/// Loggers write the time of day alone, or the time since the start of the test (`46:00:00`).
pub fn parse_clock(s: &str, decimal_comma: bool) -> Option<f64> {
    let mut f = s.trim().split(':');
    let (h, m, sec) = (f.next()?, f.next()?, f.next()?);
    if f.next().is_some() {
        return None;
    }
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    if !(digits(h) && h.len() <= 7 && m.len() == 2 && digits(m)) {
        return None;
    }
    let sep = if decimal_comma { ',' } else { '.' };
    let (whole, frac) = match sec.split_once(sep) {
        Some((w, f)) if digits(f) => (w, f),
        Some(_) => return None,
        None => (sec, ""),
    };
    if !(whole.len() == 2 && digits(whole)) {
        return None;
    }
    let (h, m, whole): (f64, f64, f64) = (h.parse().ok()?, m.parse().ok()?, whole.parse().ok()?);
    if m >= 60.0 || whole >= 60.0 {
        return None;
    }
    let frac: f64 = if frac.is_empty() {
        0.0
    } else {
        format!("0.{frac}").parse().ok()?
    };
    Some(h * 3600.0 + m * 60.0 + whole + frac)
}

/// Whether the cell looks like a time stamp rather than seconds: it is no number (in the
/// file's decimal form) but parses as a time stamp or a clock time ([`parse_clock`]).
pub fn is_timestamp(s: &str, decimal_comma: bool) -> bool {
    parse_number(s, "", decimal_comma).is_err()
        && (parse_timestamp(s).is_some()
            || parse_clock(s, decimal_comma).is_some()
            || (is_ambiguous_slash_date(s)
                && parse_timestamp_in(s, Some(DateOrder::DayFirst)).is_some()))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Clock and elapsed times against hand-computed seconds; anything else is not one.
    #[test]
    fn clock_times_are_seconds_since_midnight_or_start() {
        let cases = [
            ("0:00:00", false, 0.0),
            ("08:00:00", false, 28_800.0),
            ("23:59:59.5", false, 86_399.5),
            ("46:00:30", false, 165_630.0),
            ("1234567:00:00", false, 4_444_441_200.0),
            ("0:01:02,25", true, 62.25),
            (" 12:30:00 ", false, 45_000.0),
        ];
        for (s, dc, want) in cases {
            assert_eq!(parse_clock(s, dc), Some(want), "{s}");
            assert!(is_timestamp(s, dc), "{s}");
        }
        for bad in [
            "12:30",
            "1:2:3",
            "00:60:00",
            "00:00:60",
            "a:00:00",
            "1:00:00:00",
            "-1:00:00",
            "12345678:00:00",
            "0:00:00.",
            "0:00:00.5x",
            "0:00:00,5",
            "",
            "08:00 AM",
        ] {
            assert_eq!(parse_clock(bad, false), None, "{bad}");
        }
        assert_eq!(parse_clock("0:00:00.5", true), None);
    }

    #[test]
    fn delimiters_and_decimal_commas_are_detected() {
        assert_eq!(detect_delimiter("time_s;a_c;b_c\n0;1,5;2\n"), b';');
        assert_eq!(detect_delimiter("time_s\ta_c\n"), b'\t');
        assert_eq!(detect_delimiter("time_s,a_c\n"), b',');
        assert_eq!(detect_delimiter("\"a;b\",c\n"), b',');
        assert!(detect_decimal_comma("t;a\n0;20,125\n", b';'));
        assert!(!detect_decimal_comma("t;a\n0;20.125\n", b';'));
        let late = format!("t;a\n{}1000;20,5\n", "0;20\n".repeat(500));
        assert!(detect_decimal_comma(&late, b';'));
        assert!(matches!(
            parse_number("20,5", "a_c", false),
            Err(CellError::Bad(m)) if m.contains("--decimal-comma")
        ));
        assert!(!detect_decimal_comma("t,a\n0,\"20,125\"\n", b','));
        assert_eq!(excel_sep_hint("sep=;\r\na;b\r\n"), Some((b';', "a;b\r\n")));
        assert_eq!(excel_sep_hint("sep=|\na|b\n"), None);
        assert_eq!(excel_sep_hint("time_s;a\n"), None);
        assert!(is_comma_decimal("-1,5E-3"));
        assert!(is_comma_decimal("\"20,125\""));
        assert!(!is_comma_decimal("1,5,3"));
        assert!(!is_comma_decimal("a,5"));
    }

    /// Hand-computed instants: 2024-03-01 is day 54·365 + 13 (leap days 1972…2020) + 31 + 29
    /// = 19783 after 1970-01-01.
    #[test]
    fn time_stamps_are_instants() {
        let day = 19_783i64 * 86_400;
        let at = |s: &str| parse_timestamp(s).unwrap().nanos;
        let s8 = (day + 8 * 3600) * 1_000_000_000;
        assert_eq!(at("2024-03-01 08:00:00"), s8);
        assert_eq!(at("2024-03-01T08:00:00"), s8);
        assert_eq!(at("01.03.2024 08:00:00"), s8);
        assert_eq!(at("2024-03-01 08:00"), s8);
        assert_eq!(at("2024-03-01T08:00:00.250Z"), s8 + 250_000_000);
        assert_eq!(at("01.03.2024 08:00:00,5"), s8 + 500_000_000);
        assert_eq!(at("2024-03-01T09:00:00+01:00"), s8);
        assert_eq!(at("2024-03-01T09:00:00+0100"), s8);
        assert_eq!(at("2024-03-01T03:30:00-04:30"), s8);
        // Slash dates: 1 March 2024 day first, month first, with AM/PM; a day above 12
        // decides by itself; either way round needs the order.
        let (dmy, mdy) = (Some(DateOrder::DayFirst), Some(DateOrder::MonthFirst));
        let slash = |s: &str, o| parse_timestamp_in(s, o).unwrap().nanos;
        assert_eq!(slash("01/03/2024 08:00:00", dmy), s8);
        assert_eq!(slash("03/01/2024 08:00:00", mdy), s8);
        assert_eq!(slash("03/01/2024 08:00:00 AM", mdy), s8);
        assert_eq!(
            slash("3/1/2024 8:00 PM", mdy),
            s8 + 12 * 3600 * 1_000_000_000
        );
        assert_eq!(
            slash("01/03/2024 12:00:00 AM", dmy),
            s8 - 8 * 3600 * 1_000_000_000
        );
        let day = 24 * 3600 * 1_000_000_000i64;
        assert_eq!(slash("25/03/2024 08:00", None), s8 + 24 * day);
        assert_eq!(slash("03/25/2024 08:00", None), s8 + 24 * day);
        assert_eq!(slash("03/03/2024 08:00", None), s8 + 2 * day);
        assert!(parse_timestamp("01/03/2024 08:00:00").is_none());
        assert!(is_ambiguous_slash_date("01/03/2024 08:00:00"));
        assert!(!is_ambiguous_slash_date("25/03/2024 08:00:00"));
        assert!(!is_ambiguous_slash_date("2024-03-01 08:00:00"));
        assert!(is_timestamp("01/03/2024 08:00:00", false));
        assert!(parse_timestamp_in("25/03/2024 08:00", mdy).is_none());
        assert!(parse_timestamp("2024-03-01T08:00:00Z").unwrap().has_offset);
        assert!(!parse_timestamp("2024-03-01 08:00:00").unwrap().has_offset);
        for bad in [
            "2024-13-01 08:00:00",
            "2024-02-30 08:00:00",
            "2024-03-01 25:00:00",
            "2024-03-01 08:00:00+1:00",
            "yesterday at noon",
            "12.5",
            "2024-03-01",
        ] {
            assert!(parse_timestamp(bad).is_none(), "{bad}");
        }
    }

    #[test]
    fn numbers_in_both_decimal_forms() {
        assert_eq!(parse_number("20,125", "a", true), Ok(20.125));
        assert_eq!(parse_number("20.125", "a", false), Ok(20.125));
        assert!(matches!(
            parse_number("", "a", true),
            Err(CellError::Missing(_))
        ));
        assert!(matches!(
            parse_number("NaN", "a", false),
            Err(CellError::Missing(_))
        ));
        assert!(matches!(
            parse_number("1.234,5", "a", true),
            Err(CellError::Bad(_))
        ));
        assert!(matches!(
            parse_number("inf", "a", false),
            Err(CellError::Bad(_))
        ));
    }
}
