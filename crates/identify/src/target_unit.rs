//! The unit a log writes its displacement in. The model's offsets are µm
//! (`gearcomp_core::model`), so a target logged in mm would otherwise be fitted and applied
//! 1000 times too small. The unit comes from `--target-unit`, else from the log's units row
//! under the header (`s;°C;…;mm`), else from the column name (`z_mm`, `Weg [mm]`); a target
//! in another unit is converted to µm on reading and the fit says so in a note.

use crate::error::{invalid, Result};
use gearcomp_geometry::units::{UM_PER_INCH, UM_PER_M, UM_PER_MM, UM_PER_NM};

/// A length unit of a displacement column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Micrometres (the model's unit).
    Um,
    /// Millimetres.
    Mm,
    /// Nanometres.
    Nm,
    /// Metres.
    M,
    /// Inches.
    Inch,
}

impl LengthUnit {
    /// Micrometres per one of this unit.
    pub fn um_per_unit(self) -> f64 {
        match self {
            LengthUnit::Um => 1.0,
            LengthUnit::Mm => UM_PER_MM,
            LengthUnit::Nm => UM_PER_NM,
            LengthUnit::M => UM_PER_M,
            LengthUnit::Inch => UM_PER_INCH,
        }
    }

    /// The unit's symbol in messages.
    pub fn symbol(self) -> &'static str {
        match self {
            LengthUnit::Um => "µm",
            LengthUnit::Mm => "mm",
            LengthUnit::Nm => "nm",
            LengthUnit::M => "m",
            LengthUnit::Inch => "inch",
        }
    }

    /// The unit a units-row cell names: `µm` (micro sign or Greek mu), `um`, `micron(s)`,
    /// `mm`, `nm`, `m`, `in`, `inch(es)`, `"`; case and surrounding brackets `[ ]`, `( )`
    /// ignored. `None` for anything else.
    pub fn parse(text: &str) -> Option<Self> {
        let t = crate::unit_words::unit_word(text);
        match t.as_str() {
            "um" | "micron" | "microns" | "micrometer" | "micrometre" => Some(LengthUnit::Um),
            "mm" | "millimeter" | "millimetre" => Some(LengthUnit::Mm),
            "nm" | "nanometer" | "nanometre" => Some(LengthUnit::Nm),
            "m" | "meter" | "metre" => Some(LengthUnit::M),
            "in" | "inch" | "inches" | "\"" => Some(LengthUnit::Inch),
            _ => None,
        }
    }

    /// The unit a column name carries: in brackets anywhere (`Weg [mm]`, `Z (µm)`) or as
    /// its last `_`, `-`, `.` or space separated part (`z_mm`, `ch1_um`, `X-Pos mm`), for
    /// µm, mm and nm only (a bare `m` or `in` ending a name is too often something else).
    pub fn in_column_name(name: &str) -> Option<Self> {
        let (bracketed, last) = crate::unit_words::units_in_name(name, Self::parse);
        bracketed.or(last.filter(|u| matches!(u, LengthUnit::Um | LengthUnit::Mm | LengthUnit::Nm)))
    }
}

/// How the reader treats the unit of the target columns (`ReadOptions::target_unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetUnit {
    /// From the units row, else the column name; µm when neither names one. A units-row
    /// cell that is no length unit is refused (name the unit with `--target-unit`).
    Auto,
    /// Every target column is in this unit.
    Given(LengthUnit),
}

/// The unit of one target column and where it came from: `unit_cell` is its units-row
/// cell (if the log has a units row).
///
/// # Errors
/// A units-row cell that names no length unit, naming the column, the cell and
/// `--target-unit`.
pub fn resolve(
    choice: TargetUnit,
    column: &str,
    unit_cell: Option<&str>,
) -> Result<(LengthUnit, &'static str)> {
    match choice {
        TargetUnit::Given(u) => Ok((u, "--target-unit")),
        TargetUnit::Auto => match unit_cell.filter(|c| !c.trim().is_empty()) {
            Some(cell) => LengthUnit::parse(cell).map(|u| (u, "the units row")).ok_or_else(|| {
                invalid(
                    &format!("unit of target {column} in the units row"),
                    format!("«{cell}»"),
                    "a length unit (µm, mm, nm, m, inch): the model's offsets are µm; name the column's unit with --target-unit um|mm|nm|m|inch",
                )
            }),
            None => Ok(LengthUnit::in_column_name(column)
                .map_or((LengthUnit::Um, "the default"), |u| (u, "the column name"))),
        },
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn units_are_read_from_cells_and_names() {
        for (t, u) in [
            ("µm", LengthUnit::Um),
            ("μm", LengthUnit::Um),
            (" [um] ", LengthUnit::Um),
            ("Micron", LengthUnit::Um),
            ("mm", LengthUnit::Mm),
            ("(MM)", LengthUnit::Mm),
            ("nm", LengthUnit::Nm),
            ("m", LengthUnit::M),
            ("inch", LengthUnit::Inch),
            ("\"", LengthUnit::Inch),
        ] {
            assert_eq!(LengthUnit::parse(t), Some(u), "{t}");
        }
        for t in ["V", "°C", "", "-", "mmm", "µ"] {
            assert_eq!(LengthUnit::parse(t), None, "{t}");
        }
        for (n, u) in [
            ("ch1_um", Some(LengthUnit::Um)),
            ("z_mm", Some(LengthUnit::Mm)),
            ("Weg [mm]", Some(LengthUnit::Mm)),
            ("Z (µm)", Some(LengthUnit::Um)),
            ("X-Pos mm", Some(LengthUnit::Mm)),
            ("drift.nm", Some(LengthUnit::Nm)),
            ("mm", None),
            ("y_m", None),
            ("pos_in", None),
            ("ch1", None),
            ("comm", None),
        ] {
            assert_eq!(LengthUnit::in_column_name(n), u, "{n}");
        }
        assert_eq!(LengthUnit::Mm.um_per_unit(), 1000.0);
        assert_eq!(LengthUnit::Inch.um_per_unit(), 25_400.0);
        assert_eq!(LengthUnit::Nm.um_per_unit(), 1e-3);
        assert_eq!(LengthUnit::M.um_per_unit(), 1e6);
    }

    #[test]
    fn the_units_row_comes_before_the_name_and_no_length_is_refused() {
        let auto = TargetUnit::Auto;
        assert_eq!(
            resolve(auto, "z_um", Some("mm")).unwrap(),
            (LengthUnit::Mm, "the units row")
        );
        assert_eq!(
            resolve(auto, "z_mm", None).unwrap(),
            (LengthUnit::Mm, "the column name")
        );
        assert_eq!(
            resolve(auto, "z", None).unwrap(),
            (LengthUnit::Um, "the default")
        );
        let e = resolve(auto, "z", Some("V")).unwrap_err().to_string();
        assert!(
            e.contains("target z") && e.contains("«V»") && e.contains("--target-unit"),
            "{e}"
        );
        assert_eq!(
            resolve(TargetUnit::Given(LengthUnit::Nm), "z_mm", Some("mm")).unwrap(),
            (LengthUnit::Nm, "--target-unit")
        );
    }
}
