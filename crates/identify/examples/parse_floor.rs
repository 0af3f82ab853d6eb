//! The floor of the whole-process benchmark (`benches/static_vs_numpy.py`): a process that
//! only reads a plain numeric CSV and parses every number of it into columns, on every core,
//! with the float parser `gearcomp fit` uses (`fast-float2`), and nothing else: no checks, no
//! identification, no report. Each core reads its byte range of the file in 256 KB chunks
//! into one reused buffer (no fresh 4.4 MB buffer to fault in) and parses the whole lines of
//! each chunk as it comes. Whatever `gearcomp fit` does, it cannot take less time than this on
//! the same file and machine, so `numpy time / floor time` bounds the ratio any fit that reads
//! the CSV can reach (issue 12, performance).
//!
//! `cargo build --release -p gearcomp-identify --example parse_floor`, then
//! `target/release/examples/parse_floor LOG.csv` prints the rows and the sum of all values.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::os::unix::fs::FileExt;

const CHUNK: usize = 1 << 18;

/// Parses the comma-separated numbers of `body` (whole lines, `\n` or `\r\n` ends) into
/// `cols` (a field that is not a number is skipped).
fn parse(body: &[u8], cols: &mut [Vec<f64>]) {
    let (mut at, mut k) = (0usize, 0usize);
    while at < body.len() {
        if let Ok((v, n)) = fast_float2::parse_partial::<f64, _>(&body[at..]) {
            if let Some(c) = cols.get_mut(k) {
                c.push(v);
            }
            at += n;
        }
        // To the end of the field, then past its delimiter or line end.
        while at < body.len() && !matches!(body[at], b',' | b'\r' | b'\n') {
            at += 1;
        }
        match body.get(at) {
            Some(b',') => {
                k += 1;
                at += 1;
            }
            _ => {
                k = 0;
                while at < body.len() && matches!(body[at], b'\r' | b'\n') {
                    at += 1;
                }
            }
        }
    }
}

/// The whole lines of the byte range `[from, to)` of the file (both line starts, or `to`
/// its end), read in chunks into one reused buffer.
fn parse_range(file: &std::fs::File, from: u64, to: u64, width: usize) -> Vec<Vec<f64>> {
    let rows_guess = (to - from) as usize / (8 * width) + 1;
    let mut cols: Vec<Vec<f64>> = (0..width).map(|_| Vec::with_capacity(rows_guess)).collect();
    let mut buf = vec![0u8; 2 * CHUNK];
    // Bytes of the range read so far and kept at the front of `buf` (a partial line).
    let (mut have, mut off) = (0usize, from);
    while off + (have as u64) < to {
        let want = CHUNK.min(usize::try_from(to - off).unwrap() - have);
        if buf.len() < have + want {
            // A line longer than a chunk.
            buf.resize(have + want, 0);
        }
        let n = file
            .read_at(&mut buf[have..have + want], off + have as u64)
            .unwrap();
        assert!(n > 0, "the file ended before its size");
        let filled = have + n;
        let upto = if off + filled as u64 == to {
            filled
        } else {
            buf[..filled]
                .iter()
                .rposition(|&c| c == b'\n')
                .map_or(0, |p| p + 1)
        };
        parse(&buf[..upto], &mut cols);
        buf.copy_within(upto..filled, 0);
        have = filled - upto;
        off += upto as u64;
    }
    cols
}

fn main() {
    let path = std::env::args().nth(1).expect("usage: parse_floor LOG.csv");
    let file = std::fs::File::open(&path).expect("open the log");
    let len = file.metadata().expect("the log's size").len();
    let mut head = vec![0u8; 4096];
    let n = file.read_at(&mut head, 0).expect("read the header");
    let header_end = head[..n]
        .iter()
        .position(|&c| c == b'\n')
        .expect("a header line")
        + 1;
    let width = head[..header_end].iter().filter(|&&c| c == b',').count() + 1;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as u64;
    // Byte ranges that start at line starts.
    let mut cuts = vec![header_end as u64];
    for k in 1..cores {
        let at = header_end as u64 + (len - header_end as u64) * k / cores;
        let mut probe = vec![0u8; 4096];
        let got = file.read_at(&mut probe, at).expect("read");
        let start = probe[..got]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(len, |p| at + p as u64 + 1);
        cuts.push(start.max(*cuts.last().unwrap()));
    }
    cuts.push(len);
    let parts: Vec<Vec<Vec<f64>>> = std::thread::scope(|s| {
        let handles: Vec<_> = cuts
            .windows(2)
            .map(|w| {
                let (from, to, file) = (w[0], w[1], &file);
                s.spawn(move || parse_range(file, from, to, width))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let rows: usize = parts.iter().map(|p| p[0].len()).sum();
    let sum: f64 = parts.iter().flatten().flatten().sum();
    println!("{rows} rows, {width} columns, sum {sum}");
}
