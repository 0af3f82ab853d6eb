//! What `gearcomp grind` prints: the run's record ([`GrindReport`], from
//! `gearcomp_grinding::report`) as JSON or its text table, and the HTML report.

use super::*;

pub(super) fn emit(out: &GrindReport, a: &SetupArgs) -> Result<()> {
    if let Some(path) = &a.report {
        write_report(out, path)?;
    }
    if a.json {
        for w in &out.warnings {
            eprintln!("warning: {w}");
        }
        println!("{}", serde_json::to_string_pretty(out)?);
    } else {
        print!("{}", out.to_table());
        if let Some(p) = &a.report {
            println!("  report: {}", p.display());
        }
    }
    Ok(())
}
