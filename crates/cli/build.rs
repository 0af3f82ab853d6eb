//! Links the `gearcomp` executable position-dependent (`-no-pie`) on x86-64 Linux with glibc.
//!
//! A position-independent executable of this size carries ≈ 52 000 dynamic relocations
//! (1.2 MB of `.rela.dyn`) that the loader applies at every start, writing every page of the
//! 0.8 MB `.data.rel.ro`; linked at a fixed address they are resolved at link time. Measured
//! on `gearcomp --version` (`perf stat -r 50`): 1.44 → 0.96–1.08 ms CPU, 375 → 172 page
//! faults, 1.8 → 1.4 ms wall (docs/identification.md, "Performance"). The cost: the
//! executable's own code and data are not address-randomised (shared libraries, heap and
//! stacks still are). Only the link of the binaries changes (the crates are compiled as
//! before), so no other crate or profile rebuilds.

fn main() {
    let var = |k: &str| std::env::var(k).unwrap_or_default();
    if var("CARGO_CFG_TARGET_OS") == "linux"
        && var("CARGO_CFG_TARGET_ENV") == "gnu"
        && var("CARGO_CFG_TARGET_ARCH") == "x86_64"
    {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
