//! Unit conversions of the thermal engine: the shared ones of `gearcomp_geometry::units`
//! (the one place every crate converts), re-exported so thermal code and its users can keep
//! writing `gearcomp_thermal::units::…`.

pub use gearcomp_geometry::units::{
    f_to_c, h_to_s, inch_to_um, per_f_to_per_c, s_to_h, um_to_inch, um_to_mm, S_PER_H, UM_PER_INCH,
    UM_PER_MM,
};
