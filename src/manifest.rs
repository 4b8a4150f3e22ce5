//! Manifests: TOML job descriptions in `manifests/*.toml`.
//!
//! ```toml
//! [[table]]
//! name = "water-index"          # output: <out>/<name>.sbt ; [a-z0-9][a-z0-9._-]*
//! stage = "water-index"         # see `scatterbake stages`
//! description = "optional text"
//! [table.params]                # stage parameters (see `scatterbake stages`)
//! wavelength_nm = [380.0, 700.0, 10.0]
//! temperature_c = [0.0, 20.0]
//! ```
//!
//! Every problem (syntax, unknown key, wrong type, out-of-range value, unknown stage, duplicate
//! table name) is reported as `FILE:LINE:COLUMN: key `K`: message`.

use crate::stages::{Job, PlanError, Stage};
use serde_spanned::Spanned;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::de::{DeTable, DeValue, ValueDeserializer};

/// A manifest error with its location: `FILE:LINE:COLUMN: key `K`: message`, or `FILE: message`
/// when the problem has no place in the text (the file could not be read).
#[derive(Debug)]
pub struct ManifestError {
    pub file: PathBuf,
    /// 1-based line; 0 when the problem has no place in the text.
    pub line: usize,
    /// 1-based column; 0 when the problem has no place in the text.
    pub column: usize,
    /// Dotted key path, when the problem is at a key.
    pub key: Option<String>,
    pub message: String,
}

impl std::fmt::Display for ManifestError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file.display())?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        f.write_str(": ")?;
        if let Some(k) = &self.key {
            write!(f, "key `{k}`: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ManifestError {}

/// One planned output table.
pub struct PlannedTable {
    /// Output table name (file stem).
    pub name: String,
    /// Manifest file it came from.
    pub manifest: PathBuf,
    /// Optional description from the manifest.
    pub description: Option<String>,
    /// The stage.
    pub stage: Box<dyn Stage>,
    /// The planned job.
    pub job: Box<dyn Job>,
}

fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(src.len());
    let before = &src[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rfind('\n').map_or(offset, |p| offset - p - 1) + 1;
    (line, column)
}

struct Ctx<'a> {
    file: &'a Path,
    src: &'a str,
}

impl Ctx<'_> {
    fn err(
        &self,
        span: Option<Range<usize>>,
        key: Option<String>,
        message: impl Into<String>,
    ) -> ManifestError {
        let (line, column) = span.map_or((1, 1), |s| line_col(self.src, s.start));
        ManifestError {
            file: self.file.to_path_buf(),
            line,
            column,
            key,
            message: message.into(),
        }
    }
}

fn type_name(v: &DeValue<'_>) -> &'static str {
    match v {
        DeValue::String(_) => "string",
        DeValue::Integer(_) => "integer",
        DeValue::Float(_) => "float",
        DeValue::Boolean(_) => "boolean",
        DeValue::Datetime(_) => "datetime",
        DeValue::Array(_) => "array",
        DeValue::Table(_) => "table",
    }
}

/// Find the span of a dotted key inside a table (for error locations).
fn find_key_span(table: &DeTable<'_>, dotted: &str) -> Option<Range<usize>> {
    let mut parts = dotted.split('.');
    let first = parts.next()?;
    let (k, v) = table.iter().find(|(k, _)| k.get_ref().as_ref() == first)?;
    let rest: Vec<&str> = parts.collect();
    if rest.is_empty() {
        return Some(k.span());
    }
    match v.get_ref() {
        DeValue::Table(t) => find_key_span(t, &rest.join(".")).or(Some(k.span())),
        _ => Some(k.span()),
    }
}

fn valid_table_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_lowercase() || c.is_ascii_digit())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || matches!(c, '.' | '_' | '-'))
        && !name.ends_with(".sbt")
        && name.len() <= 128
}

/// Read and plan every table of a manifest file.
pub fn load_manifest(file: &Path) -> Result<Vec<PlannedTable>, ManifestError> {
    let src = std::fs::read_to_string(file).map_err(|e| ManifestError {
        file: file.to_path_buf(),
        line: 0,
        column: 0,
        key: None,
        message: format!("the manifest could not be read: {e}"),
    })?;
    parse_manifest(file, &src)
}

