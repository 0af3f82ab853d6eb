//! gearcomp-grinding (being built).
