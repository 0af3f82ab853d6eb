//! gearcomp-dressing (being built).
