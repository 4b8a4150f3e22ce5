//! `scatterbake stages`: the registered stages with their parameters and defaults.

use anyhow::Result;

/// List the registered stages with their parameters and defaults.
pub fn run_stages() -> Result<()> {
    for s in scatterbake::stages::registry() {
        println!(
            "{} (algorithm v{}): {}",
            s.name(),
            s.algorithm_version(),
            s.summary()
        );
        for p in s.parameters() {
            println!("    {:<24} {:<28} default: {}", p.name, p.kind, p.default);
            println!("    {:<24} {}", "", p.description);
        }
        println!();
    }
    Ok(())
}
