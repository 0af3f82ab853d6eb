//! Workbooks as thermal-test logs: Excel (`.xlsx`, `.xlsm`, `.xlsb`, `.xls`) and OpenDocument
//! (`.ods`) files, read with the `calamine` crate (pure Rust).
//!
//! Each sheet read becomes one source of [`data::read_runs`]'s reading, so a workbook gives
//! exactly the table, checks (finite values, time increasing within a run, gaps, runs, bad
//! rows, `--missing error|split`) and column selection of the same values written as a CSV
//! log. A sheet is written for that reading as a CSV text in which line `k` is the sheet's
//! row `k` and field `j` its column `j` (A = 1), so every row number is the sheet's; the
//! messages of bad cells are then given the sheet and the cell in A1 notation
//! (`Sheet 'day 3' cell C17: a_c = "oops" is not a number`).
//!
//! Cells: numbers are numbers (written back in the shortest form that reads back to the same
//! `f64`, so a workbook and a CSV of the same values give the same table to the last bit);
//! text cells are read as the CSV path reads a field (numeric text is a number, a decimal
//! comma honoured: forced by [`ReadOptions::decimal_comma`], or detected when a text cell of
//! a sheet read is written so); empty and error cells (`#DIV/0!`, `#N/A`, …) are missing
//! samples; date/time cells are time stamps (`YYYY-MM-DD hh:mm:ss.mmm` from the serial date,
//! 1900 or 1904 epoch as the workbook declares it, Excel's millisecond resolution), so a
//! date-time column is a time column in seconds since the run's first stamp; a time of day
//! without a date (serial < 1) and a duration (`[h]:mm:ss`) are seconds.
//!
//! Sheets: [`SheetChoice`]. Several sheets read are several runs, as several files are, each
//! named after its sheet (`book:sheet` when several workbooks are read). Target columns in
//! a second workbook (`--target-data`): [`read_paths_with_targets`].

use std::io::Cursor;
use std::path::{Path, PathBuf};

use calamine::{open_workbook_auto_from_rs, Data, Reader as _};

use crate::data::{self, positional_name, DataIssue, ReadOptions, Selection, Table};
use crate::dialect;
use crate::error::{invalid, IdentifyError, Result};

/// File extensions read as workbooks (compared without case).
pub const WORKBOOK_EXTENSIONS: [&str; 5] = ["xlsx", "xlsm", "xlsb", "xls", "ods"];

/// Which sheets of each workbook are read.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SheetChoice {
    /// Sheets by name, or by 1-based number when no sheet has that name (`--sheet`).
    /// Empty: the workbook's only sheet with cells (refused when it has several, unless
    /// [`SheetChoice::all`]).
    pub sheets: Vec<String>,
    /// Every sheet with cells is read, each a run named after the sheet
    /// (`--sheets-as-runs`); with [`SheetChoice::sheets`], those sheets.
    pub all: bool,
}

/// Whether `path` names a workbook (by its extension, see [`WORKBOOK_EXTENSIONS`]).
pub fn is_workbook(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
        WORKBOOK_EXTENSIONS
            .iter()
            .any(|w| w.eq_ignore_ascii_case(e))
    })
}

/// The A1 name of the cell at 0-based `row`, `col` (`A1` for 0, 0; `AA3` for 2, 26).
pub fn cell_name(row: usize, col: usize) -> String {
    let mut letters = Vec::new();
    let mut c = col + 1;
    while c > 0 {
        let r = (c - 1) % 26;
        letters.push(b'A' + r as u8);
        c = (c - 1) / 26;
    }
    letters.reverse();
    format!("{}{}", String::from_utf8_lossy(&letters), row + 1)
}

/// One sheet's cells, from A1 (`cells[row][col]`, rows and columns before the used range
/// empty).
struct SheetCells {
    name: String,
    cells: Vec<Vec<Data>>,
    /// Columns from `--target-data` joined to the right of the sheet's own.
    target: Option<TargetPart>,
}

/// Where the joined target columns of a sheet come from (`--target-data`).
#[derive(Clone)]
struct TargetPart {
    /// The target workbook and its sheet.
    path: String,
    sheet: String,
    /// The first joined column.
    col0: usize,
    /// Row of the joined grid → row of the target sheet.
    rows: Vec<(usize, usize)>,
}

