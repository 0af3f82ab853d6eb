//! Interface units of the helical guide (degrees, rpm, rev/s², µm). The conversions are the
//! gear crates' shared ones in [`gearcomp_geometry::units`], re-exported here.

pub use gearcomp_geometry::units::{
    deg_to_rad, mm_to_um, rad_s2_to_rev_s2, rad_s_to_rpm, rad_to_deg, rev_s2_to_rad_s2,
    rpm_to_rad_s,
};
