//! Reference renderers that read tables through the public API.

pub mod measure;
pub mod rainbow;
