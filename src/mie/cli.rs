//! `scatterbake mie` (placeholder during development).
