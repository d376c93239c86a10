//! Limited-memory BFGS (Nocedal & Wright, "Numerical Optimization", 2nd ed., Alg. 7.4–7.5:
//! the two-loop recursion, H₀ = (sᵀy / yᵀy)·I) with a backtracking line search on the Armijo
//! condition. A pair is kept only when sᵀy > 0, so the implied Hessian stays positive
//! definite without a Wolfe search; a step that gives a non-finite value is halved.

/// Result of a minimisation.
#[derive(Clone, Debug, PartialEq)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub f: f64,
    pub iterations: usize,
}

/// Stopping rules.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LbfgsOptions {
    pub memory: usize,
    pub max_iterations: usize,
    /// Stop when the largest gradient component is below this.
    pub gradient_tolerance: f64,
    /// Stop when f falls by less than this fraction of |f| in an iteration.
    pub relative_tolerance: f64,
}

impl Default for LbfgsOptions {
    fn default() -> Self {
        Self { memory: 8, max_iterations: 200, gradient_tolerance: 1e-6, relative_tolerance: 1e-10 }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimises `f` from `x0`; `f` returns the value and the gradient, `None` where undefined.
/// Returns `None` when `f` is undefined at `x0`.
pub fn minimize(
    mut f: impl FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
    x0: &[f64],
    options: LbfgsOptions,
) -> Option<Minimum> {
    let mut x = x0.to_vec();
    let (mut fx, mut g) =
        f(&x).filter(|(v, g)| v.is_finite() && g.iter().all(|x| x.is_finite()))?;
    let mut hist: Vec<(Vec<f64>, Vec<f64>, f64)> = Vec::new();
    let mut iterations = 0;
    while iterations < options.max_iterations {
        if g.iter().fold(0.0f64, |m, v| m.max(v.abs())) < options.gradient_tolerance {
            break;
        }
        iterations += 1;
        // Two-loop recursion: d = −H·g.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(hist.len());
        for (s, y, rho) in hist.iter().rev() {
            let a = rho * dot(s, &q);
            q.iter_mut().zip(y).for_each(|(qi, yi)| *qi -= a * yi);
            alphas.push(a);
        }
        let gamma = hist.last().map_or_else(
            || 1.0 / g.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0),
            |(s, y, _)| dot(s, y) / dot(y, y),
        );
        q.iter_mut().for_each(|v| *v *= gamma);
        for ((s, y, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &q);
            q.iter_mut().zip(s).for_each(|(qi, si)| *qi += (a - b) * si);
        }
        let mut d: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut slope = dot(&g, &d);
        if slope.is_nan() || slope >= 0.0 {
            d = g.iter().map(|v| -v).collect();
            slope = -dot(&g, &g);
            hist.clear();
        }
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..60 {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + step * b).collect();
            if let Some((fn_, gn)) = f(&xn)
                && fn_.is_finite()
                && gn.iter().all(|v| v.is_finite())
                && fn_ <= fx + 1e-4 * step * slope
            {
                accepted = Some((xn, fn_, gn));
                break;
            }
            step *= 0.5;
        }
        let Some((xn, fn_, gn)) = accepted else { break };
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-12 * dot(&y, &y).sqrt() * dot(&s, &s).sqrt() {
            if hist.len() == options.memory {
                hist.remove(0);
            }
            hist.push((s, y, 1.0 / sy));
        }
        let decrease = fx - fn_;
        x = xn;
        fx = fn_;
        g = gn;
        if decrease <= options.relative_tolerance * fx.abs().max(1.0) {
            break;
        }
    }
    Some(Minimum { x, f: fx, iterations })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rosenbrock() {
        let f = |x: &[f64]| {
            let (a, b) = (x[0], x[1]);
            let v = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
            let g = vec![-2.0 * (1.0 - a) - 400.0 * a * (b - a * a), 200.0 * (b - a * a)];
            Some((v, g))
        };
        let opts =
            LbfgsOptions { max_iterations: 500, relative_tolerance: 0.0, ..Default::default() };
        let m = minimize(f, &[-1.2, 1.0], opts).unwrap();
        assert!((m.x[0] - 1.0).abs() < 1e-5 && (m.x[1] - 1.0).abs() < 1e-5, "{m:?}");
    }
}
