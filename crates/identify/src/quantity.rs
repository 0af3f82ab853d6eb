//! What a column holds, by its unit: the default selection (`*_c` inputs, `*_um` targets)
//! falls back on it when its patterns match no column of a log (`Spindel [°C]`, a units row
//! `degC`).

/// What a column's unit says it holds, for the columns the default patterns (`*_c`,
/// `*_um`) do not name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// A temperature: °C, degC, ℃, C (in a units cell or brackets), K.
    Temperature,
    /// A thermal error in µm or nm (mm is left out: a column in mm is an axis position
    /// far more often than a thermal error).
    Micrometres,
}

impl Quantity {
    /// Whether a unit cell's text is this quantity's unit.
    pub fn is(self, text: &str) -> bool {
        let w = crate::unit_words::unit_word(text);
        match self {
            Quantity::Temperature => {
                matches!(
                    w.as_str(),
                    "°c" | "degc" | "deg c" | "deg. c" | "℃" | "c" | "k" | "celsius" | "grad c"
                )
            }
            // The length words of the targets' unit reader, µm and nm only.
            Quantity::Micrometres => matches!(
                crate::target_unit::LengthUnit::parse(text),
                Some(crate::target_unit::LengthUnit::Um | crate::target_unit::LengthUnit::Nm)
            ),
        }
    }

    /// Whether a column name carries this quantity's unit in brackets (`Spindel [°C]`).
    pub fn in_brackets(self, name: &str) -> bool {
        name.split(['[', '('])
            .skip(1)
            .filter_map(|s| s.split([']', ')']).next())
            .any(|u| self.is(u))
    }

    /// The quantity's unit, for messages.
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Temperature => "°C or K",
            Quantity::Micrometres => "µm or nm",
        }
    }
}
