//! Issue 13 item 1: the span's contact diameter, the recommended k, the face-width limit,
//! ball ranges, the module range and undercut, against the independent constructions of
//! `construct.rs` (flanks built as surfaces, intersected and searched numerically).

use gearcomp_geometry::{Gear, GearSpec, GeometryError, Hand, Mesh};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

use crate::construct::{self, Gear3};

fn helical(m: f64, z: u32, beta_deg: f64, x: f64, width: Option<f64>) -> Gear {
    let mut s = GearSpec::spur(m, 20f64.to_radians(), z);
    s.helix_angle_rad = beta_deg.to_radians();
    s.hand = Hand::Right;
    s.profile_shift = x;
    s.face_width_mm = width;
    Gear::new(s).unwrap()
}

fn g3(g: &Gear, x: f64) -> Gear3 {
    let s = g.spec();
    Gear3::new(
        s.normal_module_mm,
        s.normal_pressure_angle_rad,
        s.helix_angle_rad,
        s.teeth,
        x,
    )
}

/// `gear --module 2 --teeth 40 --helix 30 --span-k 8` was refused with a contact of
/// 99.8192 mm; the anvils touch at about 94.33 mm.
#[test]
fn helical_span_k8_touches_at_94_33() {
    let g = helical(2.0, 40, 30.0, 0.0, None);
    let s = g.span(8, 0.0).unwrap();
    let c = construct::span(&g3(&g, 0.0), 8).unwrap();
    assert!((s.span_mm - c.span_mm).abs() < 1e-9, "{s:?} {c:?}");
    assert!(
        (s.contact_diameter_mm - c.contact_diameter_mm).abs() < 1e-9,
        "{s:?} {c:?}"
    );
    assert!((s.contact_diameter_mm - 94.33).abs() < 0.005, "{s:?}");
    // DIN 3960 3.6.4 gives k = 7 (k′ = 7.09).
    assert_eq!(g.recommended_span_k(0.0).unwrap(), 7);
    assert_eq!(construct::din3960_k(&g3(&g, 0.0), 0.0), 7);
}

/// `--width 5`: no k touching the flank fits the face; the message states W_k·sin β_b
/// against b for the k it names, with consistent numbers.
#[test]
fn helical_span_face_width_limit_is_stated() {
    let g = helical(2.0, 40, 30.0, 0.0, Some(5.0));
    let e = g.span(7, 0.0).unwrap_err();
    match e {
        GeometryError::SpanTooWide {
            k,
            span_mm,
            axial_mm,
            face_width_mm,
            ..
        } => {
            assert_eq!(k, 7);
            let c = construct::span(&g3(&g, 0.0), 7).unwrap();
            assert!(
                (axial_mm - c.axial_mm).abs() < 1e-9,
                "{axial_mm} vs {}",
                c.axial_mm
            );
            assert!((span_mm - c.span_mm).abs() < 1e-9);
            assert!(axial_mm > face_width_mm);
        }
        e => panic!("{e}"),
    }
    let msg = g.recommended_span_k(0.0).unwrap_err().to_string();
    assert!(
        msg.contains("W_k·sin β_b = 13.2751 mm")
            && msg.contains("face width b = 5 mm")
            && msg.contains("= 5:"),
        "{msg}"
    );
    // A face of 14 mm takes k = 5 (13.28 mm) but not the DIN k = 7: the recommendation
    // is the largest k that fits, and it is accepted when given back.
    let g = helical(2.0, 40, 30.0, 0.0, Some(14.0));
    let k = g.recommended_span_k(0.0).unwrap();
    assert_eq!(k, 5);
    g.span(k, 0.0).unwrap();
}

