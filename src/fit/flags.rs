//! The fit's side of the per-frame failure flags: a [`FrameFit`] gives the residual flags
//! (`landmarks::flags::fit_flags`) its frame, reprojection RMS and failure.

use super::FrameFit;
use crate::landmarks::flags::FitResidual;

impl FitResidual for FrameFit {
    fn frame(&self) -> usize {
        self.frame
    }

    fn reproj_rms_px(&self) -> f64 {
        self.reproj_rms_px
    }

    fn failure(&self) -> Option<&str> {
        self.failed.as_deref()
    }
}

#[cfg(test)]
mod tests {
    use crate::fit::FrameFit;
    use crate::landmarks::flags::{FlagReason, FlagThresholds, fit_flags};

    #[test]
    fn frame_fits_flag_failures_and_high_residuals() {
        let fit = |frame, rms: f64, failed: Option<&str>| FrameFit {
            reproj_rms_px: rms,
            failed: failed.map(str::to_string),
            ..FrameFit::unposed(frame)
        };
        let fits: Vec<FrameFit> = (0..20)
            .map(|f| match f {
                7 => fit(f, 15.0, None),
                9 => fit(f, f64::NAN, Some("too few landmarks")),
                _ => fit(f, 2.0 + (f % 3) as f64 * 0.1, None),
            })
            .collect();
        let flags = fit_flags(&fits, &FlagThresholds::default());
        assert_eq!(flags.iter().map(|f| f.0).collect::<Vec<_>>(), vec![7, 9]);
        assert_eq!(flags[0].1, FlagReason::HighResidual { rms_px: 15.0 });
        assert_eq!(flags[1].1, FlagReason::FitFailed { reason: "too few landmarks".into() });
    }
}
