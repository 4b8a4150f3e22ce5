//! One module per subcommand family; each holds the clap argument struct and the glue that
//! calls the library.

pub mod build;
pub mod cloth;
pub mod debye;
pub mod hair;
pub mod legendre;
pub mod lut;
pub mod medulla;
pub mod mie;
pub mod mieplot;
pub mod mitsuba;
pub mod plot;
pub mod plot_raytrace;
pub mod raytrace;
pub mod render;
pub mod table;

/// A clap value parser for a library enum that names its variants (`NAMES`) and parses them
/// (`FromStr`): `--help` lists the names and a wrong one is refused with the list.
pub fn named<T>(names: &'static [&'static str]) -> impl clap::builder::TypedValueParser<Value = T>
where
    T: std::str::FromStr + Clone + Send + Sync + 'static,
    T::Err: std::fmt::Display,
{
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(names)
        .try_map(|s| s.parse::<T>().map_err(|e| e.to_string()))
}

#[cfg(test)]
mod consumer_tests;
