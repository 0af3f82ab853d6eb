//! Shared geometries of the tests: G1 (our test list) and G1-Z5 (docs/dressing.md "Reference case G1-Z5").
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::worm::Worm;

/// Worm z_S, d_S0, m_n = 3, α_n = 20°, with a gap-filling dresser d_A, jacket 0.8 mm.
pub fn setup(z_s: u32, d_s0: f64, d_a: f64) -> DressingSetup {
    let worm = Worm::design(z_s, d_s0, 3.0, 20f64.to_radians()).unwrap();
    let dresser = Dresser::design(
        &worm,
        DresserSpec {
            d_a_mm: d_a,
            jacket_width_mm: 0.8,
            clearance_mm: 0.0,
        },
    )
    .unwrap();
    DressingSetup::new(worm, dresser)
}

/// G1: z_S = 1, d_S0 = 280, d_A = 125.
pub fn g1() -> DressingSetup {
    setup(1, 280.0, 125.0)
}

/// G1-Z5: z_S = 5, d_S0 = 160, d_A = 100.
pub fn g1_z5() -> DressingSetup {
    setup(5, 160.0, 100.0)
}
