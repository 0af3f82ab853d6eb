//! The unit a log writes its time column in. Every time constant, delay, gap and split of a
//! fit is in seconds, and so is the model file the engine runs in real time: a log whose
//! time column counts minutes, read as seconds, gives time constants 60 times too short, a
//! model that still fits its own log and compensates the machine wrongly. The unit comes
//! from `--time-unit`, else from the log's units row under the header (`min;°C;…;µm`), else
//! from the column name (`time_min`, `Zeit [h]`); a time column in another unit is converted
//! to seconds on reading and the fit says so in a note. Time stamps (dates and times of day)
//! are instants and have no unit.

use crate::error::{invalid, Result};
use gearcomp_geometry::units::{S_PER_H, S_PER_MIN, S_PER_MS};

/// A unit of a numeric time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeUnit {
    /// Seconds (the fit's unit).
    S,
    /// Milliseconds.
    Ms,
    /// Minutes.
    Min,
    /// Hours.
    H,
}

impl TimeUnit {
    /// Seconds per one of this unit.
    pub fn s_per_unit(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => S_PER_MS,
            TimeUnit::Min => S_PER_MIN,
            TimeUnit::H => S_PER_H,
        }
    }

    /// The unit's symbol in messages.
    pub fn symbol(self) -> &'static str {
        match self {
            TimeUnit::S => "s",
            TimeUnit::Ms => "ms",
            TimeUnit::Min => "min",
            TimeUnit::H => "h",
        }
    }

    /// The unit a units-row cell names, in English or German: `s`, `sec`, `second(s)`,
    /// `Sekunde(n)`, `ms`, `msec`, `millisecond(s)`, `min`, `minute(s)`, `Minute(n)`, `h`,
    /// `hr`, `hrs`, `hour(s)`, `Std`, `Stunde(n)`; case and surrounding brackets ignored.
    /// `None` for anything else.
    pub fn parse(text: &str) -> Option<Self> {
        let t = crate::unit_words::unit_word(text);
        match t.as_str() {
            "s" | "sec" | "secs" | "second" | "seconds" | "sekunde" | "sekunden" => {
                Some(TimeUnit::S)
            }
            "ms" | "msec" | "millisecond" | "milliseconds" | "millisekunde" | "millisekunden" => {
                Some(TimeUnit::Ms)
            }
            "min" | "mins" | "minute" | "minutes" | "minuten" => Some(TimeUnit::Min),
            "h" | "hr" | "hrs" | "hour" | "hours" | "std" | "stunde" | "stunden" => {
                Some(TimeUnit::H)
            }
            _ => None,
        }
    }

    /// The unit a time column's name carries: in brackets anywhere (`Zeit [min]`,
    /// `Time (h)`) or as its last `_`, `-`, `.` or space separated part (`time_min`,
    /// `t_h`, `elapsed-s`).
    pub fn in_column_name(name: &str) -> Option<Self> {
        let (bracketed, last) = crate::unit_words::units_in_name(name, Self::parse);
        bracketed.or(last)
    }
}

/// The time column a selection names by default. When a log has no column of this name
/// and exactly one column reads as a time axis (`time`, `Zeit [s]`, `time_ms`:
/// [`crate::time_unit::looks_like_time`]), that column is the time, with a note.
pub const DEFAULT_TIME_COLUMN: &str = "time_s";

/// Whether a column name reads as a time axis (for the hint when the time column given is
/// missing): `time`, `Zeit`, `t`, `timestamp`, `datetime`, `date_time`, `elapsed`, `stamp`,
/// `Uhrzeit`, `Zeitstempel`, `Date&Time` (Graphtec), `Date Time`, `Date/Time`, any case, with
/// or without a unit (`time_min`, `Zeit [s]`).
pub fn looks_like_time(name: &str) -> bool {
    let base = name.split(['[', '(']).next().unwrap_or(name).trim();
    let base = match base.rsplit_once(['_', '-', '.', ' ']) {
        Some((head, tail)) if TimeUnit::parse(tail).is_some() => head,
        _ => base,
    };
    matches!(
        base.trim().to_lowercase().as_str(),
        "time"
            | "zeit"
            | "t"
            | "timestamp"
            | "datetime"
            | "date_time"
            | "elapsed"
            | "stamp"
            | "uhrzeit"
            | "zeitstempel"
            | "elapsed time"
            | "time stamp"
            | "date&time"
            | "date time"
            | "date/time"
            | "date-time"
    )
}

/// Where [`resolve`] found the unit when nothing named it (seconds).
pub const FROM_DEFAULT: &str = "the default";

/// How the reader treats the unit of a numeric time column (`ReadOptions::time_unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeUnitChoice {
    /// From the units row, else the column name; seconds when neither names one. A
    /// units-row cell that names no time unit is refused (name it with `--time-unit`).
    Auto,
    /// The time column is in this unit.
    Given(TimeUnit),
}

