//! `scatterbake export --format legendre`: glue for [`scatterbake::consumers::export::legendre`].

#[allow(unused_imports)]
use scatterbake::consumers::export::legendre::*;
#[allow(unused_imports)]
use scatterbake::table::Table;

/// `scatterbake export --format legendre`.
#[derive(Debug, Clone, clap::Args)]
pub struct LegendreArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: std::path::PathBuf,
    /// Entry selection, NAME=VALUE per entry axis (default: first sample of each).
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<scatterbake::consumers::read::phase::EntrySelection>,
    /// Highest Legendre order L (moments χ_0..χ_L).
    #[arg(long, default_value_t = 64)]
    pub order: usize,
    /// Delta-M truncation (Wiscombe 1977): write χ*_l and report f = χ_{L+1}.
    #[arg(long)]
    pub delta_m: bool,
    /// Report the truncation error over θ ≥ this angle (deg); default 0, or 5 with --delta-m.
    #[arg(long)]
    pub error_from_deg: Option<f64>,
    /// Only this wavelength (nearest table wavelength); default: every wavelength as a column.
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Output text file (default: stdout).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
}

/// Run the Legendre export: a text file with `# ` comment lines (table, entry, convention, and
/// the truncation error per wavelength), then rows `l  χ_l(λ_1)  χ_l(λ_2) ...`.
pub fn run_legendre(args: &LegendreArgs) -> anyhow::Result<()> {
    use std::fmt::Write as _;
    let pt = scatterbake::consumers::read::phase::PhaseTable::open(&args.table)?;
    let c = pt.curves(&args.entry)?;
    let ks: Vec<usize> = match args.wavelength_nm {
        Some(w) => vec![crate::args::nearest_wavelength(&c.wavelengths_nm, w)],
        None => (0..c.wavelengths_nm.len()).collect(),
    };
    let mut s = String::new();
    let _ = writeln!(s, "# scatterbake legendre export");
    let _ = writeln!(s, "# table: {}", crate::display::path(&args.table));
    let _ = writeln!(
        s,
        "# entry: {}",
        scatterbake::consumers::read::phase::describe_entry(&pt.table, &c.entry)
    );
    let _ = writeln!(
        s,
        "# convention: chi_l = 2 pi int_-1^1 p(mu) P_l(mu) dmu (chi_0 = 1, chi_1 = g); p_L(mu) = sum_l (2l+1)/(4 pi) chi_l P_l(mu)"
    );
    let from_deg = args
        .error_from_deg
        .unwrap_or(if args.delta_m { 5.0 } else { 0.0 });
    anyhow::ensure!(
        (0.0..180.0).contains(&from_deg),
        "--error-from-deg must be within [0, 180)"
    );
    if args.delta_m {
        let _ = writeln!(
            s,
            "# delta-M (Wiscombe 1977): p = f delta(1 - mu)/(2 pi) + (1 - f) p*_L, columns are chi*_l = (chi_l - f)/(1 - f), f = chi_(L+1) per wavelength below; scale the scattering coefficient by (1 - f)"
        );
    }
    let mut cols = Vec::new();
    for &k in &ks {
        let full = moments(&c.angles_deg, &c.phase[k], args.order + 1);
        let (chi, f) = if args.delta_m {
            let d = delta_m(&full)?;
            (d.chi_star, Some(d.f))
        } else {
            (full[..=args.order].to_vec(), None)
        };
        let e = truncation_error_from(
            &c.angles_deg,
            &c.phase[k],
            &chi,
            1.0 - f.unwrap_or(0.0),
            from_deg,
        );
        let line = format!(
            "wavelength_nm {}: order {}{}, over theta >= {from_deg} deg: max_rel_error {:.3e} (at {} deg), l1_error {:.3e}, chi_0 {:.6}, g {:.6}",
            c.wavelengths_nm[k],
            args.order,
            f.map(|f| format!(", delta-M f {f:.6}")).unwrap_or_default(),
            e.max_rel_error,
            e.max_rel_error_at_deg,
            e.l1_error,
            full[0],
            full.get(1).copied().unwrap_or(0.0)
        );
        eprintln!("{line}");
        let _ = writeln!(s, "# truncation: {line}");
        cols.push(chi);
    }
    let _ = writeln!(
        s,
        "# l\t{}",
        ks.iter()
            .map(|&k| format!("chi_l({} nm)", c.wavelengths_nm[k]))
            .collect::<Vec<_>>()
            .join("\t")
    );
    for l in 0..=args.order {
        let _ = write!(s, "{l}");
        for col in &cols {
            let _ = write!(s, "\t{:e}", col[l]);
        }
        s.push('\n');
    }
    match &args.out {
        Some(p) => std::fs::write(p, s)?,
        None => print!("{s}"),
    }
    Ok(())
}
