//! `scatterbake` glue for [`scatterbake::consumers::export::mieplot`].

use anyhow::{Context, bail};
#[allow(unused_imports)]
use scatterbake::consumers::export::mieplot::*;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::path::PathBuf;

/// `scatterbake export --format mieplot`.
#[derive(Debug, Clone, clap::Args)]
pub struct MiePlotArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Wavelength (nm); default: the table's first wavelength. Interpolated linearly between
    /// table wavelengths (the table's lookup formula).
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Output text file (default: stdout).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run the MiePlot-style export.
pub fn run_mieplot(args: &MiePlotArgs) -> anyhow::Result<()> {
    let pt = PhaseTable::open(&args.table)?;
    let wl = args.wavelength_nm.unwrap_or_else(|| pt.wavelengths_nm()[0]);
    let d = from_table(&pt, &args.entry, wl)?;
    let e = pt.resolve_entry(&args.entry)?;
    let text = write_mieplot(
        &d,
        &[
            format!("table: {}", args.table.display()),
            format!("entry: {}", describe_entry(&pt.table, &e)),
        ],
    );
    match &args.out {
        Some(p) => std::fs::write(p, text)?,
        None => print!("{text}"),
    }
    Ok(())
}

/// `scatterbake validate`: compare a table, or one sphere computed here, against a
/// MiePlot-style reference text file (our export or a file saved by MiePlot).
#[derive(Debug, Clone, clap::Args)]
pub struct ValidateArgs {
    /// Phase-function table (.sbt); leave out to compare one sphere given by --x or
    /// --radius-um/--wavelength-nm and an index.
    pub table: Option<PathBuf>,
    /// MiePlot-style reference text file (angle, perpendicular, parallel[, unpolarised]; columns
    /// found from a header line naming them, else by position).
    #[arg(long)]
    pub reference: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Wavelength (nm); default: the reference's `# wavelength_nm:` line. For a sphere: the
    /// vacuum wavelength with --radius-um.
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Sphere mode: size parameter in the medium.
    #[arg(long, conflicts_with_all = ["table", "radius_um"])]
    pub x: Option<f64>,
    /// Sphere mode: radius in µm (with --wavelength-nm).
    #[arg(long, conflicts_with = "table")]
    pub radius_um: Option<f64>,
    /// Sphere mode: the sphere's index (--index N+Ki, --n/--k, or water at the wavelength).
    #[command(flatten)]
    pub refractive: crate::commands::mie::IndexArgs,
    /// Sphere mode: index of the medium around the sphere (MiePlot's "refractive index of the
    /// surrounding medium").
    #[arg(long, default_value_t = 1.0)]
    pub n_medium: f64,
    /// Fit one scale factor to the reference first (for references in other units).
    #[arg(long)]
    pub rescale: bool,
    /// Fail (non-zero exit) when any column's max relative error exceeds this.
    #[arg(long)]
    pub tolerance: Option<f64>,
}