/// The sheets of a workbook (its bytes; `name` for messages) that `choice` selects.
fn sheets_of(bytes: Vec<u8>, name: &str, choice: &SheetChoice) -> Result<Vec<SheetCells>> {
    let mut book = open_workbook_auto_from_rs(Cursor::new(bytes)).map_err(|e| {
        invalid(
            "--data",
            name,
            &format!("an Excel (.xlsx .xlsm .xlsb .xls) or OpenDocument (.ods) workbook ({e})"),
        )
    })?;
    let names = book.sheet_names();
    let listed = || {
        names
            .iter()
            .enumerate()
            .map(|(k, n)| format!("{} '{n}'", k + 1))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut read = |sheet: &str| -> Result<SheetCells> {
        let range = book.worksheet_range(sheet).map_err(|e| {
            invalid(
                "--data",
                format!("{name}, sheet '{sheet}'"),
                &format!("a readable sheet ({e})"),
            )
        })?;
        let mut cells = Vec::new();
        if let (Some((r0, c0)), Some((r1, c1))) = (range.start(), range.end()) {
            let (r0, c0, r1, c1) = (r0 as usize, c0 as usize, r1 as usize, c1 as usize);
            cells = vec![Vec::new(); r0];
            for (k, row) in range.rows().enumerate() {
                let mut cols = vec![Data::Empty; c0];
                cols.extend(row.iter().cloned());
                cols.resize(c1 + 1, Data::Empty);
                if r0 + k <= r1 {
                    cells.push(cols);
                }
            }
        }
        // Trailing empty rows and columns are no data.
        while cells.last().is_some_and(|r| r.iter().all(is_blank)) {
            cells.pop();
        }
        Ok(SheetCells {
            name: sheet.to_string(),
            cells,
            target: None,
        })
    };
    let mut out = Vec::new();
    if choice.sheets.is_empty() {
        for n in &names {
            let s = read(n)?;
            if !s.cells.is_empty() {
                out.push(s);
            }
        }
        if out.len() > 1 && !choice.all {
            return Err(invalid(
                "--data",
                name,
                &format!(
                    "one sheet with data, or a choice: {name} has {} sheets with data ({}); name one or several with --sheet NAME|NUMBER, or read each as a run with --sheets-as-runs",
                    out.len(),
                    out.iter()
                        .map(|s| format!("'{}'", s.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        if out.is_empty() {
            return Err(invalid(
                "--data",
                name,
                &format!("a workbook with data (its sheets {} are empty)", listed()),
            ));
        }
        return Ok(out);
    }
    for want in &choice.sheets {
        let sheet = match names.iter().find(|n| *n == want) {
            Some(n) => n.clone(),
            None => match want.trim().parse::<usize>() {
                Ok(k) if (1..=names.len()).contains(&k) => names[k - 1].clone(),
                _ => {
                    return Err(invalid(
                        "--sheet",
                        want,
                        &format!("a sheet name or number of {name}: {}", listed()),
                    ))
                }
            },
        };
        let s = read(&sheet)?;
        if s.cells.is_empty() {
            return Err(invalid(
                "--sheet",
                want,
                &format!("a sheet with data: sheet '{sheet}' of {name} is empty"),
            ));
        }
        if out.iter().all(|o: &SheetCells| o.name != s.name) {
            out.push(s);
        }
    }
    Ok(out)
}

fn is_blank(d: &Data) -> bool {
    match d {
        Data::Empty => true,
        Data::String(s) => s.trim().is_empty(),
        _ => false,
    }
}

/// A text cell written with a decimal comma (`20,125`): a number read so, not read with a
/// decimal point.
fn is_comma_decimal(s: &str) -> bool {
    let s = s.trim();
    s.contains(',')
        && dialect::parse_number(s, "", true).is_ok()
        && dialect::parse_number(s, "", false).is_err()
}

/// The CSV field of a cell: numbers in the shortest form that reads back exactly (decimal
/// comma when `dc`), text as written (quoted when it holds the delimiter or a quote; line
/// breaks become spaces so that line `k` stays row `k`), date/time cells as time stamps or
/// seconds, empty and error cells empty.
fn field(d: &Data, dc: bool, delim: char) -> String {
    let number = |v: f64| {
        let s = format!("{v}");
        if dc {
            s.replacen('.', ",", 1)
        } else {
            s
        }
    };
    let text = |s: &str| {
        let s = s.trim().replace(['\n', '\r'], " ");
        if s.contains(delim) || s.contains('"') {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s
        }
    };
    match d {
        Data::Empty | Data::Error(_) => String::new(),
        Data::Int(i) => i.to_string(),
        Data::Float(v) => number(*v),
        Data::String(s) | Data::DateTimeIso(s) | Data::DurationIso(s) => text(s),
        Data::Bool(b) => text(if *b { "TRUE" } else { "FALSE" }),
        Data::DateTime(x) => {
            let days = x.as_f64();
            if x.is_datetime() && days >= 1.0 {
                let (y, mo, da, h, mi, s, ms) = x.to_ymd_hms_milli();
                format!("{y:04}-{mo:02}-{da:02} {h:02}:{mi:02}:{s:02}.{ms:03}")
            } else {
                // A time of day without a date, or a duration: seconds, to the millisecond.
                number((days * 86_400_000.0).round() / 1000.0)
            }
        }
    }
}

/// One source of the reading: a CSV text, or a sheet written as one.
struct Source {
    /// Name in messages.
    name: String,
    text: String,
    /// Run name (a sheet's).
    run: String,
    sheet: Option<SheetInfo>,
}

/// What the messages of a sheet need.
struct SheetInfo {
    /// Workbook path.
    path: String,
    sheet: String,
    /// Column names by position (the header row, or c1 … cN).
    header: Vec<String>,
    /// Error cells: (0-based row, column, the error as Excel shows it).
    errors: Vec<(usize, usize, String)>,
    /// The joined target columns (`--target-data`).
    target: Option<TargetPart>,
}

impl SheetInfo {
    /// [`SheetInfo::locate`] after the workbook's name (a target cell's is already there).
    fn locate_in_file(&self, line: u64, reason: &str) -> String {
        let located = self.locate(line, reason);
        match &self.target {
            Some(t) if located.starts_with(&format!("{}: ", t.path)) => located,
            _ => format!("{}: {located}", self.path),
        }
    }

    /// `reason` (a message of the CSV reading about 1-based row `line`, starting with a
    /// column name) with the sheet and the cell: `Sheet 's' cell C17: reason`.
    fn locate(&self, line: u64, reason: &str) -> String {
        let row = usize::try_from(line.saturating_sub(1)).unwrap_or(usize::MAX);
        let col = self
            .header
            .iter()
            .enumerate()
            .filter(|(_, h)| !h.is_empty() && reason.starts_with(&format!("{h} ")))
            .max_by_key(|(k, h)| (h.len(), std::cmp::Reverse(*k)))
            .map(|(k, _)| k);
        match col {
            Some(c) => {
                let err = self
                    .errors
                    .iter()
                    .find(|e| e.0 == row && e.1 == c)
                    .map(|e| format!(" (the cell holds the error {})", e.2))
                    .unwrap_or_default();
                match &self.target {
                    Some(t) if c >= t.col0 => {
                        let r = t.rows.iter().find(|m| m.0 == row).map_or(row, |m| m.1);
                        format!(
                            "{}: Sheet '{}' cell {}: {reason}{err}",
                            t.path,
                            t.sheet,
                            cell_name(r, c - t.col0)
                        )
                    }
                    _ => format!(
                        "Sheet '{}' cell {}: {reason}{err}",
                        self.sheet,
                        cell_name(row, c)
                    ),
                }
            }
            None => format!("Sheet '{}' row {line}: {reason}", self.sheet),
        }
    }
}

fn io_error(p: &Path, source: std::io::Error) -> IdentifyError {
    IdentifyError::Io {
        path: p.display().to_string(),
        source,
    }
}

/// Reads the logs at `paths` into one [`Table`]: CSV files as [`data::read_runs`] reads them,
/// or workbooks (see the module documentation), one run per file or sheet when there are
/// several. A list may not mix CSV files and workbooks; `choice` applies to workbooks only.
pub fn read_paths(
    paths: &[PathBuf],
    sel: &Selection,
    opts: ReadOptions,
    choice: &SheetChoice,
) -> Result<Table> {
    crate::encoding::each_file_once(paths)?;
    let books = paths.iter().filter(|p| is_workbook(p)).count();
    if books == 0 {
        if !choice.sheets.is_empty() || choice.all {
            return Err(invalid(
                if choice.all {
                    "--sheets-as-runs"
                } else {
                    "--sheet"
                },
                paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                "workbooks (.xlsx .xlsm .xlsb .xls .ods); CSV logs have no sheets",
            ));
        }
        return crate::encoding::read_log_files(paths, sel, opts);
    }
    if books < paths.len() {
        return Err(invalid(
            "--data",
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            "either CSV logs or workbooks, not both in one fit",
        ));
    }
    let mut sheets = Vec::new();
    for p in paths {
        let bytes = std::fs::read(p).map_err(|e| io_error(p, e))?;
        sheets.push((
            p.display().to_string(),
            sheets_of(bytes, &p.display().to_string(), choice)?,
        ));
    }
    read_sheets(&sheets, sel, opts)
}

/// [`read_paths`] with the target columns in other workbooks (`--target-data`): workbook k
/// of `targets` holds the target columns of workbook k of `paths`, row by row (the n-th row
/// with data of a sheet, header included, beside the n-th of its target sheet). The target
/// sheet of a sheet is the one of the same name, else the one at the same place when the
/// target workbook has as many sheets with data as are read from the data workbook. Row
/// counts must match. Target cells are named in messages by their own workbook, sheet and
/// cell; with [`ReadOptions::no_header`] their columns continue the numbering (`c23` after
/// 22 columns).
pub fn read_paths_with_targets(
    paths: &[PathBuf],
    targets: &[PathBuf],
    sel: &Selection,
    opts: ReadOptions,
    choice: &SheetChoice,
) -> Result<Table> {
    if targets.is_empty() {
        return read_paths(paths, sel, opts, choice);
    }
    crate::encoding::each_file_once(paths)?;
    let list = |ps: &[PathBuf]| {
        ps.iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if targets.len() != paths.len() {
        return Err(invalid(
            "--target-data",
            list(targets),
            &format!(
                "one target workbook per --data file: {} file(s) for {} ({})",
                targets.len(),
                paths.len(),
                list(paths)
            ),
        ));
    }
    if let Some(p) = paths.iter().chain(targets).find(|p| !is_workbook(p)) {
        return Err(invalid(
            "--target-data",
            p.display(),
            "workbooks (.xlsx .xlsm .xlsb .xls .ods) for --data and --target-data (CSV logs are not joined: put their columns into one file)",
        ));
    }
    let mut books = Vec::new();
    for (p, tp) in paths.iter().zip(targets) {
        let (name, tname) = (p.display().to_string(), tp.display().to_string());
        let sheets = sheets_of(std::fs::read(p).map_err(|e| io_error(p, e))?, &name, choice)?;
        let all = SheetChoice {
            sheets: Vec::new(),
            all: true,
        };
        let tsheets = sheets_of(
            std::fs::read(tp).map_err(|e| io_error(tp, e))?,
            &tname,
            &all,
        )?;
        let n = sheets.len();
        let mut joined = Vec::with_capacity(n);
        for (k, s) in sheets.into_iter().enumerate() {
            let t = match tsheets.iter().find(|t| t.name == s.name) {
                Some(t) => t,
                None if tsheets.len() == n => &tsheets[k],
                None => {
                    return Err(invalid(
                        "--target-data",
                        &tname,
                        &format!(
                            "a sheet '{}' (as in {name}), or as many sheets with data as are read from {name} ({n}); its sheets with data: {}",
                            s.name,
                            tsheets
                                .iter()
                                .map(|t| format!("'{}'", t.name))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ))
                }
            };
            joined.push(join(s, &name, t, &tname)?);
        }
        books.push((name, joined));
    }
    read_sheets(&books, sel, opts)
}

/// The sheet `s` (of workbook `name`) with the columns of target sheet `t` (of `tname`)
/// to its right, the n-th row with data beside the n-th.
fn join(s: SheetCells, name: &str, t: &SheetCells, tname: &str) -> Result<SheetCells> {
    let with_data = |c: &SheetCells| -> Vec<usize> {
        (0..c.cells.len())
            .filter(|&r| !c.cells[r].iter().all(is_blank))
            .collect()
    };
    let (rows, trows) = (with_data(&s), with_data(t));
    if rows.len() != trows.len() {
        return Err(invalid(
            "--target-data",
            tname,
            &format!(
                "as many rows as the data, row for row: sheet '{}' of {tname} has {} row(s) with data, sheet '{}' of {name} has {}",
                t.name,
                trows.len(),
                s.name,
                rows.len()
            ),
        ));
    }
    let col0 = s.cells.iter().map(Vec::len).max().unwrap_or(0);
    let twidth = t.cells.iter().map(Vec::len).max().unwrap_or(0);
    let mut cells = s.cells;
    for (&r, &tr) in rows.iter().zip(&trows) {
        cells[r].resize(col0, Data::Empty);
        cells[r].extend(t.cells[tr].iter().cloned());
        cells[r].resize(col0 + twidth, Data::Empty);
    }
    Ok(SheetCells {
        name: s.name,
        cells,
        target: Some(TargetPart {
            path: tname.to_string(),
            sheet: t.name.clone(),
            col0,
            rows: rows.into_iter().zip(trows).collect(),
        }),
    })
}

/// Reads sheets (`(workbook name, its sheets)`) as [`read_paths`] does.
fn read_sheets(
    books: &[(String, Vec<SheetCells>)],
    sel: &Selection,
    opts: ReadOptions,
) -> Result<Table> {
    if let Some(d) = opts.delimiter {
        return Err(invalid(
            "--delimiter",
            dialect::delimiter_name(d),
            "no delimiter: it is an option of CSV logs, and the data are workbooks",
        ));
    }
    // One decimal separator for the text cells of every sheet read.
    let dc = opts.decimal_comma.unwrap_or_else(|| {
        books.iter().flat_map(|b| &b.1).any(|s| {
            s.cells
                .iter()
                .flatten()
                .any(|d| matches!(d, Data::String(t) if is_comma_decimal(t)))
        })
    });
    let delim = if dc { ';' } else { ',' };
    let count: usize = books.iter().map(|b| b.1.len()).sum();
    let mut sources = Vec::with_capacity(count);
    // Each workbook's run name: its stem, or where stems collide (`a/days.xlsx b/days.xlsx`)
    // as much of its path as tells it apart, as for CSV files.
    let paths: Vec<&str> = books.iter().map(|b| b.0.as_str()).collect();
    let stems = if books.len() > 1 {
        crate::data::file_run_names(&paths)?
    } else {
        paths
            .iter()
            .map(|p| {
                Path::new(p)
                    .file_stem()
                    .map_or(p.to_string(), |s| s.to_string_lossy().into_owned())
            })
            .collect()
    };
    for ((path, sheets), stem) in books.iter().zip(&stems) {
        for s in sheets {
            let width = s.cells.iter().map(Vec::len).max().unwrap_or(0);
            let mut text = String::new();
            let mut errors = Vec::new();
            for (r, row) in s.cells.iter().enumerate() {
                if !row.iter().all(is_blank) {
                    let fields: Vec<String> = (0..width)
                        .map(|c| row.get(c).map_or(String::new(), |d| field(d, dc, delim)))
                        .collect();
                    text.push_str(&fields.join(&delim.to_string()));
                }
                text.push('\n');
                for (c, d) in row.iter().enumerate() {
                    if let Data::Error(e) = d {
                        errors.push((r, c, e.to_string()));
                    }
                }
            }
            let header: Vec<String> = if opts.no_header {
                (0..width).map(positional_name).collect()
            } else {
                let first = s.cells.iter().find(|r| !r.iter().all(is_blank));
                (0..width)
                    .map(|c| {
                        first
                            .and_then(|r| r.get(c))
                            .map_or(String::new(), |d| field(d, false, '\n'))
                    })
                    .collect()
            };
            let run = match (books.len(), sheets.len()) {
                (1, _) => s.name.clone(),
                (_, 1) => stem.clone(),
                _ => format!("{stem}:{}", s.name),
            };
            sources.push(Source {
                name: if count == 1 {
                    path.clone()
                } else {
                    format!("{path}, sheet '{}'", s.name)
                },
                text,
                run,
                sheet: Some(SheetInfo {
                    path: path.clone(),
                    sheet: s.name.clone(),
                    header,
                    errors,
                    target: s.target.clone(),
                }),
            });
        }
    }
    let opts = ReadOptions {
        delimiter: Some(delim as u8),
        decimal_comma: Some(dc),
        ..opts
    };
    read_sources(&sources, sel, opts)
}

/// The reading of `sources`, every message about a row of a sheet given its sheet and cell.
fn read_sources(sources: &[Source], sel: &Selection, opts: ReadOptions) -> Result<Table> {
    let files: Vec<(&str, &str)> = sources
        .iter()
        .map(|s| (s.text.as_str(), s.name.as_str()))
        .collect();
    let runs: Vec<String> = sources.iter().map(|s| s.run.clone()).collect();
    let many = sources.len() > 1;
    // A reason of the reading (`name: reason` with several sources) at `line`, located.
    let locate = |line: u64, reason: &str| -> String {
        if !many {
            return match &sources[0].sheet {
                Some(info) => info.locate(line, reason),
                None => reason.to_string(),
            };
        }
        for s in sources {
            if let (Some(core), Some(info)) =
                (reason.strip_prefix(&format!("{}: ", s.name)), &s.sheet)
            {
                return info.locate_in_file(line, core);
            }
        }
        reason.to_string()
    };
    match data::read_named_runs(&files, &runs, sel, opts) {
        Ok(mut t) => {
            for issue in &mut t.issues {
                match issue {
                    DataIssue::BadRow { line, reason }
                    | DataIssue::Missing { line, reason, .. } => {
                        *reason = locate(*line, reason);
                    }
                    // Gaps and skipped lines (title lines, a units row) name lines only.
                    _ => {}
                }
            }
            Ok(t)
        }
        Err(IdentifyError::BadRows {
            path,
            count,
            lines,
            first_reason,
        }) => {
            // One source: the reason of the first bad line; several: `reason (name: line N)`.
            let first_line: u64 = lines
                .split(|c: char| !c.is_ascii_digit())
                .find_map(|n| n.parse().ok())
                .unwrap_or(0);
            let mut located = None;
            if many {
                for s in sources {
                    let tail = format!(" ({}: line ", s.name);
                    if let (Some(p), Some(info)) = (first_reason.rfind(&tail), &s.sheet) {
                        let line = first_reason[p + tail.len()..]
                            .trim_end_matches(')')
                            .parse::<u64>()
                            .unwrap_or(0);
                        located = Some(info.locate_in_file(line, &first_reason[..p]));
                        break;
                    }
                }
            } else if let Some(info) = &sources[0].sheet {
                located = Some(info.locate(first_line, &first_reason));
            }
            Err(IdentifyError::BadRows {
                path,
                count,
                lines,
                first_reason: located.unwrap_or(first_reason),
            })
        }
        Err(IdentifyError::ColumnNotFound { pattern, available }) if many => {
            // Which source's columns these are.
            let of = sources.iter().find(|s| {
                s.sheet
                    .as_ref()
                    .is_some_and(|i| available.starts_with(&i.header.join(", ")))
            });
            Err(IdentifyError::ColumnNotFound {
                pattern,
                available: match of {
                    Some(s) => format!("{available} (in {})", s.name),
                    None => available,
                },
            })
        }
        Err(e) => Err(e),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn cell_names_in_a1_notation() {
        assert_eq!(cell_name(0, 0), "A1");
        assert_eq!(cell_name(16, 2), "C17");
        assert_eq!(cell_name(2, 25), "Z3");
        assert_eq!(cell_name(2, 26), "AA3");
        assert_eq!(cell_name(0, 51), "AZ1");
        assert_eq!(cell_name(0, 52), "BA1");
        assert_eq!(cell_name(9, 16383), "XFD10");
    }

    #[test]
    fn workbook_extensions() {
        assert!(is_workbook(Path::new("a/b.XLSX")));
        assert!(is_workbook(Path::new("b.ods")));
        assert!(!is_workbook(Path::new("b.csv")));
        assert!(!is_workbook(Path::new("xlsx")));
    }
}
