//! Cross-checks of the geometry against references derived independently of the code:
//! closed forms from other textbook routes, a rack-generation envelope simulation and a
//! numeric distance from the ball to the flank helicoid.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::PI;

use gearcomp_geometry::involute::inv;
use gearcomp_geometry::{
    BasicRack, Gear, GearPair, GearSpec, GeneratingWorm, Hand, Mesh, ShaperCutter, WormSpec,
};

fn deg(d: f64) -> f64 {
    d.to_radians()
}

fn gear(m: f64, a: f64, b: f64, z: u32, x: f64, mesh: Mesh) -> Gear {
    Gear::new(GearSpec {
        normal_module_mm: m,
        normal_pressure_angle_rad: deg(a),
        helix_angle_rad: deg(b),
        hand: Hand::Right,
        teeth: z,
        mesh,
        profile_shift: x,
        face_width_mm: None,
        rack: BasicRack::DIN_867,
    })
    .unwrap()
}

/// A spread of external and internal, spur and helical gears that all exist.
fn zoo() -> Vec<Gear> {
    vec![
        gear(1.0, 20.0, 0.0, 20, 0.0, Mesh::External),
        gear(3.5, 20.0, 21.0, 31, 0.3, Mesh::External),
        gear(2.0, 25.0, 30.0, 17, 0.5, Mesh::External),
        gear(5.0, 15.0, 10.0, 60, -0.4, Mesh::External),
        gear(2.0, 20.0, 0.0, 60, 0.2, Mesh::Internal),
        gear(3.0, 20.0, 18.0, 75, -0.3, Mesh::Internal),
    ]
}

/// Golden-section minimum of f on [a, b].
fn golden(mut a: f64, mut b: f64, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let x = 0.5 * (a + b);
    (x, f(x))
}

/// W_k by the textbook closed form (ISO 21771 5.5.1, DIN 3960 3.6.4), not by the code's
/// base-thickness route: m_n·cos α_n·[(k − 0.5)·π + z·inv α_t] ± 2·x·m_n·sin α_n.
#[test]
fn span_matches_closed_form_external_and_internal() {
    for g in zoo() {
        let s = g.spec();
        let z = f64::from(s.teeth);
        let (m, a) = (s.normal_module_mm, s.normal_pressure_angle_rad);
        let alpha_t = (a.tan() / s.helix_angle_rad.cos()).atan();
        let sign = if s.mesh == Mesh::External { 1.0 } else { -1.0 };
        let k = g.recommended_span_k(s.profile_shift).unwrap();
        let w = g.span(k, s.profile_shift).unwrap().span_mm;
        let closed = m * a.cos() * ((f64::from(k) - 0.5) * PI + z * inv(alpha_t))
            + sign * 2.0 * s.profile_shift * m * a.sin();
        assert!(
            (w - closed).abs() < 1e-12 * closed,
            "{s:?}: {w} vs {closed}"
        );
    }
}

/// Tooth thickness at any diameter against a simulation of rack generation: the rack's
/// straight flank is swept through the rolling motion and the deepest cut on the circle
/// of radius ρ is the flank. Agreement to 1e-9 mm.
#[test]
fn thickness_at_diameter_matches_rack_envelope() {
    for g in zoo()
        .into_iter()
        .filter(|g| g.spec().mesh == Mesh::External)
    {
        let s = *g.spec();
        let d = g.dims();
        let r = d.reference_diameter_mm / 2.0;
        let m_t = d.transverse_module_mm;
        let t = d.transverse_pressure_angle_rad.tan();
        let z = f64::from(s.teeth);
        let x = s.profile_shift;
        let y_d = r + x * s.normal_module_mm;
        let h_ap = s.normal_module_mm * s.rack.addendum_coeff;
        let a_n = s.normal_pressure_angle_rad;
        let h_ffp = s.normal_module_mm
            * (s.rack.dedendum_coeff - s.rack.root_radius_coeff * (1.0 - a_n.sin()));
        let r_ff = d.root_form_diameter_mm.unwrap() / 2.0;
        let r_a = d.tip_diameter_mm / 2.0;
        for i in 0..=8 {
            let rho = r_ff + (r_a - r_ff) * f64::from(i) / 8.0;
            // Polar angle (gear frame) where the rack's right flank crosses the circle ρ
            // after the gear turned by φ and the rack moved by −r·φ.
            let theta = |phi: f64| {
                let a0 = PI * m_t / 4.0 - y_d * t - r * phi;
                let disc = a0 * a0 * t * t - (1.0 + t * t) * (a0 * a0 - rho * rho);
                if disc < 0.0 {
                    return f64::INFINITY;
                }
                let y = (-a0 * t + disc.sqrt()) / (1.0 + t * t);
                // Only the straight part of the rack flank, between its tip rounding and
                // its root, generates the involute.
                if y < y_d - h_ffp || y > y_d + h_ap {
                    return f64::INFINITY;
                }
                (y).atan2(a0 + y * t) - phi
            };
            let n = 4000;
            let step = 1.6 / f64::from(n);
            let i_best = (0..=n)
                .min_by(|&a, &b| {
                    let fa = theta(-0.8 + step * f64::from(a));
                    let fb = theta(-0.8 + step * f64::from(b));
                    fa.total_cmp(&fb)
                })
                .unwrap();
            let phi0 = -0.8 + step * f64::from(i_best);
            assert!(i_best > 0 && i_best < n, "minimum on the bracket edge");
            let (_, theta_min) = golden(phi0 - step, phi0 + step, theta);
            let psi = theta_min - (PI / 2.0 - PI / z);
            let s_env = 2.0 * rho * psi;
            let s_lib = g.transverse_thickness_at_mm(2.0 * rho, x).unwrap();
            assert!(
                (s_env - s_lib).abs() < 1e-9,
                "{s:?} ρ={rho}: envelope {s_env} vs {s_lib}"
            );
        }
    }
}

