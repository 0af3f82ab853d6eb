//! Source line numbers of CSV records from their byte offsets.
//!
//! The csv crate's own line count comes out one short on files with CRLF line ends (the
//! FL_THERMAL log is one), so every reader that reports bad rows by line counts the line
//! here from the record's byte offset instead.

/// Counts lines of one text incrementally: a whole file costs one pass.
#[derive(Debug, Clone)]
pub struct LineCounter<'a> {
    text: &'a [u8],
    byte: usize,
    line: u64,
}

impl<'a> LineCounter<'a> {
    /// A counter over `text`, whose first line is line 1.
    pub fn new(text: &'a str) -> Self {
        Self {
            text: text.as_bytes(),
            byte: 0,
            line: 1,
        }
    }

    /// 1-based line of the record that starts at byte offset `byte`: 1 + the number of
    /// `\n` before its first byte. A record never starts on a line end, so leading `\r`/`\n`
    /// are stepped over (the csv reader may report the offset of the terminator's tail).
    pub fn line_at(&mut self, byte: u64) -> u64 {
        let mut b = usize::try_from(byte)
            .unwrap_or(usize::MAX)
            .min(self.text.len());
        while b < self.text.len() && matches!(self.text[b], b'\r' | b'\n') {
            b += 1;
        }
        if b < self.byte {
            self.byte = 0;
            self.line = 1;
        }
        let newlines = self.text[self.byte..b]
            .iter()
            .filter(|&&c| c == b'\n')
            .count();
        self.line += newlines as u64;
        self.byte = b;
        self.line
    }
}

#[cfg(test)]
mod tests {
    use super::LineCounter;

    #[test]
    fn lines_from_offsets_for_lf_crlf_and_out_of_order_queries() {
        let lf = "h\nab\ncd\n";
        let mut c = LineCounter::new(lf);
        assert_eq!(c.line_at(0), 1);
        assert_eq!(c.line_at(2), 2);
        assert_eq!(c.line_at(5), 3);
        assert_eq!(c.line_at(2), 2);
        let crlf = "h\r\nab\r\ncd\r\n";
        let mut c = LineCounter::new(crlf);
        // offsets of the record start and of the '\n' tail of the previous terminator
        assert_eq!(c.line_at(3), 2);
        assert_eq!(c.line_at(6), 3);
        assert_eq!(c.line_at(7), 3);
        assert_eq!(c.line_at(u64::MAX), 4);
    }
}
