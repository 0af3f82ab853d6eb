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
    let lines: Vec<String> = text.split('\n').map(shorten_line).collect();
    lines.join("\n")
}

fn shorten_line(line: &str) -> String {
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
                if ends.len() > SHOWN_CHARS {
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
                if w.chars().count() > SHOWN_BARE_CHARS {
                    shown(w)
                } else {
                    w.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
    }
    let n = out.chars().count();
    if n <= SHOWN_LINE_CHARS {
        return out;
    }
    let head: String = out.chars().take(SHOWN_LINE_CHARS).collect();
    format!("{head}… ({n} characters)")
}