/// The ball centre the code places must lie at D_M/2 from the flank helicoid, found by
/// minimising the distance to the involute surface built from its definition
/// (roll angle u, polar angle θ0 ∓ (u − atan u), helix twist w·tan β / r).
#[test]
fn ball_centre_is_half_a_ball_from_the_flank() {
    for g in zoo() {
        let s = *g.spec();
        let d = g.dims();
        let x = s.profile_shift;
        let z = f64::from(s.teeth);
        let r_b = d.base_diameter_mm / 2.0;
        let r = d.reference_diameter_mm / 2.0;
        let alpha_t = d.transverse_pressure_angle_rad;
        let q = (PI / 2.0 + 2.0 * x * s.normal_pressure_angle_rad.tan()) / z;
        let ball = g.recommended_ball_mm(x).unwrap();
        let meas = g.ball_dimension(ball, x).unwrap();
        let r_k = meas.centre_diameter_mm / 2.0;
        let centre = [r_k * (PI / z).cos(), r_k * (PI / z).sin(), 0.0];
        let tan_b = s.helix_angle_rad.tan();
        // Flank facing the gap centred at π/z: of the tooth at 0 (external, its flank
        // unwinds towards +θ... bounded by θ0 − inv) or of the internal tooth at 0.
        let (theta0, dir) = match s.mesh {
            Mesh::External => (q + inv(alpha_t), -1.0),
            Mesh::Internal => (q - inv(alpha_t), 1.0),
        };
        let point = |u: f64, w: f64| {
            let rho = r_b * (1.0 + u * u).sqrt();
            let th = theta0 + dir * (u - u.atan()) + w * tan_b / r;
            [rho * th.cos(), rho * th.sin(), w]
        };
        let dist = |u: f64, w: f64| {
            let p = point(u, w);
            ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2]).powi(2))
                .sqrt()
        };
        let u_max =
            ((d.tip_diameter_mm.max(d.root_diameter_mm) / 2.0 / r_b).powi(2) - 1.0).sqrt() * 1.2;
        let w_span = 2.0 * ball;
        let (w_best, _) = golden(-w_span, w_span, |w| golden(0.0, u_max, |u| dist(u, w)).1);
        let (u_best, dmin) = golden(0.0, u_max, |u| dist(u, w_best));
        assert!(
            (dmin - ball / 2.0).abs() < 1e-9,
            "{s:?}: distance {dmin} vs D_M/2 = {}",
            ball / 2.0
        );
        // The contact point found numerically is where the code says.
        let d_c = 2.0 * r_b * (1.0 + u_best * u_best).sqrt();
        assert!(
            (d_c - meas.contact_diameter_mm).abs() < 1e-6,
            "{s:?}: contact {d_c} vs {}",
            meas.contact_diameter_mm
        );
        // And the recommended ball touches on d + 2σ·x·m_n.
        let sigma = if s.mesh == Mesh::External { 1.0 } else { -1.0 };
        let target = d.reference_diameter_mm + 2.0 * sigma * x * s.normal_module_mm;
        assert!((meas.contact_diameter_mm - target).abs() < 1e-9);
    }
}

