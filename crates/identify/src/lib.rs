//! Thermal model identification from measured data (issue 4, CN105397560).
//!
//! Reads a thermal-test log ([`data`]), groups the temperature sensors by fuzzy-equivalence
//! clustering of their correlation ([`cluster`]), keeps one representative per class, fits
//! static or dynamic least-squares models ([`regress`], [`pipeline`], [`identify()`]) validated on held-out
//! data, adds the dry-hobbing workpiece shrink ([`workpiece`]), and produces the thermal
//! model file of `gearcomp_core::model` that the compensation engine runs; [`report`]
//! renders a fit as text, JSON and HTML.
//!
//! ```
//! use gearcomp_identify::{data, identify, IdentifyOptions, ModelKind, Split};
//! let csv = "time_s,a_c,b_c,c_c,d_um\n".to_string()
//!     + &(0..60).map(|k| {
//!         let t = k as f64 * 60.0;
//!         let a = 20.0 + (t / 900.0).sin();
//!         let b = 21.0 + (t / 1500.0).cos();
//!         let c = 22.0 + 0.5 * (t / 400.0).sin();
//!         format!("{t},{a},{b},{c},{}\n", 3.0 * a - 2.0 * b)
//!     }).collect::<String>();
//! let sel = data::Selection { targets: vec!["d_um".into()], ..Default::default() };
//! let table = data::read_csv(&csv, "example", &sel, Default::default()).unwrap();
//! let opts = IdentifyOptions {
//!     model: ModelKind::Static, classes: Some(3), split: Split::None,
//!     ..Default::default()
//! };
//! let id = identify(&table, &opts).unwrap();
//! assert!(id.targets[0].train_rmse < 1e-9);
//! ```

pub mod cluster;
pub mod data;
pub mod dendrogram;
pub mod dialect;
pub mod encoding;
pub mod envelope;
pub mod error;
pub mod fit;
pub mod missing_code;
mod par;
pub mod pipeline;
pub mod preamble;
pub mod quantity;
pub mod regress;
pub mod report;
pub mod resample;
pub mod select;
pub mod spreadsheet;
pub mod stack;
pub mod target_unit;
pub mod time_unit;
pub mod transform;
mod unit_words;
pub mod workpiece;

/// Seeded uniform numbers in [0, 1) for the unit tests: Knuth's MMIX linear congruential
/// generator, its top 53 bits.
#[cfg(test)]
pub(crate) fn test_uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub use error::{IdentifyError, Result};

pub use fit::{
    predict, Grouping, Identification, IdentifyOptions, ModelKind, Origin, RepresentativeBy, Split,
    TargetModel,
};
pub use pipeline::{drop_degenerate_inputs, folds, identify, plain_least_squares, train_mask};
