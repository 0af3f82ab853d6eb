//! Exact cylindrical involute gear geometry (ISO 21771 / DIN 3960) for gearcomp.
//!
//! - [`Gear`] / [`GearSpec`]: external and internal, spur and helical gears with any profile
//!   shift; diameters, pitches, lead, undercut and pointed-tooth limits.
//! - Tooth thickness and space width at any diameter ([`Gear::transverse_thickness_at_mm`],
//!   [`Gear::normal_thickness_at_mm`]), generating profile shift from thickness allowances
//!   ([`Gear::generating_shift`]).
//! - Measurements: span W_k ([`Gear::span`], [`Gear::recommended_span_k`]) and balls M_dK
//!   ([`Gear::ball_dimension`], [`Gear::recommended_ball_mm`]), with their inverses.
//! - [`GearPair`]: working pressure angle, Σx ↔ centre distance, contact ratios, backlash.
//! - [`GeneratingWorm`] (hob / grinding worm as a ZI helicoid) and [`ShaperCutter`].
//! - [`report`]: the report of a gear and its mate (what `gearcomp gear` prints: the
//!   [`report::GearReport`] record, its JSON and its text table).
//! - [`involute`]: inv α and its inverse; [`shrink`]: CN105397560 workpiece shrink.
//! - The gear vocabulary every gear crate shares: [`Hand`], [`Flank`], [`Mesh`],
//!   [`transverse_pressure_angle_rad`] and the interface [`units`] (degrees, µm, rpm).
//!
//! Lengths are mm and angles rad everywhere; degrees appear only in error messages and at
//! the CLI. Conventions (internal gears, signs, the k and ball rules) are in
//! `docs/geometry.md`.
//!
//! ```
//! use gearcomp_geometry::{Gear, GearSpec};
//! let gear = Gear::new(GearSpec::spur(1.0, 20f64.to_radians(), 20))?;
//! assert!((gear.dims().base_diameter_mm - 18.7939).abs() < 5e-5);
//! assert!((gear.span(2, 0.0)?.span_mm - 4.7083).abs() < 5e-5);
//! assert!((gear.ball_dimension(1.7, 0.0)?.dimension_mm - 22.2941).abs() < 5e-5);
//! # Ok::<(), gearcomp_geometry::GeometryError>(())
//! ```
//!
//! Every function outside [`report`] (an interface record with strings and vectors) is
//! allocation-free and returns a `Copy` error, so the thickness and measurement functions may
//! be called from a control cycle (see `benches/geometry_eval.rs`).

pub mod balls;
pub mod error;
pub mod gear;
pub mod involute;
pub mod iso1328;
pub mod pair;
pub mod report;
pub mod shrink;
pub mod span;
pub mod thickness;
pub mod tool;
pub mod units;

pub use balls::{BallMeasurement, RecommendedBall};
pub use error::{GeometryError, Result};
pub use gear::{
    transverse_pressure_angle_rad, BasicRack, Flank, Gear, GearDimensions, GearSpec, Hand, Mesh,
};
pub use pair::{
    centre_distance_for_shift_sum, shift_sum_for_centre_distance, Backlash, GearPair, PairGeometry,
};
pub use span::Span;
pub use tool::{GeneratingWorm, ShaperCutter, ShapingSetup, WormDimensions, WormSpec};
