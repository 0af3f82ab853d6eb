//! Long user values in messages, shortened. A configuration value of 5000 characters
//! (a pasted log line, a runaway script) came back whole in every error that named it,
//! three times in a TOML parse error: messages keep a value's start and say its length
//! instead (`"qqq…" (5000 characters)`). Shared by the service, the engine's configuration
//! and the other readers of user files.

/// Characters of a user's value a message shows before it is shortened.
pub const SHOWN_CHARS: usize = 80;

/// Characters of a value written without quotes (and without spaces) beyond which it is
/// shortened: longer than a file path usually is, so a path is shown whole.
const SHOWN_BARE_CHARS: usize = 200;

/// Characters of one message line beyond which it is shortened (after its quoted values).
const SHOWN_LINE_CHARS: usize = 400;

/// A number as a message shows it: as Rust writes it for ordinary magnitudes (`0.25`, `-1`,
/// `3601`: the shortest text that reads back as the same value), in exponent form beyond
/// them (`1e300`, `1e-300`, not 300 digits). Shared by the engine's and the service's
/// messages.
pub fn number(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-6..1e15).contains(&a) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// A user's value as a message shows it: whole up to [`SHOWN_CHARS`] characters, else
/// its first [`SHOWN_CHARS`] characters, `…` and its length (`qqq… (5000 characters)`),
/// so a 5000-character value stays one readable line.
pub fn shown(value: &str) -> String {
    let n = value.chars().count();
    if n <= SHOWN_CHARS {
        value.to_string()
    } else {
        let head: String = value.chars().take(SHOWN_CHARS).collect();
        format!("{head}… ({n} characters)")
    }
}

/// A message with every long user value shortened: each quoted value (`` `…` `` as serde
/// quotes a variant or key, `"…"` with its escapes as a string is written or debug-printed)
/// longer than [`SHOWN_CHARS`] characters keeps its start and says its length
/// (`"qqq…" (5000 characters)`); a line still longer than 400 characters (the source line
/// and the `^^^` marker of a TOML parse error, an unquoted value) is cut the same way.
pub fn shorten_message(text: &str) -> String {
    let lines: Vec<String> = text.split('\n').map(|l| shorten_line(l, true)).collect();
    lines.join("\n")
}

/// [`shorten_message`] without the cut of long lines: every quoted value, every bare word
/// longer than a path and every `^^^` marker under a shortened value is shortened, but a
/// message line that is long for its own words (a list of columns, a remedy) stays whole.
/// For any error a command prints.
pub fn shorten_values(text: &str) -> String {
    let lines: Vec<String> = text.split('\n').map(|l| shorten_line(l, false)).collect();
    lines.join("\n")
}

fn shorten_line(line: &str, cut_long_lines: bool) -> String {
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::with_capacity(line.len().min(2 * SHOWN_LINE_CHARS));
    let mut i = 0;
    while i < chars.len() {
        let q = chars[i];
        if q == '`' || q == '"' {
            // The value's characters up to the closing quote, an escape of a debug-printed
            // string (`\"`, `\\`, `\n`, `\u{1f600}`) as one character.
            let mut ends = Vec::new();
            let mut j = i + 1;
            while j < chars.len() && chars[j] != q {
                if q == '"' && chars[j] == '\\' {
                    j += if chars.get(j + 1) == Some(&'u') {
                        chars[j..].iter().position(|c| *c == '}').unwrap_or(1) + 1
                    } else {
                        2
                    };
                } else {
                    j += 1;
                }
                ends.push(j.min(chars.len()));
            }
            if j < chars.len() {
                // A value shortened already (its start and `…`, as a library's message
                // gave it) is left as it is: shortening twice keeps the first length.
                let done = ends.len() == SHOWN_CHARS + 1 && chars[j - 1] == '…';
                if ends.len() > SHOWN_CHARS && !done {
                    out.push(q);
                    out.extend(&chars[i + 1..ends[SHOWN_CHARS - 1]]);
                    out.push('…');
                    out.push(q);
                    out.push_str(&format!(" ({} characters)", ends.len()));
                } else {
                    out.extend(&chars[i..=j]);
                }
                i = j + 1;
                continue;
            }
        }
        out.push(q);
        i += 1;
    }
    let carets = out.chars().filter(|c| *c == '^').count();
    if carets > SHOWN_CHARS + 2 && out.chars().all(|c| matches!(c, ' ' | '|' | '^')) {
        // The marker under a source line whose value was shortened: as wide as the
        // shortened value with its quotes.
        let lead = out.chars().take_while(|c| *c != '^').count();
        let head: String = out.chars().take(lead + SHOWN_CHARS + 2).collect();
        return format!("{head}…");
    }
    // A bare value (a key of 5000 letters, an unquoted name) longer than a path would be.
    if out
        .split_whitespace()
        .any(|w| w.chars().count() > SHOWN_BARE_CHARS)
    {
        out = out
            .split(' ')
            .map(|w| {
                // A list's comma or a sentence's stop after the value stays after it.
                let core = w.trim_end_matches([',', ';', ':', '.', ')']);
                if core.chars().count() > SHOWN_BARE_CHARS {
                    format!("{}{}", shown(core), &w[core.len()..])
                } else {
                    w.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
    }
    let n = out.chars().count();
    if n <= SHOWN_LINE_CHARS || !cut_long_lines {
        return out;
    }
    let head: String = out.chars().take(SHOWN_LINE_CHARS).collect();
    format!("{head}… ({n} characters)")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plain form up to 16 digits, exponent form beyond; both read back as the value.
    #[test]
    fn numbers_read_back_and_stay_short() {
        for (v, want) in [
            (1e300, "1e300"),
            (-2.5e16, "-2.5e16"),
            (3601.0, "3601"),
            (1e-12, "1e-12"),
            (0.00008, "0.00008"),
            (123456.5, "123456.5"),
            (0.0, "0"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (f64::MAX, "1.7976931348623157e308"),
        ] {
            assert_eq!(number(v), want);
        }
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..10_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let v = f64::from_bits(s);
            if v.is_finite() {
                let t = number(v);
                assert_eq!(
                    t.parse::<f64>().ok().map(f64::to_bits),
                    Some(v.to_bits()),
                    "{t}"
                );
                assert!(t.len() <= 26, "{t}");
            }
        }
    }

    /// Shortening twice (a library's message, then the command's) gives the first result;
    /// a list's comma after a long bare value stays after it.
    #[test]
    fn shortening_is_idempotent_and_keeps_punctuation() {
        let q = "q".repeat(5000);
        for text in [
            format!("unknown variant `{q}`, expected one of `a`, `b`"),
            format!("invalid x = \"{q}\": expected y"),
            format!("columns are a, {q}, b"),
        ] {
            let once = shorten_message(&text);
            assert_eq!(shorten_values(&once), once);
            assert_eq!(shorten_message(&once), once);
            assert!(once.contains("(5000 characters)"), "{once}");
        }
        let listed = shorten_values(&format!("columns are a, {q}, b"));
        assert!(listed.ends_with("… (5000 characters), b"), "{listed}");
    }
}
