//! The interference warnings of `gearcomp gear` against the active root diameters written out
//! here from the line of action (ISO 21771 6.3: the mate's tip circle cuts the line of action
//! at a distance sqrt(r_a2² − r_b2²) from the mate's tangent point; the rest of the path
//! T1T2 = a_w·sin α_wt lies on gear 1's side). A warning printed "active root None mm" or
//! "Some(231.07464989278392) mm" (Rust's debug form of an optional value) for an external
//! pinion and an internal gear whose tip circle passes the pinion's tangent point T1.

use gearcomp_geometry::report::{GearReport, GearRequest, MateRequest};
use gearcomp_geometry::{BasicRack, GearSpec, Hand, Mesh};
use proptest::prelude::*;

use super::involute::{inv, inv_inverse};
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// (d_Nf1, d_Nf2) of pinion (external, z1, x1) and mate (z2, x2; internal if `internal`) at
/// the zero-backlash centre distance, `None` where the mate's tip passes the tangent point.
fn active_roots(
    m: f64,
    alpha_n: f64,
    beta: f64,
    (z1, x1): (f64, f64),
    (z2, x2): (f64, f64),
    internal: bool,
) -> (Option<f64>, Option<f64>) {
    let alpha_t = (alpha_n.tan() / beta.cos()).atan();
    let m_t = m / beta.cos();
    let (d1, d2) = (z1 * m_t, z2 * m_t);
    let (rb1, rb2) = (0.5 * d1 * alpha_t.cos(), 0.5 * d2 * alpha_t.cos());
    let ra1 = 0.5 * d1 + m * (1.0 + x1);
    let s = if internal { -1.0 } else { 1.0 };
    let ra2 = 0.5 * d2 + s * m * (1.0 + x2);
    let zs = if internal { z2 - z1 } else { z1 + z2 };
    let alpha_wt = inv_inverse(inv(alpha_t) + s * 2.0 * alpha_n.tan() * (x1 + x2) / zs);
    let a_w = 0.5 * m_t * zs * alpha_t.cos() / alpha_wt.cos();
    let t1t2 = a_w * alpha_wt.sin();
    let (g1, g2) = (
        (ra1 * ra1 - rb1 * rb1).sqrt(),
        (ra2 * ra2 - rb2 * rb2).sqrt(),
    );
    let (l1, l2) = if internal {
        (g2 - t1t2, t1t2 + g1)
    } else {
        (t1t2 - g2, t1t2 - g1)
    };
    let d = |rb: f64, l: f64| (l >= 0.0).then(|| 2.0 * (rb * rb + l * l).sqrt());
    (d(rb1, l1), d(rb2, l2))
}

#[test]
fn interference_warnings_print_the_active_root_or_say_there_is_none() {
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 150,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[11; 32]),
    );
    let seen_none = std::cell::Cell::new(0);
    let seen_some = std::cell::Cell::new(0);
    let strategy = (
        0.5..20.0_f64,
        15.0..28.0_f64,
        0.0..40.0_f64,
        20u32..200,
        5u32..60,
        -0.3..0.8_f64,
        -0.3..0.6_f64,
        any::<bool>(),
    );
    runner
        .run(
            &strategy,
            |(m, a_deg, b_deg, z, z_mate, x, x_mate, internal)| {
                let (alpha_n, beta) = (a_deg.to_radians(), b_deg.to_radians());
                let spec = GearSpec {
                    normal_module_mm: m,
                    normal_pressure_angle_rad: alpha_n,
                    helix_angle_rad: beta,
                    hand: Hand::Right,
                    teeth: z,
                    mesh: if internal {
                        Mesh::Internal
                    } else {
                        Mesh::External
                    },
                    profile_shift: x,
                    face_width_mm: None,
                    rack: BasicRack::DIN_867,
                };
                let z_mate = if internal { z_mate.min(z - 8) } else { z_mate };
                let req = GearRequest {
                    spec,
                    shift_name: "--shift",
                    allowances_mm: None,
                    span_k: None,
                    ball_mm: None,
                    at_diameters_mm: vec![],
                    mate: Some(MateRequest {
                        teeth: z_mate,
                        shift_name: "--mate-shift",
                        profile_shift: Some(x_mate),
                        allowances_mm: None,
                        face_width_mm: None,
                        centre_distance_mm: None,
                    }),
                };
                // invalid gears (pointed, span off the face, ...) are not the subject here
                let Ok(report) = GearReport::compute(&req) else {
                    return Ok(());
                };
                let pinion = if internal {
                    (f64::from(z_mate), x_mate)
                } else {
                    (f64::from(z), x)
                };
                let mate = if internal {
                    (f64::from(z), x)
                } else {
                    (f64::from(z_mate), x_mate)
                };
                let (d1, d2) = active_roots(m, alpha_n, beta, pinion, mate, internal);
                for w in report
                    .warnings
                    .iter()
                    .filter(|w| w.contains("interference"))
                {
                    prop_assert!(
                        !w.contains("None") && !w.contains("Some("),
                        "debug text in {w}"
                    );
                    let (i, d) = if w.starts_with("gear 1") {
                        (1, d1)
                    } else {
                        (2, d2)
                    };
                    match d {
                        Some(d) => {
                            seen_some.set(seen_some.get() + 1);
                            let want = format!("active root diameter d_Nf{i} = {d:.4} mm");
                            prop_assert!(w.contains(&want), "{w} (want {want})");
                        }
                        None => {
                            seen_none.set(seen_none.get() + 1);
                            let want = format!("no active root diameter d_Nf{i}");
                            prop_assert!(w.contains(&want), "{w}");
                        }
                    }
                }
                Ok(())
            },
        )
        .unwrap();
    let (n, s) = (seen_none.get(), seen_some.get());
    assert!(n > 3 && s > 3, "{n} / {s}");
}

/// Huge and infinite values in messages: exponent form and ∞, not 300 digits and "inf".
#[test]
fn huge_and_infinite_values_read_in_short_form() {
    let mut s = GearSpec::spur(1.0, 20f64.to_radians(), 20);
    s.face_width_mm = Some(1e300);
    let e = gearcomp_geometry::Gear::new(s).unwrap_err().to_string();
    assert!(e.contains("face_width_mm = 1e300 mm"), "{e}");
    let mut s = GearSpec::spur(1.0, 20f64.to_radians(), 10);
    s.profile_shift = -1.5; // d_a = 9 mm below d_b = 9.3969 mm
    let e = gearcomp_geometry::Gear::new(s).unwrap_err().to_string();
    assert!(
        e.contains("tip diameter d_a = 9 mm") && e.contains("9.396926 … ∞ mm"),
        "{e}"
    );
}
