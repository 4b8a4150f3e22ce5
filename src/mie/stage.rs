//! `mie` stage (placeholder during development).
