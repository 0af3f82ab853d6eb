//! What stands around the table of a real log: title lines above the header (a data
//! logger's export names the machine, the test and the date first) and a units row under
//! it (`s;°C;°C;µm`). Both are found from the selected columns and read as blank lines, so
//! every line keeps its number in the file and each is reported by it.
//!
//! The header is the first line in which every selected column is found: the time column
//! (or both parts of `DATE+TIME`; none with a sample interval), the run column, and at least
//! one column for each input and target name or pattern. Only the first
//! [`MAX_TITLE_LINES`] lines are searched, and only when the first line is not that header.
//! A units row is the line right under the header when every selected input and target
//! cell of it is text that is not a number (an empty cell is not a unit: such a line is
//! data with missing cells, reported as such). When no line names every column, the first
//! line naming the time column is taken for the header (when the first line does not), so
//! that the reader's error names the column that header lacks; without one either, the
//! first line whose shape is a header's (names over data of the same width, perhaps with a
//! units row between: a data logger's `No.,Date&Time,ms,CH1,…`), so that the error lists
//! the log's own columns rather than a title line's words. The default time column
//! (`time_s`, not in the log) stands for the log's one column that reads as a time axis, as
//! the reader takes it.

use globset::Glob;

/// Lines searched for the header when the first line is not it.
pub const MAX_TITLE_LINES: usize = 200;

/// A log with its title lines and units row read as blank lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Preamble {
    /// The text, each skipped line emptied (line numbers unchanged).
    pub text: String,
    /// What was skipped: (1-based line, what), in line order.
    pub skipped: Vec<(u64, String)>,
    /// The fields of the units row, by the header's column positions (empty without one).
    pub units: Vec<String>,
}

/// The delimiter of one line, as the reader detects a header's (`forced` when the user
/// named one).
fn line_delimiter(line: &str, forced: Option<u8>) -> u8 {
    forced.unwrap_or_else(|| crate::dialect::detect_delimiter(line))
}

/// The trimmed fields of one line (quotes as the csv reader reads them).
fn fields(line: &str, delimiter: u8) -> Vec<String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(line.as_bytes());
    rdr.records()
        .next()
        .and_then(|r| r.ok())
        .map(|r| r.iter().map(str::to_string).collect())
        .unwrap_or_default()
}

/// Indices of the fields a name or glob pattern selects (exact names first, as the reader).
fn matches(pattern: &str, header: &[String]) -> Vec<usize> {
    let exact: Vec<usize> = (0..header.len())
        .filter(|&i| header[i] == pattern)
        .collect();
    if !exact.is_empty() {
        return exact;
    }
    match Glob::new(pattern) {
        Ok(g) => {
            let m = g.compile_matcher();
            (0..header.len())
                .filter(|&i| m.is_match(header[i].as_str()))
                .collect()
        }
        Err(_) => Vec::new(),
    }
}

/// The columns a log's reader looks for (borrowed from its selection).
#[derive(Debug, Clone, Copy)]
pub struct Wanted<'a> {
    /// The time column (or `DATE+TIME`); None when the log has a sample interval instead.
    pub time: Option<&'a str>,
    /// The run column, if any.
    pub run: Option<&'a str>,
    /// Input names or glob patterns.
    pub inputs: &'a [String],
    /// Target names or glob patterns.
    pub targets: &'a [String],
}

/// The selected input and target columns of `header`, or None when a selected column is
/// missing from it.
fn selected(header: &[String], w: &Wanted) -> Option<Vec<usize>> {
    if let Some(time) = w.time.filter(|t| !header.iter().any(|h| h == t)) {
        // The default time column stands for the one column that reads as a time axis, as
        // the reader takes it.
        let lone_time = time == crate::time_unit::DEFAULT_TIME_COLUMN
            && header
                .iter()
                .filter(|h| crate::time_unit::looks_like_time(h))
                .count()
                == 1;
        if !lone_time {
            let (d, t) = time.split_once('+')?;
            if !(header.iter().any(|h| h == d) && header.iter().any(|h| h == t)) {
                return None;
            }
        }
    }
    if let Some(run) = w.run {
        if !header.iter().any(|h| h == run) {
            return None;
        }
    }
    let mut cols = Vec::new();
    for p in w.inputs.iter().chain(w.targets) {
        let m = matches(p, header);
        if m.is_empty() {
            return None;
        }
        cols.extend(m);
    }
    Some(cols)
}

