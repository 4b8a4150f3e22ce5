//! Tensor-train size/error sweep on built medulla tables:
//! `cargo run --release --example fur_tt_sweep -- TABLE.sbt CHANNEL TOL...`
use scatterbake::fur::tt::compress_table;
use scatterbake::table::{Provenance, Table, TableContent};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let t = Table::open(&args[1])?;
    let h = t.header;
    let content = TableContent {
        encoding: Default::default(),
        schema: h.schema,
        description: h.description,
        axes: h.axes,
        channels: h.channels,
        attributes: h.attributes,
        data: t.data,
    };
    let mut dense_only = content.clone();
    let ci = content
        .channels
        .iter()
        .position(|c| c.name == args[2])
        .unwrap();
    let nc = content.channels.len();
    dense_only.data = content.data.iter().skip(ci).step_by(nc).copied().collect();
    dense_only.channels = vec![content.channels[ci].clone()];
    dense_only.attributes = Default::default();
    let bytes = Table::from_content(dense_only, Provenance::default())?
        .to_bytes()?
        .len();
    println!("channel {} alone, dense zstd: {bytes} B", args[2]);
    for tol in &args[3..] {
        let (mut tt, rep) = compress_table(&content, &args[2], tol.parse()?, 256)?;
        let ranks = tt.attributes["ranks"].clone();
        tt.attributes.remove("source_attributes");
        let bytes = Table::from_content(tt, Provenance::default())?
            .to_bytes()?
            .len();
        println!(
            "tol {tol}: ranks {ranks}, {} values, file {bytes} B (without source attributes), rel Frobenius {:.3e}, max abs {:.3e} of max",
            rep.parameters, rep.rel_frobenius_error, rep.max_abs_error_rel_to_max
        );
    }
    Ok(())
}
