//! Defects found by fuzzing `gearcomp shape run` with random valid and invalid G83 blocks and
//! machine data (session 10):
//!
//! 1. the exact coupling check of a whole cut overflowed i128 at valid encoder resolutions
//!    near 2^26 counts/rev ("exact ratio arithmetic overflows for coupling check", valid
//!    set-up refused at column 1);
//! 2. a crank radius R < 3 mm was accepted with a facewidth B = 4 mm that does not fit in the
//!    stroke 2R (exit 0, lead "evaluated" over a 0.2 mm stroke).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_shaping::coupling::{Hand, Mesh};
use gearcomp_shaping::gcode::{parse_program, MachineData};
use gearcomp_shaping::ratio::Ratio;
use gearcomp_shaping::simulate::{coupling_residual, execute_program};
use gearcomp_shaping::ShapingError;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Runs `prop` over `strat` for `cases` cases from the fixed seed `[seed; 32]`, then `between`
/// (a check of what the fixed cases covered), then as many cases from a fresh seed; nothing
/// is persisted (the fixed seed is the regression).
fn fixed_then_fresh<S: Strategy>(
    cases: u32,
    seed: u8,
    strat: &S,
    prop: &impl Fn(S::Value) -> Result<(), TestCaseError>,
    between: impl FnOnce(),
) {
    let cfg = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]);
    TestRunner::new_with_rng(cfg.clone(), rng)
        .run(strat, prop)
        .unwrap();
    between();
    TestRunner::new(cfg).run(strat, prop).unwrap();
}

/// Exact C2 position of ρ·(cpr_C2/cpr_C1)·C1 built here by integer division (whole counts,
/// remainder, denominator), not by the crate's ratio arithmetic.
fn exact_c2(
    rho_num: i128,
    rho_den: i128,
    cpr1: i128,
    cpr2: i128,
    c1: (i128, i128, i128),
) -> (i128, i128, i128) {
    let (w, r, d) = c1;
    let num = rho_num * cpr2 * (w * d + r);
    let den = rho_den * cpr1 * d;
    let whole = num.div_euclid(den);
    (whole, num - whole * den, den)
}

fn check_residual(t: u32, l: u32, internal: bool, cpr1: u32, cpr2: u32, c1: (i128, i128, i128)) {
    let (n, d) = (i128::from(t), i128::from(l));
    let rho_num = if internal { n } else { -n };
    let rho = Ratio::new(rho_num, d).unwrap();
    let c2 = exact_c2(rho_num, d, i128::from(cpr1), i128::from(cpr2), c1);
    assert_eq!(
        coupling_residual(rho, cpr1, cpr2, c2, c1).unwrap(),
        0,
        "T{t} L{l} cpr {cpr1}/{cpr2} C1 {c1:?} C2 {c2:?}"
    );
    // One whole C2 count of drift is a residual of exactly 1 count.
    let drifted = (c2.0 + 1, c2.1, c2.2);
    assert_eq!(
        coupling_residual(rho, cpr1, cpr2, drifted, c1).unwrap(),
        1,
        "T{t} L{l} cpr {cpr1}/{cpr2} C1 {c1:?}"
    );
}

/// The fuzzer's case: T997 L991 at 2^26 counts/rev and 2^40 C1 counts, where the
/// cross-multiplied check needed ~2^138.
#[test]
fn coupling_check_does_not_overflow_at_the_finest_encoders() {
    check_residual(
        997,
        991,
        false,
        1 << 26,
        1 << 26,
        (1 << 40, 12_345_678, 1 << 26),
    );
}

/// Random teeth, mesh, encoder resolutions up to 2^26 and positions up to 2^40 counts: the
/// exact coupling gives residual 0, one count of drift gives 1 (fixed seed + fresh cases).
#[test]
fn coupling_residual_is_exact_over_random_set_ups() {
    let strat = (
        1u32..=1000,
        1u32..=1000,
        any::<bool>(),
        360u32..=(1 << 26),
        360u32..=(1 << 26),
        0i128..(1 << 40),
        20u32..=26,
        any::<u64>(),
    );
    let prop = |(t, l, internal, cpr1, cpr2, whole, shift, r): (
        u32,
        u32,
        bool,
        u32,
        u32,
        i128,
        u32,
        u64,
    )| {
        let d = 1i128 << shift;
        check_residual(t, l, internal, cpr1, cpr2, (whole, i128::from(r) % d, d));
        Ok(())
    };
    fixed_then_fresh(64, 10, &strat, &prop, || {});
}