/// ε_α by the tooth-count form of ISO 21771 6.5 (a different route from the path length):
/// [z1·(tan α_a1 − tan α_wt) ± z2·(tan α_a2 − tan α_wt)] / (2π).
#[test]
fn contact_ratio_matches_tooth_count_form() {
    let cases = [
        (
            gear(3.5, 20.0, 21.0, 31, 0.4, Mesh::External),
            30,
            Mesh::External,
            116.5,
        ),
        (
            gear(3.0, 20.0, 0.0, 12, 0.6, Mesh::External),
            24,
            Mesh::External,
            56.4999,
        ),
        (
            gear(2.0, 20.0, 0.0, 20, 0.0, Mesh::External),
            60,
            Mesh::Internal,
            40.0,
        ),
    ];
    for (g1, z2, mesh2, a_w) in cases {
        let mut s2 = *g1.spec();
        s2.teeth = z2;
        s2.mesh = mesh2;
        s2.profile_shift = 0.0;
        if mesh2 == Mesh::External {
            s2.hand = Hand::Left;
        }
        let g2 = Gear::new(s2).unwrap();
        let p = *GearPair::new(&g1, &g2, a_w).unwrap().geometry();
        let tan_a = |g: &Gear| {
            (g.dims().base_diameter_mm / g.dims().tip_diameter_mm)
                .acos()
                .tan()
        };
        let tw = p.working_pressure_angle_rad.tan();
        let sign = if mesh2 == Mesh::External { 1.0 } else { -1.0 };
        let eps = (f64::from(g1.spec().teeth) * (tan_a(&g1) - tw)
            + sign * f64::from(z2) * (tan_a(&g2) - tw))
            / (2.0 * PI);
        assert!(
            (p.transverse_contact_ratio - eps).abs() < 1e-12,
            "{} vs {eps}",
            p.transverse_contact_ratio
        );
        assert!(eps > 1.0 && eps < 2.5);
    }
}

/// Backlash for a consistent design equals DIN 3967's j_t = −(A_st1 + A_st2)·cos α_t / cos α_wt.
#[test]
fn backlash_matches_din3967_form() {
    let g1 = gear(3.5, 20.0, 21.0, 31, 0.3, Mesh::External);
    let mut s2 = *g1.spec();
    s2.teeth = 30;
    s2.hand = Hand::Left;
    s2.profile_shift = 0.651877 - 0.3;
    let g2 = Gear::new(s2).unwrap();
    let a_w =
        gearcomp_geometry::centre_distance_for_shift_sum(g1.spec(), g2.spec(), 0.651877).unwrap();
    let pair = GearPair::new(&g1, &g2, a_w).unwrap();
    let (a1, a2) = (-0.08, -0.05);
    let j = pair.backlash(a1, a2).unwrap();
    let beta = deg(21.0);
    let d = g1.dims();
    let jt = -(a1 + a2) / beta.cos() * d.transverse_pressure_angle_rad.cos()
        / pair.geometry().working_pressure_angle_rad.cos();
    assert!(
        (j.circumferential_mm - jt).abs() < 1e-12,
        "{} vs {jt}",
        j.circumferential_mm
    );
    // j_bn = −(A_sn1 + A_sn2)·cos α_n (normal plane, along the line of action).
    assert!((j.normal_mm + (a1 + a2) * deg(20.0).cos()).abs() < 1e-12);
}

/// The ZI worm's base cylinder from the gear analogy equals Litvin's helicoid form
/// r_b0 = p / tan γ_b (p = p_z/2π, cos γ_b = cos γ·cos α_n), and the worm's normal base
/// pitch equals the generated gear's: π·d_b0·cos β_b0 / z0 with β_b0 = 90° − γ_b.
#[test]
fn worm_helicoid_matches_litvin() {
    for (z0, m, a, d0) in [
        (1, 2.0, 20.0, 50.0),
        (3, 3.5, 20.0, 110.0),
        (2, 1.0, 17.5, 30.0),
    ] {
        let w = GeneratingWorm::new(WormSpec {
            starts: z0,
            normal_module_mm: m,
            normal_profile_angle_rad: deg(a),
            reference_diameter_mm: d0,
            hand: Hand::Right,
        })
        .unwrap();
        let dm = w.dims();
        let gamma = (f64::from(z0) * m / d0).asin();
        let p = dm.lead_mm / (2.0 * PI);
        let gamma_b = (gamma.cos() * deg(a).cos()).acos();
        let r_b_litvin = p / gamma_b.tan();
        assert!((dm.base_diameter_mm / 2.0 - r_b_litvin).abs() < 1e-10 * r_b_litvin);
        let p_bn = PI * dm.base_diameter_mm * gamma_b.sin() / f64::from(z0);
        assert!((p_bn - PI * m * deg(a).cos()).abs() < 1e-12 * p_bn);
        // Lead = starts × axial pitch, tan α_x = tan α_n / cos γ (axial section of the thread).
        assert!((dm.lead_mm - f64::from(z0) * PI * m / gamma.cos()).abs() < 1e-10);
    }
}

