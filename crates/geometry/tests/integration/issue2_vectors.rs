//! The published test vectors of issue 2 (docs/geometry.md "Published test vectors", TV1–TV3), through the
//! library API. Tolerance 5e-5 mm (or 5e-7 for Σx) is half a unit of the last published
//! digit: the references print 4 (Σx: 6) decimals.
#![allow(clippy::unwrap_used, clippy::expect_used)]
// The published s_n = 1.5708 mm is a 4-decimal value, not an attempt at π/2.
#![allow(clippy::approx_constant)]

use gearcomp_geometry::{
    centre_distance_for_shift_sum, shift_sum_for_centre_distance, Gear, GearPair, GearSpec, Hand,
};

const HALF_UNIT_4: f64 = 5e-5;

fn deg(d: f64) -> f64 {
    d.to_radians()
}

fn close(name: &str, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{name}: got {got:.7}, want {want} ± {tol}"
    );
}

/// TV1, MESYS helical gear calculator: z = 20, m_n = 1, α_n = 20°, x = 0, D_M = 1.7, k = 2.
#[test]
fn tv1_mesys_spur_z20() {
    let g = Gear::new(GearSpec::spur(1.0, deg(20.0), 20)).unwrap();
    let d = g.dims();
    close("d", d.reference_diameter_mm, 20.0, HALF_UNIT_4);
    close("d_b", d.base_diameter_mm, 18.7939, HALF_UNIT_4);
    close("d_a", d.tip_diameter_mm, 22.0, HALF_UNIT_4);
    close("d_f", d.root_diameter_mm, 17.5, HALF_UNIT_4);
    close(
        "d_Ff",
        d.root_form_diameter_mm.unwrap(),
        18.8003,
        HALF_UNIT_4,
    );
    close(
        "x_Emin",
        d.min_shift_undercut.unwrap(),
        -0.0843,
        HALF_UNIT_4,
    );
    close(
        "s_n",
        g.normal_thickness_at_reference_mm(0.0),
        1.5708,
        HALF_UNIT_4,
    );
    close(
        "s_n at d",
        g.normal_thickness_at_mm(20.0, 0.0).unwrap(),
        1.5708,
        HALF_UNIT_4,
    );
    close(
        "s_an",
        g.tip_normal_thickness_mm(0.0).unwrap(),
        0.6949,
        HALF_UNIT_4,
    );
    close("W_2", g.span(2, 0.0).unwrap().span_mm, 4.7083, HALF_UNIT_4);
    let ball = g.ball_dimension(1.7, 0.0).unwrap();
    close("M_dK", ball.dimension_mm, 22.2941, HALF_UNIT_4);
    // MESYS also prints the radial dimension M_rK = 11.1471; M_dK/2 = 11.147047 rounds to
    // 11.1470, so MESYS rounds from slightly different digits: checked to one unit (1e-4).
    close("M_rK", ball.dimension_mm / 2.0, 11.1471, 1e-4);
}

/// TV2, Ondrives/MESYS: z = 30, m_n = 1, DIN 867, A_sn = −0.06 / −0.03 mm, D_M = 1.7.
#[test]
fn tv2_ondrives_spur_z30_allowances() {
    let g = Gear::new(GearSpec::spur(1.0, deg(20.0), 30)).unwrap();
    close("d_b", g.dims().base_diameter_mm, 28.1908, HALF_UNIT_4);
    let cases = [
        (-0.06, 1.5108, -0.0824, 27.3352, 32.1641),
        (-0.03, 1.5408, -0.0412, 27.4176, 32.2380),
    ];
    for (a, s_n, x_e, d_f, m_dk) in cases {
        let x = g.generating_shift(a).unwrap();
        close("x_E", x, x_e, HALF_UNIT_4);
        close(
            "s_n",
            g.normal_thickness_at_reference_mm(x),
            s_n,
            HALF_UNIT_4,
        );
        close("d_f", g.root_diameter_mm(x), d_f, HALF_UNIT_4);
        close(
            "M_dK",
            g.ball_dimension(1.7, x).unwrap().dimension_mm,
            m_dk,
            HALF_UNIT_4,
        );
        close("A_sn back", g.allowance_from_shift(x), a, 1e-14);
    }
}

fn tv3_gears() -> (Gear, Gear) {
    let mut s1 = GearSpec::spur(3.5, deg(20.0), 31);
    s1.helix_angle_rad = deg(21.0);
    s1.hand = Hand::Right;
    let mut s2 = s1;
    s2.teeth = 30;
    s2.hand = Hand::Left;
    (Gear::new(s1).unwrap(), Gear::new(s2).unwrap())
}

/// TV3, generating-profile-shift worked example: m_n = 3.5, α_n = 20°, β = 21°,
/// z1 = 31, z2 = 30, a_w = 116.5 mm.
#[test]
fn tv3_helical_pair_working_pressure_angle() {
    let (g1, g2) = tv3_gears();
    close(
        "α_t",
        g1.dims().transverse_pressure_angle_rad.to_degrees(),
        21.2991,
        HALF_UNIT_4,
    );
    let sum = shift_sum_for_centre_distance(g1.spec(), g2.spec(), 116.5).unwrap();
    close("Σx", sum, 0.651877, 5e-7);
    let pair = GearPair::new(&g1, &g2, 116.5).unwrap();
    let p = pair.geometry();
    close("a", p.reference_centre_distance_mm, 114.3447, HALF_UNIT_4);
    close(
        "α_wt",
        p.working_pressure_angle_rad.to_degrees(),
        23.8708,
        HALF_UNIT_4,
    );
    close("Σx (pair)", p.shift_sum, 0.651877, 5e-7);
    close(
        "a_w back",
        centre_distance_for_shift_sum(g1.spec(), g2.spec(), sum).unwrap(),
        116.5,
        1e-9,
    );
    // Method 2 of the same source: j_n = 0.03 mm needs Σx_E = 0.639347.
    let sum_e = pair.generating_shift_sum_for_backlash(0.03).unwrap();
    close("Σx_E", sum_e, 0.639347, 5e-7);
}

/// KHK Technical Reference (Gear technical reference, table 4.3 example): m = 3,
/// α = 20°, z1 = 12, z2 = 24, x1 = 0.6, x2 = 0.36 → α_w = 26.0886°, a = 56.4999 mm.
#[test]
fn khk_profile_shifted_spur_pair() {
    let mut s1 = GearSpec::spur(3.0, deg(20.0), 12);
    s1.profile_shift = 0.6;
    let mut s2 = GearSpec::spur(3.0, deg(20.0), 24);
    s2.profile_shift = 0.36;
    let (g1, g2) = (Gear::new(s1).unwrap(), Gear::new(s2).unwrap());
    let a = centre_distance_for_shift_sum(g1.spec(), g2.spec(), 0.96).unwrap();
    close("a", a, 56.4999, HALF_UNIT_4);
    let p = *GearPair::new(&g1, &g2, a).unwrap().geometry();
    close(
        "α_w",
        p.working_pressure_angle_rad.to_degrees(),
        26.0886,
        HALF_UNIT_4,
    );
}
