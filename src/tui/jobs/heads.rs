//! Transferred-head jobs: a head's set-up (once per head) and its shape at each fitted frame.

use crate::fit::FrameFit;
use crate::model::MorphableModel;
use crate::tui::app::App;
use crate::tui::screens::head::HeadSetup;
use crate::tui::screens::head::{HeadFrame, PreparedHead};
use std::sync::Arc;

/// Sets up the transfer onto a session's transferred head for the head view (the one call
/// into `workflow::transfer`, on a job: it takes a good part of a second).
///
/// # Errors
/// One line: the session's model or map, the head or its map cannot be read, or the
/// transfer cannot be set up.
pub fn prepare_head_for_tui(
    session: &crate::session::Session,
    entry: &crate::session::TransferredHead,
) -> Result<PreparedHead, String> {
    use crate::workflow::transfer::{load_target, parse_mode, set_up_for_head};
    let prepare = || -> crate::workflow::Result<PreparedHead> {
        let res = crate::workflow::Resources::load(session)?;
        let target = load_target(&entry.mesh, &entry.mapping)?;
        let transfer = set_up_for_head(&res, &target, parse_mode(&entry.mode)?, &entry.mesh)?;
        Ok(PreparedHead::new(
            entry.name.clone(),
            entry.mode.clone(),
            transfer,
            target.mesh,
            &target.skin,
            &target.map,
        ))
    };
    prepare().map_err(|e| crate::workflow::error_chain(&e))
}

/// One frame of a transferred head to compute: the set-up head and the frame's fit.
pub struct HeadFrameJob {
    pub head: usize,
    pub prepared: Arc<PreparedHead>,
    pub model: Arc<MorphableModel>,
    pub fit: FrameFit,
}

impl HeadFrameJob {
    /// Frame `frame` of transferred head `head`, when the head is set up and the frame has a
    /// usable fit.
    pub fn of(app: &App, head: usize, frame: usize) -> Option<Self> {
        let prepared = match app.head.heads.setups.get(head)? {
            HeadSetup::Ready(p) => p.clone(),
            _ => return None,
        };
        let fit = app.fits.by_frame.get(&frame).filter(|f| f.is_usable()).cloned()?;
        Some(Self { head, prepared, model: app.model.clone()?, fit })
    }
}

/// The transferred head's shape for the job's fit, as `workflow::transfer::transfer_fits`
/// computes it, with the head's faces (the view hides what they cover).
pub fn transfer_frame_for_tui(job: &HeadFrameJob) -> HeadFrame {
    let source = crate::fit::fitted_shape(&job.model, &job.fit);
    let shape = job
        .prepared
        .transfer
        .apply(&source)
        .map(|s| {
            Arc::new(crate::model::Mesh::from_flat(s.as_slice(), job.prepared.mesh.faces.clone()))
        })
        .map_err(|e| e.to_string());
    HeadFrame { head: job.head, frame: job.fit.frame, shape }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_transferred_head_follows_the_fitted_jaw() {
        use crate::tui::fixtures::{synthetic_model, synthetic_prepared_head, synthetic_track};
        let prepared = Arc::new(synthetic_prepared_head());
        let model = Arc::new(synthetic_model());
        let track = synthetic_track(1, 100, 100);
        let rest = prepared.mesh.vertices.clone();
        let shape_at = |jaw: f64| {
            let mut fit = crate::tui::fixtures::synthetic_fits(&track)[0].clone();
            fit.expression = vec![jaw];
            let job =
                HeadFrameJob { head: 0, prepared: prepared.clone(), model: model.clone(), fit };
            let f = transfer_frame_for_tui(&job);
            assert_eq!((f.head, f.frame), (0, 0));
            f.shape.unwrap()
        };
        // Closed: the head at rest (source and target are one mesh).
        let closed = shape_at(0.0);
        for (p, q) in closed.vertices.iter().zip(&rest) {
            assert!((p - q).norm() < 1e-6, "{p} vs {q}");
        }
        // Open: the lower front follows the 20-unit drop, the crown stays.
        let open = shape_at(1.0);
        let dy = |v: usize| open.vertices[v].y - rest[v].y;
        let chin = 1 + 7 * 16; // iBUG 8's vertex: ring 8, front meridian
        assert!((dy(chin) + 20.0).abs() < 2.0, "chin moved {}", dy(chin));
        assert!(dy(0).abs() < 2.0, "crown moved {}", dy(0));
        assert_eq!(open.faces, prepared.mesh.faces, "faces kept for hidden lines");
    }
}
