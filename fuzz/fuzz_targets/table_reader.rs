//! Fuzz the table reader: arbitrary bytes must give Ok or a clean error, never a panic, an
//! abort or an absurd allocation. Run: `cargo fuzz run table_reader` (see docs/testing.md).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = scatterbake_table::Table::from_bytes(data, Path::new("fuzz.sbt")) {
        // A table that verifies must also be usable through the lookup API.
        let coords: Vec<f64> = t.axes().iter().map(|a| a.coord(0)).collect();
        let _ = t.sample(&coords);
    }
});
