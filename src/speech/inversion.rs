//! HMM inversion (Terissi et al. 2011, §4.2): for audio O_a, the visual sequence
//! `Õ_v = argmax_{O_v} P(O_a, O_v | λ_av)` (eq. 2), found by iterating eq. 3:
//!
//! `õ_vt = [Σ_jk γ_t(j,k) Φ^v_jk]⁻¹ Σ_jk γ_t(j,k) [Φ^v_jk μ^v_jk − Φ^va_jk (o_at − μ^a_jk)]`
//!
//! with Φ_jk = Σ_jk⁻¹ split into its visual (v) and cross (va) blocks, and γ_t(j,k) the
//! component posteriors under the current estimate (the paper writes the cross term as
//! ½Φ^va(·) + ½[(·)ᵀΦ^av]; Φ is symmetric, so the halves are one term). Since
//! `Φ^v μ^v − Φ^va(o_a − μ^a) = Φ^v · (μ^v + Σ^va Σ^aa⁻¹ (o_a − μ^a))`, each step is a
//! precision-weighted blend of every component's Gaussian conditional mean of the visual part
//! given the audio.
//!
//! Departure: the paper starts from a random visual sequence. Here the first posteriors come
//! from the audio alone (each component's audio marginal N(o_a; μ^a, Σ^aa), the visual
//! dimensions integrated out), which is what the posteriors would be if nothing were known of
//! the visual part; a random start pulls the first posteriors towards arbitrary states.

use super::error::{SpeechError, bad};
use super::forward_backward::forward_backward;
use super::gaussian::Gaussian;
use super::hmm::Hmm;
use crate::math::{DMatrix, DVector};

/// Inversion settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InversionOptions {
    /// Re-estimations after the audio-only start (0 = the audio-only estimate).
    pub iterations: usize,
    /// Stop early once no visual value moves more than this.
    pub tolerance: f64,
}

impl Default for InversionOptions {
    /// No re-estimation: the first eq. 3 step from the audio-only posteriors. On 80 held-out
    /// demo sentences 0, 3 and 10 re-estimations gave the same ACC and AMSE to 0.001, and
    /// each costs as much as the first step (an hour of audio is 86,400 frames).
    fn default() -> Self {
        Self { iterations: 0, tolerance: 1e-6 }
    }
}

/// Per-component quantities of eq. 3, computed once per model.
#[derive(Clone, Debug)]
pub struct Inverter {
    hmm: Hmm,
    audio_dim: usize,
    /// ln c_jk and the audio marginal N(μ^a, Σ^aa) per component.
    audio: Vec<(f64, Gaussian)>,
    /// Φ^v_jk (dv × dv).
    phi_v: Vec<DMatrix>,
    /// Φ^v_jk μ^v_jk + Φ^va_jk μ^a_jk: the constant part of each component's term.
    offset: Vec<DVector>,
    /// Φ^va_jk (dv × da).
    phi_va: Vec<DMatrix>,
}

impl Inverter {
    /// Prepares `hmm` (trained on `[audio, visual]` vectors) for inverting audio of
    /// `audio_dim` dimensions.
    ///
    /// # Errors
    /// `audio_dim` not strictly inside the model's dimension; a degenerate covariance block.
    pub fn new(hmm: &Hmm, audio_dim: usize) -> Result<Self, SpeechError> {
        let d = hmm.dim();
        if audio_dim == 0 || audio_dim >= d {
            return Err(bad("audio dimension", format!("{audio_dim} of a {d}-dimensional model")));
        }
        let dv = d - audio_dim;
        let mut audio = Vec::new();
        let (mut phi_v, mut offset, mut phi_va) = (Vec::new(), Vec::new(), Vec::new());
        for c in hmm.components() {
            let g = &c.gaussian;
            let mu_a = g.mean.rows(0, audio_dim).into_owned();
            let mu_v = g.mean.rows(audio_dim, dv).into_owned();
            let cov_aa = g.cov.view((0, 0), (audio_dim, audio_dim)).into_owned();
            audio.push((c.weight.ln(), Gaussian::new(mu_a.clone(), cov_aa)?));
            let phi = g.precision();
            let pv = phi.view((audio_dim, audio_dim), (dv, dv)).into_owned();
            let pva = phi.view((audio_dim, 0), (dv, audio_dim)).into_owned();
            offset.push(&pv * mu_v + &pva * mu_a);
            phi_v.push(pv);
            phi_va.push(pva);
        }
        Ok(Self { hmm: hmm.clone(), audio_dim, audio, phi_v, offset, phi_va })
    }

