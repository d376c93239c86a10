//! Accuracy of estimated visual parameters (Terissi et al. 2011, §6.1): the average mean
//! square error normalised by each parameter's variance (eq. 6, AMSE ε) and the average
//! correlation coefficient (eq. 7, ACC ρ), over R parameters and T frames.

use super::error::SpeechError;
use crate::math::DMatrix;

/// Means and standard deviations of each column.
fn column_stats(m: &DMatrix) -> Vec<(f64, f64)> {
    let t = m.nrows() as f64;
    m.column_iter()
        .map(|c| {
            let mean = c.mean();
            (mean, (c.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / t).sqrt())
        })
        .collect()
}

fn check(truth: &DMatrix, estimate: &DMatrix) -> Result<(), SpeechError> {
    if truth.shape() != estimate.shape() {
        return Err(SpeechError::DimensionMismatch {
            what: "estimate rows",
            expected: truth.nrows(),
            got: estimate.nrows(),
        });
    }
    if truth.nrows() < 2 || truth.ncols() == 0 {
        return Err(SpeechError::TooFew { what: "frames to compare", need: 2, got: truth.nrows() });
    }
    Ok(())
}

/// ε = 1/(RT) Σ_r 1/σ²_{v_r} Σ_t (õ_{v_r,t} − o_{v_r,t})² (eq. 6; the paper's R is 4).
///
/// # Errors
/// Shapes that differ, fewer than 2 frames, a true parameter that is constant.
pub fn average_mse(truth: &DMatrix, estimate: &DMatrix) -> Result<f64, SpeechError> {
    check(truth, estimate)?;
    let stats = column_stats(truth);
    let mut sum = 0.0;
    for (r, (_, sd)) in stats.iter().enumerate() {
        if sd.is_nan() || *sd <= 0.0 {
            return Err(SpeechError::Degenerate(format!("true visual parameter {r} (constant)")));
        }
        sum += (truth.column(r) - estimate.column(r)).norm_squared() / (sd * sd);
    }
    Ok(sum / truth.len() as f64)
}

/// ρ = 1/(RT) Σ_r Σ_t (o − μ)(õ − μ̃) / (σ σ̃) (eq. 7): the mean of the R per-parameter
/// correlation coefficients.
///
/// # Errors
/// As [`average_mse`], and an estimated parameter that is constant.
pub fn average_correlation(truth: &DMatrix, estimate: &DMatrix) -> Result<f64, SpeechError> {
    check(truth, estimate)?;
    let (ts, es) = (column_stats(truth), column_stats(estimate));
    let mut sum = 0.0;
    for r in 0..truth.ncols() {
        let ((mt, st), (me, se)) = (ts[r], es[r]);
        if st.is_nan() || se.is_nan() || st <= 0.0 || se <= 0.0 {
            return Err(SpeechError::Degenerate(format!("visual parameter {r} (constant)")));
        }
        sum += truth
            .column(r)
            .iter()
            .zip(estimate.column(r).iter())
            .map(|(o, e)| (o - mt) * (e - me))
            .sum::<f64>()
            / (st * se);
    }
    Ok(sum / truth.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        let truth = DMatrix::from_row_slice(4, 1, &[1.0, -1.0, 1.0, -1.0]);
        // σ² = 1; errors 0.5 each frame → ε = 0.25.
        let est = truth.map(|v| v + 0.5);
        assert!((average_mse(&truth, &est).unwrap() - 0.25).abs() < 1e-12);
        assert!((average_correlation(&truth, &est).unwrap() - 1.0).abs() < 1e-12);
        assert!((average_correlation(&truth, &(-&truth)).unwrap() + 1.0).abs() < 1e-12);
        // Predicting the mean: ε = 1, whatever the variance.
        assert!((average_mse(&(&truth * 7.0), &DMatrix::zeros(4, 1)).unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn constant_or_mismatched_input_is_an_error() {
        let c = DMatrix::from_element(3, 1, 2.0);
        assert!(average_mse(&c, &c).is_err());
        assert!(average_correlation(&DMatrix::from_row_slice(3, 1, &[1.0, 2.0, 3.0]), &c).is_err());
        assert!(average_mse(&c, &DMatrix::zeros(2, 1)).is_err());
    }
}
