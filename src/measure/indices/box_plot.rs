//! Tukey box plots (quartiles by linear interpolation), from which corpus class bounds are
//! taken.

use serde::{Deserialize, Serialize};

/// A Tukey box plot of one sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxPlot {
    /// Number of finite values used.
    pub n: usize,
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
    /// Q3 − Q1.
    pub iqr: f64,
    /// The smallest value ≥ Q1 − 1.5·IQR.
    pub lower_whisker: f64,
    /// The largest value ≤ Q3 + 1.5·IQR.
    pub upper_whisker: f64,
    /// Values outside the whiskers.
    pub n_outliers: usize,
}

/// Quantile `q` in [0, 1] of sorted values, Hyndman–Fan type 7 (numpy's default).
fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// The box plot of the finite values of `values`; `None` when there are none.
///
/// ```
/// let b = lipmap::measure::indices::box_plot(&[1.0, 2.0, 3.0, 4.0, 100.0]).unwrap();
/// assert_eq!((b.q1, b.median, b.q3), (2.0, 3.0, 4.0));
/// assert_eq!((b.upper_whisker, b.n_outliers), (4.0, 1));
/// ```
pub fn box_plot(values: &[f64]) -> Option<BoxPlot> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let (q1, median, q3) =
        (quantile_sorted(&v, 0.25), quantile_sorted(&v, 0.5), quantile_sorted(&v, 0.75));
    let iqr = q3 - q1;
    let (lo_fence, hi_fence) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let inside: Vec<f64> = v.iter().copied().filter(|&x| x >= lo_fence && x <= hi_fence).collect();
    Some(BoxPlot {
        n: v.len(),
        q1,
        median,
        q3,
        iqr,
        lower_whisker: inside.first().copied().unwrap_or(q1),
        upper_whisker: inside.last().copied().unwrap_or(q3),
        n_outliers: v.len() - inside.len(),
    })
}
