//! gearcomp-shaping (being built).
