//! Reference renderers that read tables through the public API.

pub mod rainbow;