/// Plan every table of a manifest given as text (`file` is used for messages and provenance).
pub fn parse_manifest(file: &Path, src: &str) -> Result<Vec<PlannedTable>, ManifestError> {
    let ctx = Ctx { file, src };
    let root = DeTable::parse(src).map_err(|e| {
        ctx.err(
            e.span(),
            None,
            format!("TOML syntax error: {}", e.message()),
        )
    })?;
    let root = root.into_inner();
    let mut out: Vec<PlannedTable> = Vec::new();
    for (idx, entry) in table_entries(&ctx, &root)?.iter().enumerate() {
        let fields = EntryFields::read(&ctx, idx, entry)?;
        let name = fields.checked_name(&ctx, idx, entry, &out)?;
        let stage = fields.resolved_stage(&ctx, idx, entry)?;
        let job = fields.planned_job(&ctx, idx, entry, stage.as_ref())?;
        out.push(PlannedTable {
            name,
            manifest: file.to_path_buf(),
            description: fields.description,
            stage,
            job,
        });
    }
    Ok(out)
}

/// The `[[table]]` array of a manifest's root (the only top-level key allowed).
fn table_entries<'t, 'de>(
    ctx: &Ctx<'_>,
    root: &'t DeTable<'de>,
) -> Result<&'t toml::de::DeArray<'de>, ManifestError> {
    let mut tables_value: Option<&Spanned<DeValue<'_>>> = None;
    for (k, v) in root.iter() {
        match k.get_ref().as_ref() {
            "table" => tables_value = Some(v),
            other => {
                return Err(ctx.err(
                    Some(k.span()),
                    Some(other.to_string()),
                    "unknown top-level key (expected only [[table]] entries)",
                ));
            }
        }
    }
    let Some(tables_value) = tables_value else {
        return Err(ctx.err(None, None, "manifest has no [[table]] entries"));
    };
    match tables_value.get_ref() {
        DeValue::Array(entries) => Ok(entries),
        other => Err(ctx.err(
            Some(tables_value.span()),
            Some("table".into()),
            format!(
                "expected an array of tables ([[table]]), found {}",
                type_name(other)
            ),
        )),
    }
}

/// The keys of one `[[table]]` entry, checked for type and spelling but not yet for meaning.
struct EntryFields<'t, 'de> {
    name: Option<(String, Range<usize>)>,
    stage_name: Option<(String, Range<usize>)>,
    description: Option<String>,
    params: Option<&'t Spanned<DeValue<'de>>>,
}