/// `--ball 1` on z = 20, m = 2 printed "contact diameter NaN mm": refused with the range
/// of balls that touch, and that range is exact (just inside accepted, just outside not).
#[test]
fn small_ball_is_refused_with_the_valid_range() {
    let g = Gear::new(GearSpec::spur(2.0, 20f64.to_radians(), 20)).unwrap();
    let e = g.ball_dimension(1.0, 0.0).unwrap_err();
    let msg = e.to_string();
    assert!(!msg.contains("NaN"), "{msg}");
    let GeometryError::BallOffFlank {
        min_ball_mm,
        max_ball_mm,
        ..
    } = e
    else {
        panic!("{e}")
    };
    assert!(msg.contains("ball_mm = 1 mm"), "{msg}");
    assert!(min_ball_mm > 1.0 && max_ball_mm > min_ball_mm && max_ball_mm <= 10.0);
    for b in [min_ball_mm, max_ball_mm, 0.5 * (min_ball_mm + max_ball_mm)] {
        let m = g.ball_dimension(b, 0.0).unwrap();
        assert!(m.dimension_mm.is_finite() && m.contact_diameter_mm.is_finite());
    }
    for b in [min_ball_mm - 1e-5, max_ball_mm + 1e-5] {
        if b <= 10.0 {
            assert!(g.ball_dimension(b, 0.0).is_err(), "{b}");
        }
    }
    // The low end touches at the root form circle, the high end at the tip (construction).
    let c = construct::ball(&g3(&g, 0.0), min_ball_mm).unwrap();
    let (d_ff, d_a) = construct::flank_limits_din867(&g3(&g, 0.0), 0.0);
    assert!(
        (c.contact_diameter_mm - d_ff).abs() < 1e-4,
        "{c:?} vs {d_ff}"
    );
    let c = construct::ball(&g3(&g, 0.0), max_ball_mm).unwrap();
    assert!(
        (c.contact_diameter_mm - d_a).abs() < 1e-4 || max_ball_mm == 10.0,
        "{c:?} vs {d_a}"
    );
}

/// `--module 1e-300` passed validation.
#[test]
fn absurd_module_is_refused_with_a_sensible_range() {
    for m in [1e-300, 1e-3, 0.0, -1.0, 1001.0, f64::NAN] {
        let e = Gear::new(GearSpec::spur(m, 20f64.to_radians(), 20))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("normal_module_mm") && e.contains("0.01 … 1000 mm"),
            "{e}"
        );
    }
    let e = Gear::new(GearSpec::spur(1e-300, 20f64.to_radians(), 20))
        .unwrap_err()
        .to_string();
    assert!(e.contains("1e-300"), "{e}");
    Gear::new(GearSpec::spur(0.01, 20f64.to_radians(), 20)).unwrap();
}

/// Undercut gears are computed (with `undercut()` describing it), pointed teeth refused.
#[test]
fn undercut_is_computed_and_reported() {
    let g = Gear::new(GearSpec::spur(1.0, 20f64.to_radians(), 10)).unwrap();
    let u = g.undercut("profile_shift", 0.0).unwrap().to_string();
    assert!(u.contains("x_min = 0.5006") && u.contains("18.6"), "{u}");
    let k = g.recommended_span_k(0.0).unwrap();
    let s = g.span(k, 0.0).unwrap();
    let c = construct::span(&g3(&g, 0.0), k).unwrap();
    assert!((s.span_mm - c.span_mm).abs() < 1e-9);
    let b = g.recommended_ball_mm(0.0).unwrap();
    let m = g.ball_dimension(b, 0.0).unwrap();
    let c = construct::ball(&g3(&g, 0.0), b).unwrap();
    assert!(
        (m.dimension_mm - c.dimension_mm).abs() < 1e-6,
        "{m:?} {c:?}"
    );
    // Heavily undercut helical pinion (z = 8, β = 30.78°, x = −0.379): the target circle
    // lies below the usable flank; the recommended ball touches at the middle of the usable flank instead,
    // and it measures (this refused the whole `gear` command before).
    let mut s = GearSpec::spur(1.411, 20f64.to_radians(), 8);
    s.helix_angle_rad = 30.78f64.to_radians();
    s.profile_shift = -0.379;
    let g = Gear::new(s).unwrap();
    assert!(g.undercut("profile_shift", -0.379).is_some());
    let b = g.recommended_ball_mm(-0.379).unwrap();
    let m = g.ball_dimension(b, -0.379).unwrap();
    let c = construct::ball(&g3(&g, -0.379), b).unwrap();
    assert!(
        (m.dimension_mm - c.dimension_mm).abs() < 1e-6,
        "{m:?} {c:?}"
    );
    // A gear without undercut reports none.
    let g = Gear::new(GearSpec::spur(1.0, 20f64.to_radians(), 20)).unwrap();
    assert!(g.undercut("profile_shift", 0.0).is_none());
    // Pointed: still refused.
    let mut s = GearSpec::spur(1.0, 20f64.to_radians(), 10);
    s.profile_shift = 1.2;
    let e = Gear::new(s).unwrap_err().to_string();
    assert!(e.contains("pointed tooth"), "{e}");
}

