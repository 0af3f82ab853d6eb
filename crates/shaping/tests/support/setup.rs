// Shared set-ups for the shaping tests (included with `include!`, not a test target).

#[allow(dead_code)]
fn seed_config(strokes_per_min: f64, c1_counts_per_stroke: f64) -> InterpolatorConfig {
    let cut = GearCut::new(
        40,
        25,
        3.0,
        15f64.to_radians(),
        0.0,
        Hand::Right,
        Mesh::External,
    )
    .unwrap();
    // Circular feed giving exactly `c1_counts_per_stroke` C1 counts per stroke.
    let feed = c1_counts_per_stroke / 3_600_000.0
        * std::f64::consts::TAU
        * cut.workpiece_pitch_radius_mm();
    InterpolatorConfig {
        cut,
        crank: SliderCrank::new(25.0, 200.0).unwrap(),
        strokes_per_min,
        cycle_s: 1e-3,
        crank_cpr: 3_600_000,
        c1_cpr: 3_600_000,
        c2_cpr: 3_600_000,
        circular_feed_mm: feed,
        radial_feed_mm: 0.02,
        depth_mm: 6.75,
        lift_off_mm: 0.2,
        c2_limits: RotaryLimits {
            max_speed_rad_s: rpm_to_rad_s(150.0),
            max_accel_rad_s2: 100.0 * std::f64::consts::TAU,
        },
        x_limits: LinearLimits {
            max_speed_mm_s: 200.0,
            max_accel_mm_s2: 20_000.0,
        },
        delay_compensation_cycles: 0.0,
    }
}