/// The fuzzer's whole cut: internal T951 L12 with C1 and crank at 2^26 counts/rev and
/// C2 at 20 797 353 was refused by the coupling check's overflow; it runs and keeps the
/// exact ratio.
#[test]
fn whole_cut_at_fine_encoders_keeps_the_exact_ratio() {
    let p = parse_program(
        "G83 E9.977412 I1 T951 X8.691159 S1 K10000 P-4.557095 B262.451607 F10 U0.395796 \
         R138.074971 L12 D-0.479023 Q2.132691\n",
    )
    .unwrap();
    let mut m = MachineData {
        cycle_ms: 2.929474465312716,
        crank_counts_per_rev: 1 << 26,
        c1_counts_per_rev: 1 << 26,
        c2_counts_per_rev: 20_797_353,
        c2_max_speed_rpm: 3062.8,
        c2_max_accel_rev_s2: 33.86,
        ..MachineData::default()
    };
    m.c1.ideal = true;
    m.c2.ideal = true;
    let cfg = p.cycles[0].to_simulation(&m).unwrap();
    let cut = cfg.interp.cut;
    assert_eq!((cut.hand(), cut.mesh()), (Hand::Left, Mesh::Internal));
    let e = execute_program(&cfg.interp).unwrap();
    assert_eq!(e.coupling_residual, 0);
    // ⌈8.691159/0.395796⌉ = 22 infeed strokes + ⌈2^26 / counts per stroke⌉ for one turn,
    // counts per stroke = round(F/r_C1 · cpr/2π), r_C1 = m_n·z/(2 cos β).
    let r_c1 = 2.132691 * 951.0 / (2.0 * 4.557095f64.to_radians().cos());
    let per = (10.0 / r_c1 * f64::from(1u32 << 26) / std::f64::consts::TAU).round() as u64;
    assert_eq!(e.strokes, 22 + (1u64 << 26).div_ceil(per));
}

fn located_error(text: &str) -> (usize, usize, String) {
    let p = parse_program(text).unwrap();
    match p.cycles[0].to_simulation(&MachineData::default()) {
        Err(ShapingError::Parse {
            line,
            column,
            message,
        }) => (line, column, message),
        Ok(_) => panic!("{text:?} was accepted"),
        Err(e) => panic!("not located: {e}"),
    }
}

/// A stroke 2R shorter than the smallest facewidth (4 mm) plus 1 mm overtravel at each end
/// cannot cut any gear: every R in [0.1, 3) mm is refused at the R word with the range
/// 3 ..= 500 mm; R = 3 mm with B = 4 mm is the shortest accepted set-up.
#[test]
fn a_stroke_too_short_for_any_facewidth_is_refused_at_r() {
    let strat = (100u32..3000, 4u32..40);
    let prop = |(r_um, b_dmm): (u32, u32)| {
        let r = f64::from(r_um) / 1000.0;
        let b = f64::from(b_dmm) / 10.0 + 4.0;
        let text = format!("G83 T40 L25 Q1 P5 R{r} K200 S30 F0.5 B{b}\n");
        let (line, col, msg) = located_error(&text);
        prop_assert_eq!((line, col), (1, 19), "{}", msg);
        prop_assert!(
            msg.contains("crank radius R") && msg.contains(&format!("= {r} mm")),
            "{}",
            msg
        );
        prop_assert!(msg.contains("allowed 3 ..= 500 mm"), "{}", msg);
        Ok(())
    };
    fixed_then_fresh(48, 11, &strat, &prop, || {});

    let p = parse_program("G83 T40 L25 Q1 P5 R3 K200 S30 F0.5 B4\n").unwrap();
    p.cycles[0].to_simulation(&MachineData::default()).unwrap();
    let (_, col, msg) = located_error("G83 T40 L25 Q1 P5 R3 K200 S30 F0.5 B4.1\n");
    assert_eq!(col, 36, "{msg}");
    assert!(
        msg.contains("facewidth B = 4.1 mm") && msg.contains("4 ..= 4 mm"),
        "{msg}"
    );
}

