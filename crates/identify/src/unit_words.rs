//! How a log writes a unit: in a units-row cell (`[mm]`, `(min)`, `µm`) or in a column name
//! (`Weg [mm]`, `time_min`). Shared by the target's length unit ([`crate::target_unit`]) and
//! the time column's unit ([`crate::time_unit`]).

/// A unit cell's word: surrounding brackets `[ ]`, `( )`, blanks and a closing abbreviation
/// point (`sec.`, `Std.`) removed, the micro sign
/// and Greek mu written `u`, lower case.
pub(crate) fn unit_word(text: &str) -> String {
    text.trim()
        .trim_start_matches(['[', '('])
        .trim_end_matches([']', ')'])
        .trim()
        .trim_end_matches('.')
        .replace(['µ', 'μ'], "u")
        .to_lowercase()
}

/// The units a column name carries, as `parse` reads them: the first bracketed one anywhere
/// (`Weg [mm]`, `Time (h)`), and its last `_`, `-`, `.` or space separated part (`z_mm`,
/// `time_min`; none when the name has no separator).
pub(crate) fn units_in_name<U>(
    name: &str,
    parse: impl Fn(&str) -> Option<U>,
) -> (Option<U>, Option<U>) {
    let bracketed = name
        .split(['[', '('])
        .skip(1)
        .filter_map(|s| s.split([']', ')']).next())
        .find_map(&parse);
    let last = name
        .rsplit(['_', '-', '.', ' '])
        .next()
        .filter(|s| s.len() < name.len())
        .and_then(&parse);
    (bracketed, last)
}
