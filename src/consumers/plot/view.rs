//! [`View`]: a table and its file stem, with helpers that cut slices out of the stored grid for
//! the preview figures (`previews`, `cloth`).

use super::style::{axis_label, short_number};
use crate::consumers::ConsumerError;
use crate::table::Table;

/// A table plus its file stem, with helpers to cut slices out of the stored grid.
pub struct View<'a> {
    pub t: &'a Table,
    pub stem: &'a str,
}

impl<'a> View<'a> {
    pub fn new(t: &'a Table, stem: &'a str) -> Self {
        View { t, stem }
    }

    pub fn ax(&self, name: &str) -> Result<usize, ConsumerError> {
        Ok(self.t.axis_index(name)?)
    }

    pub fn ch(&self, name: &str) -> Result<usize, ConsumerError> {
        Ok(self.t.channel_index(name)?)
    }

    pub fn coord(&self, axis: usize, i: usize) -> f64 {
        self.t.axes()[axis].coord(i)
    }

    pub fn len(&self, axis: usize) -> usize {
        self.t.axes()[axis].len()
    }

    /// Index of the sample nearest `v`.
    pub fn nearest(&self, axis: usize, v: f64) -> usize {
        (0..self.len(axis))
            .min_by(|&a, &b| {
                (self.coord(axis, a) - v)
                    .abs()
                    .total_cmp(&(self.coord(axis, b) - v).abs())
            })
            .unwrap_or(0)
    }

    /// The middle sample.
    pub fn mid(&self, axis: usize) -> usize {
        self.len(axis) / 2
    }

    /// `name = value unit` of sample `i` of `axis`, with a display name.
    pub fn at_text(&self, axis: usize, i: usize, shown: &str) -> String {
        let a = &self.t.axes()[axis];
        let u = match a.unit.as_str() {
            "" | "1" => String::new(),
            "deg" => "°".into(),
            "degC" => " °C".into(),
            u => match u.strip_prefix("1/") {
                Some(per) => format!(" per {}", per.replace('_', " ")),
                None => format!(" {u}"),
            },
        };
        format!("{shown} = {}{u}", short_number(a.coord(i)))
    }

    /// Channel `ch` along `free` with the other axes at `idx` (stored samples).
    pub fn line(&self, idx: &[usize], free: usize, ch: usize) -> Vec<(f64, f64)> {
        let mut k = idx.to_vec();
        (0..self.len(free))
            .map(|i| {
                k[free] = i;
                (self.coord(free, i), self.t.at(&k, ch) as f64)
            })
            .collect()
    }

    /// Channel `ch` over `xa` × `ya` with the other axes at `idx`: (xs, ys, values row-major
    /// over y then x).
    pub fn grid(
        &self,
        idx: &[usize],
        xa: usize,
        ya: usize,
        ch: usize,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let mut k = idx.to_vec();
        let xs = self.t.axes()[xa].coords();
        let ys = self.t.axes()[ya].coords();
        let mut v = Vec::with_capacity(xs.len() * ys.len());
        for j in 0..ys.len() {
            for i in 0..xs.len() {
                k[xa] = i;
                k[ya] = j;
                v.push(self.t.at(&k, ch) as f64);
            }
        }
        (xs, ys, v)
    }

    pub fn axis_label(&self, axis: usize, shown: &str) -> String {
        axis_label(shown, &self.t.axes()[axis].unit)
    }

    pub fn channel_label(&self, ch: usize, shown: &str) -> String {
        axis_label(shown, &self.t.header.channels[ch].unit)
    }

    pub fn title(&self, what: &str) -> String {
        format!("{} ({}): {what}", self.stem, self.t.header.schema)
    }
}