/// Whether a cell is a number (a decimal point, or a decimal comma when `,` does not
/// delimit).
fn is_number(cell: &str, delimiter: u8) -> bool {
    let c = cell.trim();
    c.parse::<f64>().is_ok() || (delimiter != b',' && c.replace(',', ".").parse::<f64>().is_ok())
}

/// Whether line `k` is a header by its shape alone: at least two fields, every one a
/// non-empty name that is no number, over data of the same width (the next non-blank line,
/// or the one after a units row: the same width, no numbers, and an empty cell or every
/// cell a short word such as `°C` or `[s]`), at least half of whose fields are numbers.
fn shape_header(lines: &[&str], k: usize, forced: Option<u8>) -> Option<(u8, Vec<usize>)> {
    let d = line_delimiter(lines[k], forced);
    let names = fields(lines[k], d);
    if names.len() < 2 || names.iter().any(|f| f.is_empty() || is_number(f, d)) {
        return None;
    }
    let mut next = (k + 1..lines.len()).filter(|&j| !lines[j].trim().is_empty());
    let width = |j: usize| fields(lines[j], d);
    let numbers = |f: &[String]| f.iter().filter(|c| is_number(c, d)).count();
    let mut row = width(next.next()?);
    let unit_like =
        |f: &[String]| f.iter().any(|c| c.is_empty()) || f.iter().all(|c| c.chars().count() <= 8);
    // Its columns: those with a unit under them when there is a units row (so that the row
    // is found as one, its empty cells under the time and counter columns notwithstanding),
    // else every one.
    let mut cols: Vec<usize> = (0..names.len()).collect();
    if row.len() == names.len() && numbers(&row) == 0 && unit_like(&row) {
        cols.retain(|&c| row.get(c).is_some_and(|u| !u.is_empty()));
        row = width(next.next()?);
    }
    (row.len() == names.len() && 2 * numbers(&row) >= row.len()).then_some((d, cols))
}

fn shown(line: &str) -> String {
    let line = line.trim();
    let mut s: String = line.chars().take(40).collect();
    if line.chars().count() > 40 {
        s.push('…');
    }
    s
}

