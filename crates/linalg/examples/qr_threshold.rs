//! Where [`gearcomp_linalg::r_factor`] switches to faer's blocked QR: the R factor by
//! nalgebra's unblocked Householder QR and by faer's blocked one, on random matrices of the shapes the
//! validation engines factorise (a 1440-row block of FL_THERMAL with 24 to 214 columns, a
//! stacked pair of factors), medians of alternating runs in one process and their ratio.
//!
//! `cargo run --release -p gearcomp-linalg --example qr_threshold`
use nalgebra::DMatrix;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut s = 0x853c_49e6_748f_ea9bu64;
    let mut u = move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    println!(
        "rows × cols: nalgebra ms, faer ms, nalgebra / faer (r_factor uses faer from {} columns)",
        gearcomp_linalg::BLOCKED_QR_MIN_COLS
    );
    for &(m, n) in &[
        (1440, 24),
        (1440, 48),
        (1440, 95),
        (1440, 96),
        (1440, 142),
        (1440, 214),
        (428, 214),
        (3000, 214),
    ] {
        let a = DMatrix::from_fn(m, n, |_, _| u() * 2.0 - 1.0);
        let reps = (2e8 / (m * n * n) as f64).clamp(5.0, 400.0) as usize;
        let (mut tn, mut tf) = (Vec::new(), Vec::new());
        let mut check = 0.0;
        for _ in 0..reps {
            let t = Instant::now();
            check += a.clone().qr().r()[(0, 0)].abs();
            tn.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let fa = faer::MatRef::from_column_major_slice(a.as_slice(), m, n);
            check -= fa.qr().thin_R()[(0, 0)].abs();
            tf.push(t.elapsed().as_secs_f64());
        }
        let (tn, tf) = (median(tn), median(tf));
        println!(
            "{m} × {n}: {:.3}, {:.3}, {:.2}  (|r00| difference {check:.1e})",
            tn * 1e3,
            tf * 1e3,
            tn / tf
        );
    }
}
