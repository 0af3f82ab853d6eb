//! Life of the G1 worm (z_S 1, d_S0 280 mm, dresser 125 mm): uncorrected vs 3-point corrected.
//! Run: `cargo run --release -p gearcomp-dressing --example campaign`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::campaign::{plan, Correction, PlanSpec};
use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::worm::{Flank, Worm};

fn main() {
    let worm = Worm::design(1, 280.0, 3.0, 20f64.to_radians()).unwrap();
    let spec = DresserSpec {
        d_a_mm: 125.0,
        jacket_width_mm: 0.8,
        clearance_mm: 0.0,
    };
    let dresser = Dresser::design(&worm, spec).unwrap();
    for correction in [Correction::None, Correction::ThreePoint] {
        let rows = plan(
            &worm,
            &dresser,
            &PlanSpec {
                flank: Flank::Right,
                diameters_mm: vec![280.0, 265.0, 250.0, 235.0, 220.0],
                correction,
                crowning_mm: 0.0,
                budget_mm: 0.1,
            },
        )
        .unwrap();
        println!("{correction:?}");
        for r in rows {
            println!(
                "  d_S {:6.1} mm  max|f| {:7.4} µm  dK ({:+.3e} rad, {:+.5}°, {:+.5} mm, {:+.4} mm)",
                r.d_s_mm,
                r.deviation_max_um,
                r.dk.dphi_s_rad,
                r.dk.dgamma_rad.to_degrees(),
                r.dk.dd_mm,
                r.dk.dnu_ya_mm
            );
        }
    }
}
