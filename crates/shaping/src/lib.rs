//! gearcomp-shaping: the electronic helical guide for CNC gear shaping (Procedia CIRP 56 (2016)).
//!
//! A gear shaper strokes its cutter with a crank and connecting rod while cutter (C2) and
//! workpiece (C1) roll together; for a helical gear the cutter must also turn one extra
//! revolution per cutter lead of stroke. This crate replaces the mechanical helical guide:
//!
//! - [`crank::SliderCrank`]: exact stroke position, velocity, acceleration and inverse.
//! - [`coupling::GearCut`]: Procedia CIRP 56 (2016) eq. (1), velocity and position form, internal/external,
//!   both hands, helix-angle correction Δβ.
//! - [`ratio::Ratio`]: exact reduced integer ratios, so the ideal coupling never drifts.
//! - [`interpolator::Interpolator`]: one control cycle at a time from the crank encoder,
//!   allocation-free, with a feasibility check before start.
//! - [`servo`]: position loop around a velocity loop with feed-forward, quantisation, delay.
//! - [`simulate`]: a cut in simulation: C2 tracking error and the helix slope deviation
//!   f_Hβ, compared with ISO 1328-1 tolerances (`gearcomp_geometry::iso1328`).
//! - [`gcode`]: the G83 cycle and its parser.
//! - [`report`]: a cycle's result in interface units, its text lines and the HTML report.
//!
//! Conventions (θ = 0 at the near dead point, axis directions, helix sign) are in
//! `docs/shaping.md`.
//!
//! ```
//! use gearcomp_shaping::crank::SliderCrank;
//! let crank = SliderCrank::new(25.0, 200.0).unwrap();
//! let h = crank.h_mm(30f64.to_radians());
//! assert!((h - 177.958358).abs() < 1e-6);
//! ```

pub mod coupling;
pub mod crank;
pub mod error;
pub mod gcode;
pub mod interpolator;
pub mod ratio;
pub mod report;
pub mod servo;
pub mod simulate;
pub mod units;

pub use error::{Result, ShapingError};