/// Random valid external gears (spur and helical, shifted, with and without a face width):
/// every k whose constructed contact lies on the flank (away from its ends by 1 µm) and
/// whose axial extent fits the face is accepted, with W_k, d_M and the axial extent equal
/// to the construction; the recommended k is DIN 3960's whenever that k is measurable,
/// and the recommendation is always accepted by `span`.
#[test]
fn span_matches_construction_on_random_gears() {
    let strategy = (
        0.5..12.0f64,
        15.0..25.0f64,
        prop_oneof![Just(0.0), 0.0..45.0f64],
        12u32..160,
        -0.4..0.8f64,
        prop_oneof![Just(None), (5.0..120.0f64).prop_map(Some)],
        0.0..1.0f64,
    );
    let compared = std::cell::Cell::new(0u32);
    let check = |(m, a, b, z, x, w, kf): (f64, f64, f64, u32, f64, Option<f64>, f64)| {
        let mut s = GearSpec::spur(m, a.to_radians(), z);
        s.helix_angle_rad = b.to_radians();
        s.profile_shift = x;
        s.face_width_mm = w.map(|w| w * m);
        let Ok(g) = Gear::new(s) else {
            return Ok(());
        };
        let c3 = g3(&g, x);
        // k around DIN's (most other k miss the flank): din − 2 … din + 2.
        let din = construct::din3960_k(&c3, x);
        let k = (i64::from(din) + (kf * 5.0) as i64 - 2).clamp(1, i64::from(z - 1)) as u32;
        let (lo, hi) = g.flank_range_mm(x);
        let res = g.span(k, x);
        if let Some(c) = construct::span(&c3, k) {
            let inside = c.contact_diameter_mm > lo + 1e-6 && c.contact_diameter_mm < hi - 1e-6;
            let fits = s.face_width_mm.is_none_or(|b| c.axial_mm < b - 1e-6);
            if inside && fits {
                prop_assert!(
                    res.is_ok(),
                    "k = {k} refused: {:?} (construction {c:?})",
                    res
                );
            }
            if let Ok(sp) = res {
                compared.set(compared.get() + 1);
                prop_assert!((sp.span_mm - c.span_mm).abs() < 1e-9 * (1.0 + c.span_mm));
                prop_assert!(
                    (sp.contact_diameter_mm - c.contact_diameter_mm).abs()
                        < 1e-8 * (1.0 + c.contact_diameter_mm),
                    "{sp:?} vs {c:?}"
                );
            }
        }
        if let Ok(rk) = g.recommended_span_k(x) {
            prop_assert!(g.span(rk, x).is_ok());
            if din >= 1 && din < z && g.span(din, x).is_ok() {
                prop_assert_eq!(rk, din);
            }
        }
        Ok(())
    };
    let cfg = Config {
        cases: 300,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[7u8; 32], [13u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
    // The comparison is not vacuous: a good share of the random k touch the flank.
    assert!(
        compared.get() > 150,
        "only {} spans compared",
        compared.get()
    );
}

/// Random valid external gears: the dimension over the recommended ball (and a random
/// ball inside the accepted range) equals the ball placed numerically against the helical
/// flank; the contact diameter too.
#[test]
fn ball_matches_construction_on_random_gears() {
    let strategy = (
        0.5..8.0f64,
        15.0..25.0f64,
        prop_oneof![Just(0.0), 0.0..40.0f64],
        12u32..120,
        -0.3..0.6f64,
        0.0..1.0f64,
    );
    let check = |(m, a, b, z, x, t): (f64, f64, f64, u32, f64, f64)| {
        let mut s = GearSpec::spur(m, a.to_radians(), z);
        s.helix_angle_rad = b.to_radians();
        s.profile_shift = x;
        let Ok(g) = Gear::new(s) else {
            return Ok(());
        };
        let c3 = g3(&g, x);
        let (b_lo, b_hi) = g.ball_range_mm(x);
        prop_assert!(b_lo.is_finite() && b_hi > b_lo, "{b_lo} {b_hi}");
        for ball in [g.recommended_ball_mm(x).unwrap(), b_lo + t * (b_hi - b_lo)] {
            let meas = g.ball_dimension(ball, x).unwrap();
            let c = construct::ball(&c3, ball).unwrap();
            prop_assert!(
                (meas.dimension_mm - c.dimension_mm).abs() < 1e-6 * (1.0 + m),
                "{meas:?} vs {c:?}"
            );
            prop_assert!(
                (meas.contact_diameter_mm - c.contact_diameter_mm).abs() < 1e-5 * (1.0 + m),
                "{meas:?} vs {c:?}"
            );
        }
        Ok(())
    };
    let cfg = Config {
        cases: 12,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[3u8; 32], [11u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
}

/// Internal gears are not covered by the construction; their span still refuses nothing
/// the textbook closed form places on the flank (spot check).
#[test]
fn internal_gear_span_still_computes() {
    let mut s = GearSpec::spur(2.0, 20f64.to_radians(), 60);
    s.mesh = Mesh::Internal;
    let g = Gear::new(s).unwrap();
    let k = g.recommended_span_k(0.0).unwrap();
    assert!(g.span(k, 0.0).unwrap().span_mm.is_finite());
}

/// Random internal gears: the space of an internal gear has the shape of an external tooth
/// whose thickness is the space width, e_t = m_t·(π/2 − 2·x·tan α_n), i.e. an external tooth
/// at shift −x; so the span over k spaces and its contact equal the construction's span over
/// k teeth of that external gear. Every k whose constructed contact lies on the internal
/// flank (d_a … d_f, away from the ends by 1 µm) and fits the face is accepted.
#[test]
fn internal_span_matches_construction_on_random_gears() {
    let strategy = (
        0.5..8.0f64,
        15.0..25.0f64,
        prop_oneof![Just(0.0), 0.0..35.0f64],
        30u32..200,
        -0.3..0.5f64,
        0.0..1.0f64,
    );
    let compared = std::cell::Cell::new(0u32);
    let check = |(m, a, b, z, x, kf): (f64, f64, f64, u32, f64, f64)| {
        let mut s = GearSpec::spur(m, a.to_radians(), z);
        s.mesh = Mesh::Internal;
        s.helix_angle_rad = b.to_radians();
        s.profile_shift = x;
        let Ok(g) = Gear::new(s) else {
            return Ok(());
        };
        let c3 = Gear3::new(m, a.to_radians(), b.to_radians(), z, -x);
        let (lo, hi) = g.flank_range_mm(x);
        let Ok(rk) = g.recommended_span_k(x) else {
            return Ok(());
        };
        let k = (i64::from(rk) + (kf * 5.0) as i64 - 2).clamp(1, i64::from(z - 1)) as u32;
        let res = g.span(k, x);
        if let Some(c) = construct::span(&c3, k) {
            if c.contact_diameter_mm > lo + 1e-6 && c.contact_diameter_mm < hi - 1e-6 {
                prop_assert!(res.is_ok(), "k = {k} refused: {:?} ({c:?})", res);
            }
            if let Ok(sp) = res {
                compared.set(compared.get() + 1);
                prop_assert!((sp.span_mm - c.span_mm).abs() < 1e-9 * (1.0 + c.span_mm));
                prop_assert!(
                    (sp.contact_diameter_mm - c.contact_diameter_mm).abs()
                        < 1e-8 * (1.0 + c.contact_diameter_mm),
                    "{sp:?} vs {c:?}"
                );
            }
        }
        Ok(())
    };
    let cfg = Config {
        cases: 150,
        failure_persistence: None,
        ..Config::default()
    };
    let mut r = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[19u8; 32]),
    );
    r.run(&strategy, check).unwrap();
    TestRunner::new(cfg).run(&strategy, check).unwrap();
    assert!(
        compared.get() > 100,
        "only {} spans compared",
        compared.get()
    );
}