/// Sphere mode of `validate`: the sphere's raw |S1|², |S2|² at the reference's angles against
/// the reference's perpendicular and parallel columns (MiePlot prints raw intensities).
pub fn run_validate_sphere(args: &ValidateArgs) -> anyhow::Result<()> {
    use crate::commands::mie::{MieArgs, MieFormat, MieQuery};
    let (r, layout) = read_mieplot_layout(
        &std::fs::read_to_string(&args.reference)
            .with_context(|| format!("reading {}", args.reference.display()))?,
    )
    .with_context(|| format!("parsing {}", args.reference.display()))?;
    if let Some(bad) = r.angle_deg.iter().find(|a| !(0.0..=180.0).contains(*a)) {
        bail!("reference angle {bad} is outside 0–180°");
    }
    let q = MieQuery::solve(&MieArgs {
        radius_um: args.radius_um,
        wavelength_nm: args.wavelength_nm.or(r.wavelength_nm),
        x: args.x,
        refractive: args.refractive.clone(),
        n_medium: args.n_medium,
        core_radius_um: None,
        core_x: None,
        core_index: None,
        angle_step_deg: 1.0,
        angles: None,
        angles_deg: Some(r.angle_deg.clone()),
        format: MieFormat::Table,
        csv: None,
    })?;
    let s11: Vec<f64> = q
        .s1_sq
        .iter()
        .zip(&q.s2_sq)
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    let c = compare_curves(&r, [&q.s1_sq, &q.s2_sq, &s11], args.rescale)?;
    let columns = if layout.named {
        format!("columns named by the header: {:?}", layout.columns)
    } else {
        format!("columns by position: {:?}", layout.columns)
    };
    println!(
        "sphere x = {}, m = {} + {}i (n_medium {}) vs {}: {} rows ({columns}{}), scale {:.6e}",
        q.x,
        q.m.re,
        q.m.im,
        q.n_medium,
        args.reference.display(),
        c.rows,
        if layout.decimal_comma {
            ", decimal commas"
        } else {
            ""
        },
        c.scale
    );
    println!(
        "  max rel. difference |S1|^2 {:.3e}, |S2|^2 {:.3e}, unpolarised {:.3e} (worst at {} deg); rms {:.3e}, {:.3e}, {:.3e}",
        c.max_rel_difference[0],
        c.max_rel_difference[1],
        c.max_rel_difference[2],
        c.worst_angle_deg,
        c.rms_rel_difference[0],
        c.rms_rel_difference[1],
        c.rms_rel_difference[2]
    );
    let worst = c.max_rel_difference.iter().cloned().fold(0.0, f64::max);
    let envelope = bhmie_drift_envelope(q.x);
    let absorbing = is_large_absorbing(q.x, q.m.im);
    let verdict = if worst <= 1e-9 {
        "agreement to the digits MiePlot prints (<= 1e-9)".to_string()
    } else if worst <= envelope {
        format!(
            "within the double-precision BHMIE drift expected at this x ({envelope:.1e}){}: not a difference of the physics",
            if absorbing { ", large absorbing x" } else { "" }
        )
    } else if args.rescale {
        format!("difference larger than the BHMIE drift envelope {envelope:.1e} (after rescaling)")
    } else {
        format!(
            "REAL DIFFERENCE: larger than the BHMIE drift envelope {envelope:.1e} (different units? try --rescale)"
        )
    };
    println!(
        "  k x = {:.4}{}; verdict: {verdict}",
        q.m.im * q.x,
        if absorbing {
            " (large absorbing x: BHMIE's double-precision results drift by up to 3e-9 (x/10)^1.5 there)"
        } else {
            ""
        }
    );
    if let Some(t) = args.tolerance
        && worst > t
    {
        bail!("max relative difference {worst:.3e} exceeds tolerance {t:.3e}");
    }
    Ok(())
}

/// Run the validation; prints the figures, errors out when over `--tolerance`.
pub fn run_validate(args: &ValidateArgs) -> anyhow::Result<()> {
    let Some(table) = &args.table else {
        return run_validate_sphere(args);
    };
    let pt = PhaseTable::open(table)?;
    let r = read_mieplot_file(&args.reference)?;
    let wl = args.wavelength_nm.or(r.wavelength_nm).ok_or_else(|| {
        anyhow::anyhow!("reference has no `# wavelength_nm:` line: pass --wavelength-nm")
    })?;
    let rep = compare(&pt, &args.entry, wl, &r, args.rescale)?;
    println!(
        "{} vs {} at {wl} nm: {} rows, scale {:.6e}, max rel. error i_perp {:.3e}, i_par {:.3e}, phase {:.3e} (worst at {} deg)",
        table.display(),
        args.reference.display(),
        rep.rows,
        rep.scale,
        rep.max_rel_error[0],
        rep.max_rel_error[1],
        rep.max_rel_error[2],
        rep.worst_angle_deg
    );
    println!(
        "  rms rel. error i_perp {:.3e}, i_par {:.3e}, phase {:.3e}; correlation {:.9}",
        rep.rms_rel_error[0], rep.rms_rel_error[1], rep.rms_rel_error[2], rep.correlation
    );
    let show = |name: &str, m: Option<(f64, f64)>| match m {
        Some((t, r)) => println!("  {name} bow maximum: table {t:.4} deg, reference {r:.4} deg"),
        None => println!("  {name} bow maximum: no reference angles in its range"),
    };
    show("primary", rep.primary_max_deg);
    show("secondary", rep.secondary_max_deg);
    if let Some(t) = args.tolerance {
        let worst = rep.max_rel_error.iter().cloned().fold(0.0, f64::max);
        if worst > t {
            bail!("max relative error {worst:.3e} exceeds tolerance {t:.3e}");
        }
    }
    Ok(())
}