impl<'t, 'de> EntryFields<'t, 'de> {
    fn read(
        ctx: &Ctx<'_>,
        idx: usize,
        entry: &'t Spanned<DeValue<'de>>,
    ) -> Result<Self, ManifestError> {
        let DeValue::Table(t) = entry.get_ref() else {
            return Err(ctx.err(
                Some(entry.span()),
                Some(format!("table[{idx}]")),
                "expected a table",
            ));
        };
        let mut fields = EntryFields {
            name: None,
            stage_name: None,
            description: None,
            params: None,
        };
        for (k, v) in t.iter() {
            let key = k.get_ref().as_ref();
            let want_string = |v: &Spanned<DeValue<'_>>| -> Result<String, ManifestError> {
                match v.get_ref() {
                    DeValue::String(s) => Ok(s.to_string()),
                    other => Err(ctx.err(
                        Some(v.span()),
                        Some(format!("table[{idx}].{key}")),
                        format!("expected a string, found {}", type_name(other)),
                    )),
                }
            };
            match key {
                "name" => fields.name = Some((want_string(v)?, v.span())),
                "stage" => fields.stage_name = Some((want_string(v)?, v.span())),
                "description" => fields.description = Some(want_string(v)?),
                "params" => fields.params = Some(v),
                other => {
                    return Err(ctx.err(
                        Some(k.span()),
                        Some(format!("table[{idx}].{other}")),
                        "unknown key (expected name, stage, description, params)",
                    ));
                }
            }
        }
        Ok(fields)
    }

    /// The table name: present, well formed, and not used by an earlier entry.
    fn checked_name(
        &self,
        ctx: &Ctx<'_>,
        idx: usize,
        entry: &Spanned<DeValue<'_>>,
        earlier: &[PlannedTable],
    ) -> Result<String, ManifestError> {
        let key = Some(format!("table[{idx}].name"));
        let Some((name, name_span)) = &self.name else {
            return Err(ctx.err(Some(entry.span()), key, "missing key"));
        };
        if !valid_table_name(name) {
            return Err(ctx.err(
                Some(name_span.clone()),
                key,
                format!("`{name}` is not a valid table name (lowercase letters, digits, '.', '_', '-'; no extension)"),
            ));
        }
        if earlier.iter().any(|p| &p.name == name) {
            return Err(ctx.err(
                Some(name_span.clone()),
                key,
                format!("duplicate table name `{name}`"),
            ));
        }
        Ok(name.clone())
    }

    /// The registered stage the entry names.
    fn resolved_stage(
        &self,
        ctx: &Ctx<'_>,
        idx: usize,
        entry: &Spanned<DeValue<'_>>,
    ) -> Result<Box<dyn Stage>, ManifestError> {
        let key = Some(format!("table[{idx}].stage"));
        let Some((stage_name, stage_span)) = &self.stage_name else {
            return Err(ctx.err(Some(entry.span()), key, "missing key"));
        };
        crate::stages::find(stage_name).ok_or_else(|| {
            let known: Vec<&str> = crate::stages::registry().iter().map(|s| s.name()).collect();
            ctx.err(
                Some(stage_span.clone()),
                key,
                format!("unknown stage `{stage_name}` (known: {})", known.join(", ")),
            )
        })
    }

    /// The stage's job planned from `params` (an absent `params` is an empty table), with
    /// errors located at the offending key.
    fn planned_job(
        &self,
        ctx: &Ctx<'_>,
        idx: usize,
        entry: &Spanned<DeValue<'_>>,
        stage: &dyn Stage,
    ) -> Result<Box<dyn Job>, ManifestError> {
        let empty = Spanned::new(entry.span(), DeValue::Table(DeTable::default()));
        let params = self.params.unwrap_or(&empty);
        let DeValue::Table(params_table) = params.get_ref() else {
            return Err(ctx.err(
                Some(params.span()),
                Some(format!("table[{idx}].params")),
                format!("expected a table, found {}", type_name(params.get_ref())),
            ));
        };
        stage
            .plan(ValueDeserializer::from(params.clone()))
            .map_err(|e| plan_error_at_key(ctx, idx, params, params_table, e))
    }
}

/// A stage's planning error located at the key it concerns.
fn plan_error_at_key(
    ctx: &Ctx<'_>,
    idx: usize,
    params: &Spanned<DeValue<'_>>,
    params_table: &DeTable<'_>,
    e: PlanError,
) -> ManifestError {
    match e {
        PlanError::Deserialize(e) => {
            let span = e.span();
            // Name the key at the error position when there is one.
            let key = span.as_ref().and_then(|s| {
                params_table
                    .iter()
                    .find(|(k, v)| {
                        k.span().start <= s.start && s.start < v.span().end.max(k.span().end)
                    })
                    .map(|(k, _)| k.get_ref().to_string())
            });
            ctx.err(
                span,
                Some(format!(
                    "table[{idx}].params{}",
                    key.map(|k| format!(".{k}")).unwrap_or_default()
                )),
                e.message().to_string(),
            )
        }
        PlanError::Invalid { key, message } => ctx.err(
            find_key_span(params_table, &key).or(Some(params.span())),
            Some(format!("table[{idx}].params.{key}")),
            message,
        ),
    }
}