/// The unit of the time column `column` and where it came from: `unit_cell` is its
/// units-row cell (if the log has a units row); `stamps`: the column holds time stamps.
///
/// # Errors
/// A units-row cell that names no time unit (numbers only), naming the column, the cell and
/// `--time-unit`; `--time-unit` given for a column of time stamps.
pub fn resolve(
    choice: TimeUnitChoice,
    column: &str,
    unit_cell: Option<&str>,
    stamps: bool,
) -> Result<(TimeUnit, &'static str)> {
    if stamps {
        return match choice {
            TimeUnitChoice::Auto => Ok((TimeUnit::S, "time stamps")),
            TimeUnitChoice::Given(u) => Err(invalid(
                "--time-unit",
                u.symbol(),
                &format!(
                    "no unit: the time column {column} holds time stamps (instants); --time-unit applies to a column of numbers"
                ),
            )),
        };
    }
    match choice {
        TimeUnitChoice::Given(u) => Ok((u, "--time-unit")),
        TimeUnitChoice::Auto => match unit_cell.filter(|c| !c.trim().is_empty()) {
            Some(cell) => TimeUnit::parse(cell).map(|u| (u, "the units row")).ok_or_else(|| {
                invalid(
                    &format!("unit of the time column {column} in the units row"),
                    format!("«{cell}»"),
                    "a time unit (s, ms, min, h): every time constant of the model is in seconds; name the column's unit with --time-unit s|ms|min|h",
                )
            }),
            None => Ok(TimeUnit::in_column_name(column)
                .map_or((TimeUnit::S, FROM_DEFAULT), |u| (u, "the column name"))),
        },
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn time_units_are_read_from_cells_and_names() {
        for (t, u) in [
            ("s", TimeUnit::S),
            ("[s]", TimeUnit::S),
            ("Sekunden", TimeUnit::S),
            ("ms", TimeUnit::Ms),
            ("(min)", TimeUnit::Min),
            ("Minuten", TimeUnit::Min),
            ("h", TimeUnit::H),
            ("Std", TimeUnit::H),
            ("Hours", TimeUnit::H),
            ("sec.", TimeUnit::S),
            ("[Std.]", TimeUnit::H),
        ] {
            assert_eq!(TimeUnit::parse(t), Some(u), "{t}");
        }
        for t in ["°C", "", "-", "hh:mm:ss", "mm", "d"] {
            assert_eq!(TimeUnit::parse(t), None, "{t}");
        }
        for (n, u) in [
            ("time_s", Some(TimeUnit::S)),
            ("time_min", Some(TimeUnit::Min)),
            ("Zeit [min]", Some(TimeUnit::Min)),
            ("Time (h)", Some(TimeUnit::H)),
            ("t_h", Some(TimeUnit::H)),
            ("elapsed-ms", Some(TimeUnit::Ms)),
            ("Zeit", None),
            ("s", None),
            ("time", None),
            ("times", None),
        ] {
            assert_eq!(TimeUnit::in_column_name(n), u, "{n}");
        }
        for n in [
            "time",
            "Time_min",
            "Zeit [s]",
            "t_h",
            "Timestamp",
            "elapsed-s",
            "Uhrzeit",
        ] {
            assert!(looks_like_time(n), "{n}");
        }
        for n in ["a_c", "temp", "t1_c", "times", "z_um", "s"] {
            assert!(!looks_like_time(n), "{n}");
        }
        assert_eq!(TimeUnit::Min.s_per_unit(), 60.0);
        assert_eq!(TimeUnit::H.s_per_unit(), 3600.0);
        assert_eq!(TimeUnit::Ms.s_per_unit(), 1e-3);
    }

    #[test]
    fn the_units_row_comes_before_the_name_and_stamps_have_no_unit() {
        let auto = TimeUnitChoice::Auto;
        assert_eq!(
            resolve(auto, "time_s", Some("min"), false).unwrap(),
            (TimeUnit::Min, "the units row")
        );
        assert_eq!(
            resolve(auto, "time_h", None, false).unwrap(),
            (TimeUnit::H, "the column name")
        );
        assert_eq!(
            resolve(auto, "Zeit", None, false).unwrap(),
            (TimeUnit::S, "the default")
        );
        let e = resolve(auto, "Zeit", Some("V"), false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("time column Zeit") && e.contains("«V»") && e.contains("--time-unit"),
            "{e}"
        );
        assert_eq!(
            resolve(
                TimeUnitChoice::Given(TimeUnit::Min),
                "time_s",
                Some("s"),
                false
            )
            .unwrap(),
            (TimeUnit::Min, "--time-unit")
        );
        assert_eq!(
            resolve(auto, "stamp", Some("hh:mm:ss"), true).unwrap(),
            (TimeUnit::S, "time stamps")
        );
        let e = resolve(TimeUnitChoice::Given(TimeUnit::H), "stamp", None, true)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--time-unit") && e.contains("time stamps"),
            "{e}"
        );
    }
}