/// A shaper cutter with x0 = 0 cutting at x_E = 0 rolls on the reference circles, so the
/// work root is d ∓ 2·h_a0 (DIN 3960's rack-equivalent result).
#[test]
fn shaper_at_zero_shift_cuts_the_rack_root() {
    let mut cs = GearSpec::spur(2.0, deg(20.0), 25);
    cs.rack.addendum_coeff = 1.25;
    cs.rack.dedendum_coeff = 1.5;
    let cutter = ShaperCutter::new(cs).unwrap();
    let ext = gear(2.0, 20.0, 0.0, 40, 0.0, Mesh::External);
    let int = gear(2.0, 20.0, 0.0, 80, 0.0, Mesh::Internal);
    let se = cutter.cutting(&ext, 0.0).unwrap();
    assert!((se.centre_distance_mm - 65.0).abs() < 1e-9);
    assert!((se.work_root_diameter_mm - (80.0 - 5.0)).abs() < 1e-9);
    let si = cutter.cutting(&int, 0.0).unwrap();
    assert!((si.centre_distance_mm - 55.0).abs() < 1e-9);
    assert!((si.work_root_diameter_mm - (160.0 + 5.0)).abs() < 1e-9);
    // Helical cutter lead p_z0 = π·z0·m_n / sin β0.
    let mut hs = cs;
    hs.helix_angle_rad = deg(15.0);
    let h = ShaperCutter::new(hs).unwrap();
    let lead = h.lead_mm().unwrap();
    assert!((lead - PI * 25.0 * 2.0 / deg(15.0).sin()).abs() < 1e-9);
}

/// For a very large spur gear the recommended ball tends to the rack's: touching the
/// straight flanks at the datum line, whose space is π·m/2 wide, gives
/// D_M = π·m_n/(2·cos α_n) (1.6716·m_n at 20°). At z = 10 000 the gap is O(1/z).
#[test]
fn recommended_ball_tends_to_the_rack_ball() {
    for a in [15.0, 20.0, 25.0] {
        let g = gear(2.0, a, 0.0, 10_000, 0.0, Mesh::External);
        let ball = g.recommended_ball_mm(0.0).unwrap();
        let rack = PI * 2.0 / (2.0 * deg(a).cos());
        assert!(
            (ball - rack).abs() < 2e-4 * rack,
            "α = {a}: {ball} vs {rack}"
        );
    }
}

/// `BasicRack::din_867_at`: DIN 867 itself up to the pressure angle whose rack tip carries
/// ρ_fP* = 0.25; above it the largest root radius the tip carries, which the gear accepts
/// (it refused the DIN 867 rack there) and any larger radius it refuses. The bound is checked
/// against the full-radius tip written here: a fillet of radius ρ tangent to both flanks
/// spans ρ·(1 − sin α)/cos α either side of the tip's centre line, which the half tip width
/// π/4 − h_fP*·tan α (in m_n) must hold.
#[test]
fn din_867_at_a_high_pressure_angle_carries_the_largest_root_radius() {
    use gearcomp_geometry::{BasicRack, Gear, GearSpec, Hand, Mesh};
    let spec = |alpha_deg: f64, rack: BasicRack| GearSpec {
        normal_module_mm: 3.0,
        normal_pressure_angle_rad: alpha_deg.to_radians(),
        helix_angle_rad: 0.0,
        hand: Hand::Right,
        teeth: 40,
        mesh: Mesh::External,
        profile_shift: 0.0,
        face_width_mm: None,
        rack,
    };
    for alpha_deg in [14.5f64, 20.0, 22.5, 25.0] {
        assert_eq!(
            BasicRack::din_867_at(alpha_deg.to_radians()),
            BasicRack::DIN_867,
            "{alpha_deg}°"
        );
    }
    for alpha_deg in [27.0, 28.0, 30.0, 32.0] {
        let a = f64::to_radians(alpha_deg);
        assert!(
            Gear::new(spec(alpha_deg, BasicRack::DIN_867)).is_err(),
            "{alpha_deg}°"
        );
        let r = BasicRack::din_867_at(a);
        // Independent form of the full-radius tip: half the tip width of the tooth space
        // s_tip/2 = π/4 − h_fP*·tan α equals ρ·(1 − sin α)/cos α.
        let rho = (std::f64::consts::FRAC_PI_4 - 1.25 * a.tan()) * a.cos() / (1.0 - a.sin());
        assert!(
            (r.root_radius_coeff - rho).abs() < 1e-12,
            "{alpha_deg}°: {r:?} vs {rho}"
        );
        assert!(r.root_radius_coeff < 0.25);
        assert!(Gear::new(spec(alpha_deg, r)).is_ok(), "{alpha_deg}°");
        let over = BasicRack {
            root_radius_coeff: rho * (1.0 + 1e-9),
            ..r
        };
        assert!(Gear::new(spec(alpha_deg, over)).is_err(), "{alpha_deg}°");
    }
}