/// Gears outside ISO 1328-1:2013's scope (clause 1: 5 ≤ d ≤ 15 000 mm, 0.5 ≤ m_n ≤ 70 mm)
/// are valid G83 cuts (Q 0.1 ..= 25 mm, T 1 ..= 1000) but were refused after conversion, at
/// column 1, by the f_HβT formula's range ("normal module m_n = 0.3 mm is outside the
/// allowed range 0.5 … 70 mm", "reference diameter d = 4 mm …"). They are simulated and
/// reported without a tolerance verdict; the lead still equals the closed form
/// π·m_n·Z_C1/sin β (fine pitch, d < 5 mm and d > 15 000 mm; fixed seed + fresh cases).
#[test]
fn gears_outside_the_iso_scope_are_simulated_without_a_verdict() {
    use gearcomp_shaping::simulate::simulate;
    // (T, L, Q, P, S): fine pitch, tiny diameter, huge diameter.
    let fine = (
        10u32..200,
        10u32..100,
        0.1..0.49f64,
        0.0..45.0f64,
        Just(5.0),
    );
    let tiny = (1u32..=4, 1u32..20, 0.5..1.0f64, 0.0..30.0f64, Just(5.0));
    let huge = (
        Just(1000u32),
        10u32..40,
        16.0..25.0f64,
        20.0..45.0f64,
        Just(60.0),
    );
    let strat = prop_oneof![fine, tiny, huge];
    let prop = |(t, l, q, p, s): (u32, u32, f64, f64, f64)| {
        let d = q * f64::from(t) / p.to_radians().cos();
        prop_assume!(!(5.0..=15_000.0).contains(&d) || q < 0.5);
        let text = format!("G83 T{t} L{l} Q{q:.4} P{p:.4} R25 K200 S{s} F10 B20\n");
        let prog = parse_program(&text).unwrap();
        let mut m = MachineData {
            c2_max_speed_rpm: 10_000.0,
            c2_max_accel_rev_s2: 10_000.0,
            strokes: 2,
            ..MachineData::default()
        };
        m.c1.ideal = true;
        m.c2.ideal = true;
        m.delay_compensation_cycles = 0.0;
        let cfg = prog.cycles[0]
            .to_simulation(&m)
            .map_err(|e| TestCaseError::fail(format!("{text}: {e}")))?;
        let r = simulate(&cfg).map_err(|e| TestCaseError::fail(format!("{text}: {e}")))?;
        prop_assert_eq!(r.lead.tolerance_um, None);
        prop_assert_eq!(r.lead.tolerance_unrounded_um, None);
        prop_assert_eq!(r.lead.within_tolerance, None);
        prop_assert!(r.lead.f_h_beta_um.is_finite());
        let (q, p) = (
            format!("{q:.4}").parse::<f64>().unwrap(),
            format!("{p:.4}").parse::<f64>().unwrap(),
        );
        if p > 0.0 {
            let lead = std::f64::consts::PI * q * f64::from(t) / p.to_radians().sin();
            let got = r.lead.design_lead_mm.unwrap();
            prop_assert!(
                (got - lead).abs() <= 1e-9 * lead,
                "{}: {} vs {}",
                text,
                got,
                lead
            );
            let rel = r.lead.lead_rel_error.unwrap();
            prop_assert!(rel.abs() < 1e-4, "{}: lead error {}", text, rel);
        }
        Ok(())
    };
    fixed_then_fresh(24, 12, &strat, &prop, || {});
}

/// A left-hand helix angle beyond 45° was reported by its magnitude ("P = 45.5 deg" for
/// P-45.5); the error now shows the signed value as written, at the P word.
#[test]
fn a_helix_angle_out_of_range_is_reported_as_written() {
    let strat = (4501u32..9000, any::<bool>());
    let prop = |(p_cdeg, left): (u32, bool)| {
        let p = f64::from(p_cdeg) / 100.0 * if left { -1.0 } else { 1.0 };
        let text = format!("G83 T40 L25 Q3 P{p} R25 K200 S30 F0.5 B40\n");
        let (_, col, msg) = located_error(&text);
        prop_assert_eq!(col, 16, "{}", msg);
        prop_assert!(
            msg.contains("helix angle P") && msg.contains(&format!("= {p} deg")),
            "{}",
            msg
        );
        prop_assert!(msg.contains("-45 ..= 45 deg"), "{}", msg);
        Ok(())
    };
    fixed_then_fresh(32, 13, &strat, &prop, || {});
}

