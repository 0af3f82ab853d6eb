//! Cylindrical involute gear geometry (ISO 21771 / DIN 3960): being built.

pub mod involute;
pub mod shrink;
