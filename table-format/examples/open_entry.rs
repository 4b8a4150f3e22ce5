//! Open one entry of a table with `Table::open_slice` and print what it kept: the shape, the
//! number of samples and the SHA-256 of their little-endian bytes (the tests compare it with the
//! entry read in their own process, and measure this process's peak memory).
//!
//! ```text
//! cargo run -p scatterbake-table --example open_entry -- TABLE.sbt [I,J,...]
//! ```
//! Without indices the whole table is opened. Exit code 3 with the message when the table or
//! the entry is refused.

use scatterbake_table::{ReadLimits, Table};
use sha2::{Digest, Sha256};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: open_entry TABLE.sbt [I,J,...]");
        return ExitCode::from(2);
    };
    let entry: Result<Vec<usize>, _> = match args.get(1) {
        Some(s) => s.split(',').map(str::parse).collect(),
        None => Ok(Vec::new()),
    };
    let Ok(entry) = entry else {
        eprintln!("indices must be non-negative integers separated by commas");
        return ExitCode::from(2);
    };
    match Table::open_slice(path, &entry, &ReadLimits::default()) {
        Ok(t) => {
            let mut sha = Sha256::new();
            for v in &t.data {
                sha.update(v.to_le_bytes());
            }
            println!("shape {:?}", t.header.layout.shape);
            println!("values {}", t.data.len());
            println!("sha256 {}", hex::encode(sha.finalize()));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::from(3)
        }
    }
}
