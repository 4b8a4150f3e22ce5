//! `scatterbake validate`: compare a phase-function table, or one sphere computed here, with a
//! MiePlot-style reference text file.

use anyhow::{Context, bail};
use scatterbake::consumers::export::mieplot::*;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
use scatterbake::consumers::validate::{
    OperatedReference, ReferenceKind, ReferenceMetadata, TableOperators, apply_table_operators,
};
use std::path::PathBuf;

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
    /// Entry selection, NAME=VALUE per entry axis (default: the one the reference names, or the
    /// table's only entry).
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
    pub refractive: crate::args::IndexArgs,
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
    /// Table mode: what the reference holds. `point`: values of the curve at its angles
    /// (`scatterbake mie`, MiePlot), taken through the table's own bin and sun-disc averages
    /// before comparing; `binned`: values averaged like the table's (an export of a table),
    /// compared as they are; `auto`: `binned` when the file has a `# table:` line.
    #[arg(long, value_enum, default_value_t = ReferenceKindArg::Auto)]
    pub reference_kind: ReferenceKindArg,
}

/// `--reference-kind`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReferenceKindArg {
    Auto,
    Point,
    Binned,
}

/// Sphere mode of `validate`: the sphere's raw |S1|², |S2|² at the reference's angles against
/// the reference's perpendicular and parallel columns (MiePlot prints raw intensities).
pub fn run_validate_sphere(args: &ValidateArgs) -> anyhow::Result<()> {
    use crate::commands::mie::{MieArgs, MieQuery};
    let (r, layout) = read_mieplot_layout(
        &std::fs::read_to_string(&args.reference)
            .with_context(|| format!("reading {}", crate::display::path(&args.reference)))?,
    )
    .with_context(|| format!("parsing {}", crate::display::path(&args.reference)))?;
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
        format: crate::curve::CurveFormat::Table,
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
        crate::display::path(&args.reference),
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

/// The reference of table mode: its data (on the table's bins for a point reference), what it
/// is, and what was done to it.
struct TableReference {
    data: MiePlotData,
    meta: ReferenceMetadata,
    operated: Option<(TableOperators, OperatedReference)>,
}

/// Read the reference and, for a point reference, apply the table's operators.
fn table_reference(pt: &PhaseTable, args: &ValidateArgs) -> anyhow::Result<TableReference> {
    let text = std::fs::read_to_string(&args.reference)
        .with_context(|| format!("reading {}", crate::display::path(&args.reference)))?;
    let (data, layout) = read_mieplot_layout(&text)
        .with_context(|| format!("parsing {}", crate::display::path(&args.reference)))?;
    let meta = ReferenceMetadata::parse(&layout.header);
    let kind = match args.reference_kind {
        ReferenceKindArg::Auto => meta.kind(),
        ReferenceKindArg::Point => ReferenceKind::Point,
        ReferenceKindArg::Binned => ReferenceKind::Binned,
    };
    let operated = match kind {
        ReferenceKind::Binned => None,
        ReferenceKind::Point => {
            let ops = TableOperators::of(pt)?;
            let o = apply_table_operators(&data, &ops).with_context(|| {
                format!(
                    "averaging {} like the table",
                    crate::display::path(&args.reference)
                )
            })?;
            Some((ops, o))
        }
    };
    Ok(TableReference {
        data,
        meta,
        operated,
    })
}

/// The entry to compare: `--entry`, else what the reference says; a table with several entries
/// and neither is an error (taking the first entry would compare the wrong drop).
fn validation_entry(
    pt: &PhaseTable,
    args: &ValidateArgs,
    meta: &ReferenceMetadata,
) -> anyhow::Result<Vec<EntrySelection>> {
    if !args.entry.is_empty() {
        return Ok(args.entry.clone());
    }
    let from_file = meta.entry_for(pt);
    let axes = pt.table.axes();
    for &i in &pt.entry_axes {
        let a = &axes[i];
        if a.len() > 1 && !from_file.iter().any(|e| e.axis == a.name) {
            bail!(
                "the reference does not say which `{}` it is for (no `# radius_um:` or `# entry:` line) \
                 and the table has {} of them: pass --entry {}=VALUE",
                a.name,
                a.len(),
                a.name
            );
        }
    }
    Ok(from_file)
}

/// Notes on whether the reference describes the same sphere as the table entry (size parameter
/// and index from a `scatterbake mie` header line).
fn sphere_notes(
    pt: &PhaseTable,
    entry: &[(String, f64)],
    wl: f64,
    meta: &ReferenceMetadata,
) -> Vec<String> {
    let mut notes = Vec::new();
    let h = &pt.table.header.attributes;
    let n_medium = h.get("n_medium").and_then(|v| v.as_f64()).unwrap_or(1.0);
    let radius = entry.iter().find(|(n, _)| n == "radius").map(|e| e.1);
    if entry.iter().any(|(n, _)| n == "distribution") && meta.size_parameter.is_some() {
        notes.push(
            "the table entry is a size distribution and the reference one sphere: not like with like"
                .into(),
        );
    }
    if let (Some(xr), Some(r)) = (meta.size_parameter, radius) {
        let xt = scatterbake::mie::size_parameter(r, wl / n_medium);
        if (xr - xt).abs() > 1e-6 * xt {
            notes.push(format!(
                "the reference is for size parameter x = {xr}, the table entry ({r} um at {wl} nm) has x = {xt}"
            ));
        }
    }
    let wavelengths = pt.wavelengths_nm();
    let Some(k) = (0..wavelengths.len()).min_by(|&a, &b| {
        (wavelengths[a] - wl)
            .abs()
            .total_cmp(&(wavelengths[b] - wl).abs())
    }) else {
        return notes;
    };
    let table_n = h
        .get("refractive_index_real")
        .and_then(|v| v.as_array())
        .and_then(|a| a.get(k))
        .and_then(|v| v.as_f64());
    if let (Some((nr, _)), Some(nt)) = (meta.relative_index, table_n)
        && (wavelengths[k] - wl).abs() < 1e-9 * wl
        && (nr - nt / n_medium).abs() > 1e-9
    {
        notes.push(format!(
            "the reference's relative index {nr} differs from the table's {} at {wl} nm (another water model or temperature?)",
            nt / n_medium
        ));
    }
    notes
}

/// Why a comparison failed, in the terms of the data: scale, sampling, sphere.
fn failure_hints(
    rep: &ValidationReport,
    reference: &TableReference,
    notes: &[String],
    tolerance: f64,
    rescale: bool,
) -> Vec<String> {
    let mut hints: Vec<String> = notes.to_vec();
    if !rescale {
        // the least-squares scale, had it been fitted
        let scale = rep.fitted_scale;
        if (scale - 1.0).abs() > 10.0 * tolerance {
            hints.push(format!(
                "the reference is about {scale:.4e} times the table: another normalisation (MiePlot prints raw |S|^2)? try --rescale"
            ));
        }
    }
    match &reference.operated {
        Some((_, o)) if o.resolution_error > 0.1 * tolerance => hints.push(format!(
            "the reference's own angle step ({} deg) limits the comparison to about {:.1e}: use a finer step",
            o.reference_step_deg, o.resolution_error
        )),
        None if reference.meta.kind() == ReferenceKind::Point => hints.push(
            "the reference was compared as binned values but has no `# table:` line: if it is a point \
             evaluation (scatterbake mie, MiePlot), use --reference-kind point"
                .into(),
        ),
        _ => {}
    }
    if hints.is_empty() {
        hints.push(format!(
            "largest difference at {} deg; the curves differ beyond the reference's sampling error",
            rep.worst_angle_deg
        ));
    }
    hints
}

/// Run the validation; prints the figures, errors out when over `--tolerance`.
pub fn run_validate(args: &ValidateArgs) -> anyhow::Result<()> {
    let Some(table) = &args.table else {
        return run_validate_sphere(args);
    };
    let pt = PhaseTable::open(table)?;
    let reference = table_reference(&pt, args)?;
    let wl = args
        .wavelength_nm
        .or(reference.meta.wavelength_nm)
        .or(reference.data.wavelength_nm)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "the reference states no wavelength (`# wavelength_nm:` line): pass --wavelength-nm"
            )
        })?;
    let selection = validation_entry(&pt, args, &reference.meta)?;
    let entry = pt.resolve_entry(&selection)?;
    let compared = match &reference.operated {
        Some((_, o)) => &o.data,
        None => &reference.data,
    };
    let rep = compare(&pt, &selection, wl, compared, args.rescale)?;
    println!(
        "{} [{}] vs {} at {wl} nm",
        crate::display::path(table),
        describe_entry(&pt.table, &entry),
        crate::display::path(&args.reference),
    );
    match &reference.operated {
        Some((ops, o)) => println!(
            "  reference: point values every {} deg over [{}, {}] deg, taken through the table's operators ({}); \
             its own sampling error ~{:.1e}; {} bins compared, {} not covered",
            o.reference_step_deg,
            reference.data.angle_deg[0],
            reference.data.angle_deg[reference.data.angle_deg.len() - 1],
            ops.describe(),
            o.resolution_error,
            rep.rows,
            o.bins_left_out
        ),
        None => println!(
            "  reference: values compared as they are (binned like the table), {} angles",
            rep.rows
        ),
    }
    println!(
        "  max rel. error i_perp {:.3e}, i_par {:.3e}, phase {:.3e} (worst at {} deg); rms {:.3e}, {:.3e}, {:.3e}; correlation {:.9}; scale {:.6e}",
        rep.max_rel_error[0],
        rep.max_rel_error[1],
        rep.max_rel_error[2],
        rep.worst_angle_deg,
        rep.rms_rel_error[0],
        rep.rms_rel_error[1],
        rep.rms_rel_error[2],
        rep.correlation,
        rep.scale
    );
    let show = |name: &str, m: Option<(f64, f64)>| match m {
        Some((t, r)) => println!("  {name} bow maximum: table {t:.4} deg, reference {r:.4} deg"),
        None => println!("  {name} bow maximum: no reference angles in its range"),
    };
    show("primary", rep.primary_max_deg);
    show("secondary", rep.secondary_max_deg);
    let notes = sphere_notes(&pt, &entry, wl, &reference.meta);
    for n in &notes {
        println!("  note: {n}");
    }
    if let Some(t) = args.tolerance {
        let worst = rep.max_rel_error.iter().cloned().fold(0.0, f64::max);
        if worst > t {
            for h in failure_hints(&rep, &reference, &notes, t, args.rescale) {
                eprintln!("  why: {h}");
            }
            bail!("max relative error {worst:.3e} exceeds tolerance {t:.3e}");
        }
        println!("  within tolerance {t:.1e}");
    }
    Ok(())
}