/// Samples of the last simulated stroke inside the helix evaluation range, counted here
/// from the slider-crank closed form Z(θ) = √(K² − R² sin²θ) − R cos θ − (K − R) and
/// ISO 1328-1's L_β = b − 2·min(0.05 b, m_n) centred in the stroke, for `shrink` = ±1e-9 mm
/// of the range (a borderline sample makes the two counts differ).
fn helix_samples_by_hand(
    (r, k, s, b): (f64, f64, f64, f64),
    m_n: f64,
    (cycle_s, strokes): (f64, u32),
    shrink: f64,
) -> usize {
    let l_beta = b - 2.0 * (0.05 * b).min(m_n);
    let lo = r - 0.5 * l_beta + shrink;
    let hi = r + 0.5 * l_beta - shrink;
    let cycles_per_stroke = 60.0 / s / cycle_s;
    let total = (f64::from(strokes) * cycles_per_stroke).ceil() as u64;
    let start = ((f64::from(strokes) - 1.0) * cycles_per_stroke).ceil() as u64;
    (start..total)
        .filter(|&i| {
            let theta = (i as f64 * s / 60.0 * cycle_s).fract() * std::f64::consts::TAU;
            let sn = theta.sin();
            let z = (k * k - r * r * sn * sn).sqrt() - r * theta.cos() - (k - r);
            theta <= std::f64::consts::PI && z >= lo && z <= hi
        })
        .count()
}

/// A short facewidth at a high stroke rate and a long cycle leaves fewer than 3 samples in
/// L_β: that was found only by the simulation, after conversion (earlier blocks already
/// printed) and at column 1. It is now refused when the block is converted, at the S word,
/// with the count; every block with at least 3 samples converts (fixed seed + fresh cases).
#[test]
fn too_few_helix_samples_are_refused_at_s_when_converted() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let seen = [AtomicUsize::new(0), AtomicUsize::new(0)];
    let strat = (
        10.0..3000.0f64,
        20.0..100.0f64,
        0.0..1.0f64,
        1.0..4.0f64,
        1u32..=4,
    );
    let prop = |(s, r, b, cycle_ms, strokes): (f64, f64, f64, f64, u32)| {
        let (s, r, b, cycle_ms) = (
            s.round(),
            r.round(),
            // 4 mm ..= 2R − 2 mm, the facewidths the stroke holds.
            ((4.0 + b * (2.0 * r.round() - 6.0)) * 10.0).floor() / 10.0,
            cycle_ms.round(),
        );
        let k = 4.0 * r;
        let count =
            |shrink| helix_samples_by_hand((r, k, s, b), 1.0, (cycle_ms * 1e-3, strokes), shrink);
        let (n, n_wide) = (count(1e-9), count(-1e-9));
        prop_assume!(n == n_wide);
        let text = format!("G83 T20 L20 Q1 P0 R{r} K{k} S{s} F0.1 E0 B{b}\n");
        let prog = parse_program(&text).unwrap();
        let m = MachineData {
            cycle_ms,
            strokes,
            ..MachineData::default()
        };
        match prog.cycles[0].to_simulation(&m) {
            Ok(_) => {
                prop_assert!(n >= 3, "{}: accepted with {} samples", text, n);
                seen[0].fetch_add(1, Ordering::Relaxed);
            }
            Err(ShapingError::Parse {
                column, message, ..
            }) => {
                prop_assert!(n < 3, "{}: refused with {} samples: {}", text, n, message);
                prop_assert_eq!(column, prog.cycles[0].column_of('S'));
                prop_assert!(
                    message.contains(&format!("{n} samples, at least 3")),
                    "{}",
                    message
                );
                seen[1].fetch_add(1, Ordering::Relaxed);
            }
            Err(e) => prop_assert!(false, "not located: {}", e),
        }
        Ok(())
    };
    fixed_then_fresh(48, 15, &strat, &prop, || {
        // The fixed seed covers both sides.
        let (ok, refused) = (
            seen[0].load(Ordering::Relaxed),
            seen[1].load(Ordering::Relaxed),
        );
        assert!(ok > 0 && refused > 0, "accepted {ok}, refused {refused}");
    });
}