    /// The visual sequence (T × dv) for `audio` (T × da) by eq. 3.
    ///
    /// # Errors
    /// Wrong audio width, no frames, audio impossible under the model.
    pub fn invert(&self, audio: &DMatrix, opts: &InversionOptions) -> Result<DMatrix, SpeechError> {
        if audio.ncols() != self.audio_dim {
            return Err(SpeechError::DimensionMismatch {
                what: "audio feature dimension",
                expected: self.audio_dim,
                got: audio.ncols(),
            });
        }
        let audio_log = DMatrix::from_columns(
            &self
                .audio
                .iter()
                .map(|(lw, g)| {
                    let mut l = g.log_density_rows(audio);
                    l.add_scalar_mut(*lw);
                    l
                })
                .collect::<Vec<_>>(),
        );
        let m = self.hmm.n_mixtures();
        let mut gamma =
            forward_backward(&self.hmm.initial, &self.hmm.transitions, &audio_log, m)?.components;
        // Φ^va_jk o_at for every component and frame: the only audio-dependent part.
        let cross: Vec<DMatrix> = self.phi_va.iter().map(|p| audio * p.transpose()).collect();
        let mut visual = self.blend(&gamma, &cross)?;
        for _ in 0..opts.iterations {
            let mut joint = DMatrix::zeros(audio.nrows(), self.hmm.dim());
            joint.columns_mut(0, self.audio_dim).copy_from(audio);
            joint.columns_mut(self.audio_dim, visual.ncols()).copy_from(&visual);
            let comp_log = self.hmm.component_log_densities(&joint)?;
            gamma = forward_backward(&self.hmm.initial, &self.hmm.transitions, &comp_log, m)?
                .components;
            let next = self.blend(&gamma, &cross)?;
            let moved = (&next - &visual).abs().max();
            visual = next;
            if moved < opts.tolerance {
                break;
            }
        }
        Ok(visual)
    }

    /// One application of eq. 3 with posteriors `gamma` (T × N·M).
    fn blend(&self, gamma: &DMatrix, cross: &[DMatrix]) -> Result<DMatrix, SpeechError> {
        let dv = self.hmm.dim() - self.audio_dim;
        let mut out = DMatrix::zeros(gamma.nrows(), dv);
        for t in 0..gamma.nrows() {
            let mut lhs = DMatrix::zeros(dv, dv);
            let mut rhs = DVector::zeros(dv);
            for c in 0..gamma.ncols() {
                let g = gamma[(t, c)];
                // Components with negligible posterior change nothing at double precision.
                if g < 1e-12 {
                    continue;
                }
                lhs += &self.phi_v[c] * g;
                rhs += (&self.offset[c] - cross[c].row(t).transpose()) * g;
            }
            let x = lhs
                .cholesky()
                .ok_or_else(|| SpeechError::Degenerate(format!("visual precision at frame {t}")))?
                .solve(&rhs);
            out.set_row(t, &x.transpose());
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::speech::hmm::Component;

    fn one_gaussian_model() -> Hmm {
        // 2 audio + 1 visual dimensions, correlated.
        let cov = DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.8, 0.3, 1.0, -0.4, 0.8, -0.4, 1.5]);
        let g = Gaussian::new(DVector::from_vec(vec![1.0, -2.0, 0.5]), cov).unwrap();
        Hmm {
            initial: vec![1.0],
            transitions: DMatrix::identity(1, 1),
            states: vec![vec![Component { weight: 1.0, gaussian: g }]],
        }
    }

    #[test]
    fn with_one_gaussian_it_is_the_conditional_mean() {
        let hmm = one_gaussian_model();
        let g = &hmm.states[0][0].gaussian;
        let audio = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 2.5, -1.0, -1.0, 3.0]);
        let inv = Inverter::new(&hmm, 2).unwrap();
        let est = inv.invert(&audio, &InversionOptions::default()).unwrap();
        let s_aa = g.cov.view((0, 0), (2, 2)).into_owned();
        let s_va = g.cov.view((2, 0), (1, 2)).into_owned();
        let gain = s_va * s_aa.try_inverse().unwrap();
        for t in 0..3 {
            let d = audio.row(t).transpose() - g.mean.rows(0, 2);
            let want = g.mean[2] + (&gain * d)[0];
            assert!((est[(t, 0)] - want).abs() < 1e-10, "frame {t}: {} vs {want}", est[(t, 0)]);
        }
    }

    #[test]
    fn recovers_which_regime_a_two_state_signal_is_in() {
        // State 0: visual ≈ +3, audio around 0; state 1: visual ≈ −3, audio around 5.
        let mk = |m: [f64; 2]| {
            Gaussian::new(
                DVector::from_vec(m.to_vec()),
                DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.1]),
            )
            .unwrap()
        };
        let hmm = Hmm {
            initial: vec![0.5, 0.5],
            transitions: DMatrix::from_row_slice(2, 2, &[0.9, 0.1, 0.1, 0.9]),
            states: vec![
                vec![Component { weight: 1.0, gaussian: mk([0.0, 3.0]) }],
                vec![Component { weight: 1.0, gaussian: mk([5.0, -3.0]) }],
            ],
        };
        let audio = DMatrix::from_row_slice(6, 1, &[0.1, -0.2, 0.3, 5.1, 4.8, 5.2]);
        let est =
            Inverter::new(&hmm, 1).unwrap().invert(&audio, &InversionOptions::default()).unwrap();
        assert!(est.rows(0, 3).iter().all(|v| (v - 3.0).abs() < 0.05), "{est}");
        assert!(est.rows(3, 3).iter().all(|v| (v + 3.0).abs() < 0.05), "{est}");
    }

    #[test]
    fn wrong_widths_are_refused() {
        let hmm = one_gaussian_model();
        assert!(Inverter::new(&hmm, 3).is_err());
        let inv = Inverter::new(&hmm, 2).unwrap();
        assert!(inv.invert(&DMatrix::zeros(4, 3), &InversionOptions::default()).is_err());
    }
}