/// Title lines above the header and a units row under it, when `text` (one log, its BOM
/// removed) has them; None when the first non-blank line is the header and no units row
/// follows (the text is then read as it is). `delimiter`: the one the user forced, if any.
pub fn find(text: &str, wanted: &Wanted, delimiter: Option<u8>) -> Option<Preamble> {
    let lines: Vec<&str> = text
        .split('\n')
        .take(MAX_TITLE_LINES + 2)
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .collect();
    let first = lines.iter().position(|l| !l.trim().is_empty())?;
    let header_at = |k: usize| {
        let d = line_delimiter(lines[k], delimiter);
        selected(&fields(lines[k], d), wanted).map(|c| (d, c))
    };
    let search =
        || (first + 1..lines.len().min(MAX_TITLE_LINES)).filter(|&k| !lines[k].trim().is_empty());
    // Without a line that names every column, the first that names the time column is
    // the header, so that the reader's error names what that header lacks.
    let time_header = |k: usize| {
        let d = line_delimiter(lines[k], delimiter);
        let f = fields(lines[k], d);
        let full = wanted.time?;
        let time = full.split_once('+').map_or(full, |(d, _)| d);
        f.iter().any(|h| h == full || h == time).then_some(())?;
        Some((d, Vec::new()))
    };
    // Without a line naming the columns, the header is the first line of names over the
    // data (`shape_header`), when the first line is not one: the reader's error then lists
    // the log's own columns, not the words of a title line.
    let (head, (d, cols)) = match header_at(first) {
        Some(h) => (first, h),
        None => search()
            .find_map(|k| header_at(k).map(|h| (k, h)))
            .or_else(|| {
                time_header(first).is_none().then_some(())?;
                search().find_map(|k| time_header(k).map(|h| (k, h)))
            })
            .or_else(|| {
                shape_header(&lines, first, delimiter)
                    .is_none()
                    .then_some(())?;
                search().find_map(|k| shape_header(&lines, k, delimiter).map(|h| (k, h)))
            })?,
    };
    let mut skipped: Vec<(u64, String)> = Vec::new();
    let titles: Vec<usize> = (first..head)
        .filter(|&k| !lines[k].trim().is_empty())
        .collect();
    if let Some(&a) = titles.first() {
        let what = format!(
            "{} title line(s) above the header (line {}) skipped, from «{}»",
            titles.len(),
            head + 1,
            shown(lines[a])
        );
        skipped.push(((a + 1) as u64, what));
    }
    let mut blank: Vec<usize> = titles;
    let mut units_row = Vec::new();
    if let Some(u) = (head + 1..lines.len()).find(|&k| !lines[k].trim().is_empty()) {
        let cells = fields(lines[u], d);
        let units = !cols.is_empty()
            && cols.iter().all(|&c| {
                cells
                    .get(c)
                    .is_some_and(|v| !v.is_empty() && !is_number(v, d))
            });
        if units {
            skipped.push((
                (u + 1) as u64,
                format!("units row under the header skipped: «{}»", shown(lines[u])),
            ));
            blank.push(u);
            units_row = cells;
        }
    }
    if blank.is_empty() {
        return None;
    }
    let last = blank.iter().copied().max().unwrap_or(0);
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    for k in 0..=last {
        let (line, tail) = match rest.find('\n') {
            Some(p) => (&rest[..p], &rest[p..]),
            None => (rest, ""),
        };
        if !blank.contains(&k) {
            out.push_str(line);
        }
        // The line end stays (its `\r` goes with a blanked line).
        rest = tail;
        if let Some(t) = rest.strip_prefix('\n') {
            out.push('\n');
            rest = t;
        }
    }
    out.push_str(rest);
    Some(Preamble {
        text: out,
        skipped,
        units: units_row,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The columns wanted, from owned pattern lists (kept alive by the caller).
    fn owned(inputs: &[&str], targets: &[&str]) -> (Vec<String>, Vec<String>) {
        (
            inputs.iter().map(|s| s.to_string()).collect(),
            targets.iter().map(|s| s.to_string()).collect(),
        )
    }

    fn find_in(
        text: &str,
        time: Option<&str>,
        inputs: &[&str],
        targets: &[&str],
    ) -> Option<Preamble> {
        let (i, t) = owned(inputs, targets);
        let w = Wanted {
            time,
            run: None,
            inputs: &i,
            targets: &t,
        };
        find(text, &w, None)
    }

    #[test]
    fn plain_logs_are_read_as_they_are() {
        let (c, u) = (&["*_c"][..], &["*_um"][..]);
        let t = Some("time_s");
        assert_eq!(find_in("time_s,a_c,y_um\n0,1,2\n", t, c, u), None);
        assert_eq!(find_in("time_s;a_c;y_um\r\n0;1,5;2\r\n", t, c, u), None);
        // A header that lacks a selected column is left to the reader's own error.
        assert_eq!(find_in("time_s,a_c\n0,1\n", t, c, u), None);
        // Missing cells under the header are data, not units.
        assert_eq!(find_in("time_s,a_c,y_um\n0,,\n", t, c, u), None);
    }

    #[test]
    fn title_lines_and_a_units_row_become_blank_lines() {
        let text =
            "Maschine: LC 380;;\nPrüfung: Warmlauf\n\nZeit;T1;T2;D\ns;°C;°C;µm\n0;20,5;21;3\n";
        let p = find_in(text, Some("Zeit"), &["T*"], &["D"]).unwrap();
        assert_eq!(p.text, "\n\n\nZeit;T1;T2;D\n\n0;20,5;21;3\n");
        assert_eq!(p.skipped.len(), 2);
        assert_eq!(p.skipped[0].0, 1);
        assert!(p.skipped[0]
            .1
            .contains("2 title line(s) above the header (line 4)"));
        assert_eq!(p.skipped[1].0, 5);
        assert!(p.skipped[1].1.contains("units row"), "{:?}", p.skipped);
        // Only a units row.
        let text = "t,a_c,y_um\r\n[s],[degC],[um]\r\n0,1,2\r\n";
        let p = find_in(text, Some("t"), &["*_c"], &["y_um"]).unwrap();
        assert_eq!(p.text, "t,a_c,y_um\r\n\n0,1,2\r\n");
        // A sample interval: no time column needed to find the header.
        let p = find_in("title\na_c,y_um\n1,2\n", None, &["a_c"], &["y_um"]).unwrap();
        assert_eq!(p.text, "\na_c,y_um\n1,2\n");
    }
}
