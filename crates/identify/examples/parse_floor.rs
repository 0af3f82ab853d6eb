//! The floor of the whole-process benchmark (`benches/static_vs_numpy.py`): a process that
//! only reads a plain numeric CSV and parses every number of it into columns, on every core,
//! with the float parser `gearcomp fit` uses (`fast-float2`), and nothing else: no checks, no
//! identification, no report. Whatever `gearcomp fit` does, it cannot take less time than
//! this on the same file and machine, so `numpy time / floor time` bounds the ratio any
//! fit that reads the CSV can reach (issue 12, performance).
//!
//! `cargo build --release -p gearcomp-identify --example parse_floor`, then
//! `target/release/examples/parse_floor LOG.csv` prints the rows and the sum of all values.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

/// The allocator of the `gearcomp` binary (crates/cli/src/main.rs): the floor runs under the
/// same allocator as the process it bounds.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

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

fn main() {
    let path = std::env::args().nth(1).expect("usage: parse_floor LOG.csv");
    let text = std::fs::read(&path).expect("read the log");
    let head = text
        .iter()
        .position(|&c| c == b'\n')
        .expect("a header line")
        + 1;
    let width = text[..head].iter().filter(|&&c| c == b',').count() + 1;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Byte ranges that start at line starts.
    let mut cuts = vec![head];
    for k in 1..cores {
        let at = head + (text.len() - head) * k / cores;
        let start = text[at..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(text.len(), |p| at + p + 1);
        cuts.push(start.max(*cuts.last().unwrap_or(&head)));
    }
    cuts.push(text.len());
    let rows_guess = (text.len() - head) / (8 * width * cores) + 1;
    let parts: Vec<Vec<Vec<f64>>> = std::thread::scope(|s| {
        let handles: Vec<_> = cuts
            .windows(2)
            .map(|w| {
                let part = &text[w[0]..w[1]];
                s.spawn(move || {
                    let mut cols: Vec<Vec<f64>> =
                        (0..width).map(|_| Vec::with_capacity(rows_guess)).collect();
                    parse(part, &mut cols);
                    cols
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let rows: usize = parts.iter().map(|p| p[0].len()).sum();
    let sum: f64 = parts.iter().flatten().flatten().sum();
    println!("{rows} rows, {width} columns, sum {sum}");
}
