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

/// What a column's unit says it holds, for the columns the default patterns (`*_c`,
/// `*_um`) do not name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Quantity {
    /// A temperature: °C, degC, ℃, C (in a units cell or brackets), K.
    Temperature,
    /// A thermal error in µm or nm (mm is left out: a column in mm is an axis position
    /// far more often than a thermal error).
    Micrometres,
}

impl Quantity {
    /// Whether a unit cell's text is this quantity's unit.
    pub(crate) fn is(self, text: &str) -> bool {
        let w = unit_word(text);
        match self {
            Quantity::Temperature => {
                matches!(
                    w.as_str(),
                    "°c" | "degc" | "deg c" | "deg. c" | "℃" | "c" | "k" | "celsius" | "grad c"
                )
            }
            Quantity::Micrometres => matches!(
                w.as_str(),
                "um" | "micron" | "microns" | "micrometer" | "micrometre" | "nm"
            ),
        }
    }

    /// Whether a column name carries this quantity's unit in brackets (`Spindel [°C]`).
    pub(crate) fn in_brackets(self, name: &str) -> bool {
        name.split(['[', '('])
            .skip(1)
            .filter_map(|s| s.split([']', ')']).next())
            .any(|u| self.is(u))
    }

    /// The quantity's unit, for messages.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Quantity::Temperature => "°C or K",
            Quantity::Micrometres => "µm or nm",
        }
    }
}
