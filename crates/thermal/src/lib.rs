//! gearcomp-thermal (being built).
