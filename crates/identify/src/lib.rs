//! gearcomp-identify (being built).