/// All `*.toml` files directly in `dir`, sorted by name (subfolders such as `full/` are not
/// included: they hold big grids built only on request).
pub fn default_manifests(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Test helper: plan every entry of a manifest file (a relative path is taken from the package
    /// root) with its registered stage, panicking with the manifest error; returns (table name,
    /// job) pairs.
    fn plan_manifest_file(path: &str) -> Vec<(String, Box<dyn Job>)> {
        let full = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
        let text =
            std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("{}: {e}", full.display()));
        parse_manifest(std::path::Path::new(path), &text)
            .unwrap_or_else(|e| panic!("{e}"))
            .into_iter()
            .map(|t| (t.name, t.job))
            .collect()
    }

    /// The shipped hair manifests parse and plan (their tables build in the pipeline).
    #[test]
    fn shipped_hair_manifests_plan() {
        for path in ["manifests/hair-dual.toml", "manifests/full/hair-dual.toml"] {
            assert!(!plan_manifest_file(path).is_empty(), "{path}");
        }
    }

    /// The shipped fur medulla manifests plan with the documented grids.
    #[test]
    fn shipped_manifests_plan_with_the_documented_grids() {
        // (file, tasks of each table in order): Monte Carlo and adaptive one per (σ, g),
        // characteristics one per σ, adding–doubling one per g.
        for (file, tasks) in [
            ("manifests/fur-medulla.toml", [9, 5]),
            ("manifests/full/fur-medulla-full.toml", [1024, 1024]),
            ("manifests/full/fur-medulla-thesis.toml", [64, 16]),
        ] {
            let jobs = plan_manifest_file(file);
            assert_eq!(jobs.len(), 2, "{file}");
            for ((_, job), n) in jobs.into_iter().zip(tasks) {
                assert_eq!(job.tasks().len(), n, "{file}");
                if file.contains("full/") {
                    let p: crate::stages::fur_medulla::MedullaParams =
                        serde_json::from_value(job.parameters()).unwrap();
                    let sigma = p.sigma.points();
                    assert_eq!((sigma.len(), sigma[0], sigma[63]), (64, 0.0, 20.0));
                    assert!((sigma[1] - 20.0 / 63.0).abs() < 1e-12);
                    let g = p.g.points();
                    assert!((g[1] - 0.8 / 15.0).abs() < 1e-12 && g[15] == 0.8);
                    let e = p.h.or(p.theta_i_deg).unwrap().points();
                    assert_eq!(e.len(), 64);
                }
            }
        }
    }

    fn err(src: &str) -> ManifestError {
        match parse_manifest(Path::new("m.toml"), src) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e,
        }
    }

    const GOOD: &str = "[[table]]\nname = \"w\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = [400.0, 700.0, 10.0]\ntemperature_c = [20.0]\n";

    #[test]
    fn good_manifest_plans() {
        let t = parse_manifest(Path::new("m.toml"), GOOD).unwrap();
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].job.tasks().len(), 1);
    }

    #[test]
    fn unknown_param_key_names_line_and_key() {
        let e = err(&GOOD.replace(
            "temperature_c = [20.0]",
            "temperature_c = [20.0]\nbogus = 3",
        ));
        assert_eq!(e.line, 7, "{e}");
        assert!(e.to_string().contains("bogus"), "{e}");
    }

    #[test]
    fn wrong_type_names_line() {
        let e = err(&GOOD.replace("[20.0]", "\"hot\""));
        assert_eq!(e.line, 6, "{e}");
        assert!(e.to_string().contains("temperature_c"), "{e}");
    }

    #[test]
    fn out_of_range_names_line_and_key() {
        let e = err(&GOOD.replace("[20.0]", "[20.0, 150.0]"));
        assert_eq!(e.line, 6, "{e}");
        assert!(e.to_string().contains("params.temperature_c"), "{e}");
    }

    #[test]
    fn unknown_stage_and_top_level_key() {
        let e = err(&GOOD.replace("water-index", "nope"));
        assert_eq!(e.line, 3);
        assert!(e.to_string().contains("unknown stage"));
        let e = err(&format!("colour = 1\n{GOOD}"));
        assert_eq!(e.line, 1);
        let e = err("[[table]\n");
        assert!(e.to_string().contains("syntax"), "{e}");
    }

    #[test]
    fn bad_and_duplicate_names() {
        let e = err(&GOOD.replace("name = \"w\"", "name = \"../evil\""));
        assert!(e.to_string().contains("not a valid table name"));
        let e = err(&format!("{GOOD}{GOOD}"));
        assert!(e.to_string().contains("duplicate"), "{e}");
    }
}
