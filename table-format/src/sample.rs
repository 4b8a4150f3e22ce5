//! Consumer lookup API: metadata access and multilinear interpolation.
//!
//! Clamping rule: a coordinate below the first sample of its axis is clamped to the first
//! sample, one above the last to the last (no extrapolation); NaN coordinates are an error.
//! On a symmetric axis (format 3.0) the coordinate is first folded into the stored half
//! ([`Axis::fold`]; an infinite one is an error there). Axes are interpolated linearly in the
//! coordinate as stored (e.g. degrees, nm).

use crate::interp::{locate, locate_uniform, multilinear};
use crate::model::{Axis, AxisPoints, Table};

/// Why a lookup failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SampleError {
    #[error("expected {expected} coordinates (one per axis), got {got}")]
    WrongArity { expected: usize, got: usize },
    #[error("coordinate for axis `{axis}` is NaN")]
    NaN { axis: String },
    #[error("coordinate for axis `{axis}` is {x}: an even-periodic axis needs a finite one")]
    NotFinite { axis: String, x: f64 },
    #[error("no channel named `{0}`")]
    NoChannel(String),
    #[error("no axis named `{0}`")]
    NoAxis(String),
}

/// The cell of `x` on `axis`, after folding `x` on a symmetric axis.
fn locate_axis(axis: &Axis, x: f64) -> Result<(usize, f64), SampleError> {
    if x.is_nan() {
        return Err(SampleError::NaN {
            axis: axis.name.clone(),
        });
    }
    if axis.symmetry.is_some() && x.is_infinite() {
        return Err(SampleError::NotFinite {
            axis: axis.name.clone(),
            x,
        });
    }
    let x = axis.fold(x);
    Ok(match &axis.points {
        AxisPoints::Values(v) => locate(v, x),
        AxisPoints::Uniform { start, step, count } => locate_uniform(*start, *step, *count, x),
    })
}

impl Table {
    /// Axes in storage order.
    pub fn axes(&self) -> &[Axis] {
        &self.header.axes
    }

    /// Index of the channel called `name`.
    pub fn channel_index(&self, name: &str) -> Result<usize, SampleError> {
        self.header
            .channels
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| SampleError::NoChannel(name.to_string()))
    }

    /// Index of the axis called `name`.
    pub fn axis_index(&self, name: &str) -> Result<usize, SampleError> {
        self.header
            .axes
            .iter()
            .position(|a| a.name == name)
            .ok_or_else(|| SampleError::NoAxis(name.to_string()))
    }

    /// Shape of the grid (axis lengths, without the channel dimension).
    pub fn grid_shape(&self) -> Vec<usize> {
        self.header.axes.iter().map(|a| a.len()).collect()
    }

    /// Stored value at grid index `idx` (one index per axis) for channel `channel`.
    pub fn at(&self, idx: &[usize], channel: usize) -> f32 {
        let nc = self.header.channels.len();
        let mut flat = 0usize;
        for (a, &i) in self.header.axes.iter().zip(idx) {
            flat = flat * a.len() + i;
        }
        self.data[flat * nc + channel]
    }

    /// Multilinear interpolation of every channel at `coords` (one per axis, in axis units),
    /// with the folding and clamping rules of this module.
    pub fn sample(&self, coords: &[f64]) -> Result<Vec<f64>, SampleError> {
        let axes = &self.header.axes;
        if coords.len() != axes.len() {
            return Err(SampleError::WrongArity {
                expected: axes.len(),
                got: coords.len(),
            });
        }
        let pos = axes
            .iter()
            .zip(coords)
            .map(|(a, &x)| locate_axis(a, x))
            .collect::<Result<Vec<_>, _>>()?;
        let shape = self.grid_shape();
        let nc = self.header.channels.len();
        Ok((0..nc)
            .map(|c| multilinear(&pos, &shape, |flat| f64::from(self.data[flat * nc + c])))
            .collect())
    }

    /// Interpolated value of one named channel at `coords`.
    pub fn sample_channel(&self, channel: &str, coords: &[f64]) -> Result<f64, SampleError> {
        let c = self.channel_index(channel)?;
        Ok(self.sample(coords)?[c])
    }
}
