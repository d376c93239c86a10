//! W, H and P of a clip's fitted head, frame by frame, without keeping meshes.
//!
//! A mesh measure reads a few dozen vertices (the mapped landmarks, the upper lip), but a
//! fitted shape is the whole model (3448 vertices for the SFM model, ≈ 80 kB). Evaluating a
//! corpus by first building every frame's mesh held gigabytes and spent most of its time on
//! vertices nobody reads. Here the model is cut down once to the vertices the measure reads
//! ([`MeasuredVertices`]); each frame's shape is then evaluated on those rows only, into one
//! reused buffer, and measured. Each vertex is the same sum over the same coefficients as in
//! the full shape, so the measures are the same numbers.

use crate::fit::FrameFit;
use crate::math::{DVector, Point2};
use crate::measure::mesh::{landmark_points_3d, measure_shape};
use crate::measure::{
    MeshMeasureOptions, MouthMeasures, PoseComparison, Trajectory, UpperLip, measure_points,
};
use crate::model::{LandmarkMap, MorphableModel};

/// The rows of a model that a mesh measure reads, with the map and options renumbered to
/// them: measuring a shape of this small model is measuring the full shape.
#[derive(Clone, Debug)]
pub struct MeasuredVertices {
    /// Mean (3V), rescaled identity basis (3V×K) and expression deltas (3V×E) of the V kept
    /// vertices: the shape of a fit is `mean + basis·α + deltas·β` on these rows.
    mean: DVector,
    basis: crate::math::DMatrix,
    deltas: Option<crate::math::DMatrix>,
    map: LandmarkMap,
    options: MeshMeasureOptions,
}

impl MeasuredVertices {
    /// The vertices `map` names and `options` reads, cut out of `model`; `None` when the
    /// options leave the upper lip to be found on each shape ([`UpperLip::Region`]
    /// unresolved), which needs the whole mesh.
    pub fn new(
        model: &MorphableModel,
        map: &LandmarkMap,
        options: &MeshMeasureOptions,
    ) -> Option<Self> {
        let n = model.num_vertices();
        let mut keep: Vec<usize> = map.pairs().map(|(_, v)| v).collect();
        match &options.upper_lip {
            UpperLip::Region => return None,
            UpperLip::Vertices(vs) => keep.extend(vs),
            UpperLip::MappedLandmarks => {}
        }
        keep.sort_unstable();
        keep.dedup();
        // An out-of-range vertex must fail the measure as it would on the full shape.
        if keep.last().is_some_and(|&v| v >= n) {
            return None;
        }
        let new_index = |v: usize| keep.binary_search(&v).ok();
        let rows: Vec<usize> = keep.iter().flat_map(|&v| [3 * v, 3 * v + 1, 3 * v + 2]).collect();
        let mean = model.shape.mean.select_rows(&rows);
        let basis = model.shape.rescaled_basis().select_rows(&rows);
        let deltas = model.expressions.as_ref().map(|e| e.deltas.select_rows(&rows));
        let map = LandmarkMap {
            to_vertex: map.pairs().filter_map(|(l, v)| Some((l, new_index(v)?))).collect(),
        };
        let mut options = options.clone();
        if let UpperLip::Vertices(vs) = &mut options.upper_lip {
            *vs = vs.iter().filter_map(|&v| new_index(v)).collect();
        }
        Some(Self { mean, basis, deltas, map, options })
    }

    /// Writes the kept rows of `fit`'s shape into `out` (resized as needed).
    fn shape_into(&self, fit: &FrameFit, out: &mut DVector) {
        out.clone_from(&self.mean);
        let k = fit.identity.len().min(self.basis.ncols());
        if k > 0 {
            let alpha = DVector::from_column_slice(&fit.identity[..k]);
            out.gemv(1.0, &self.basis.columns(0, k), &alpha, 1.0);
        }
        if let Some(d) = &self.deltas {
            let e = fit.expression.len().min(d.ncols());
            if e > 0 {
                let beta = DVector::from_column_slice(&fit.expression[..e]);
                out.gemv(1.0, &d.columns(0, e), &beta, 1.0);
            }
        }
    }

    /// W, H, P of `fit`'s shape as `pose` compares it, using `buffer` for the shape.
    fn measure(
        &self,
        fit: &FrameFit,
        buffer: &mut DVector,
        pose: PoseComparison,
    ) -> Option<MouthMeasures> {
        self.shape_into(fit, buffer);
        measure_posed(buffer, &self.map, &self.options, fit, pose)
    }
}

/// W, H, P of a fitted shape: P always on the mesh (the side view is compared with the
/// head's own profile), W and H on the mesh or, for [`PoseComparison::ImagePlane`], on the
/// landmark vertices as the frame's fitted camera projects them. `shape` is in the fitted
/// model's space (a transferred head taken there: `Transfer::in_source_space`).
pub(super) fn measure_posed(
    shape: &DVector,
    map: &LandmarkMap,
    options: &MeshMeasureOptions,
    fit: &FrameFit,
    pose: PoseComparison,
) -> Option<MouthMeasures> {
    let mut m = measure_shape(shape, map, options).ok()?;
    if pose == PoseComparison::ImagePlane {
        let seen = measure_points(&image_plane_landmarks(shape, map, fit)).ok()?;
        (m.w, m.h) = (seen.w, seen.h);
    }
    Some(m)
}

/// The 68 landmark vertices of `shape` projected with `fit`'s camera (`None` where unmapped).
fn image_plane_landmarks(
    shape: &DVector,
    map: &LandmarkMap,
    fit: &FrameFit,
) -> Vec<Option<Point2>> {
    // W and H are ratios of distances, which the image height (it only flips y) leaves
    // unchanged: any height gives the same measures.
    landmark_points_3d(shape, map)
        .into_iter()
        .map(|p| p.map(|p| crate::fit::project(fit, p, 0.0)))
        .collect()
}

/// The fitted head's W/H/P trajectory of a clip, `n_frames` long (frame = index; failed or
/// missing fits and unmeasurable shapes are `None`), measured through `map` as given (the
/// caller completes its mouth corners), W and H as `pose` compares them (frames past a
/// frontal limit are the caller's to leave out). Keeps one shape buffer, never a mesh per
/// frame.
pub fn head_trajectory(
    model: &MorphableModel,
    map: &LandmarkMap,
    fits: &[FrameFit],
    n_frames: usize,
    options: &MeshMeasureOptions,
    pose: PoseComparison,
) -> Trajectory {
    let Some(cut) = MeasuredVertices::new(model, map, options) else {
        // The whole mesh is needed per frame: still one shape at a time.
        let mut by_frame: Vec<Option<&FrameFit>> = vec![None; n_frames];
        for f in fits.iter().filter(|f| f.is_usable_within(n_frames)) {
            by_frame[f.frame] = Some(f);
        }
        let frames: Vec<Option<MouthMeasures>> = by_frame
            .iter()
            .map(|f| {
                let fit = (*f)?;
                let shape = crate::fit::fitted_shape(model, fit);
                measure_posed(&shape, map, options, fit, pose)
            })
            .collect();
        return Trajectory::from_frames(&frames);
    };
    let mut frames: Vec<Option<MouthMeasures>> = vec![None; n_frames];
    let mut buffer = DVector::zeros(0);
    for f in fits.iter().filter(|f| f.is_usable_within(n_frames)) {
        frames[f.frame] = cut.measure(f, &mut buffer, pose);
    }
    Trajectory::from_frames(&frames)
}

/// The same trajectory from whole shapes, for tests comparing the two paths.
#[cfg(test)]
fn head_trajectory_from_shapes(
    model: &MorphableModel,
    map: &LandmarkMap,
    fits: &[FrameFit],
    n_frames: usize,
    options: &MeshMeasureOptions,
) -> Trajectory {
    let shapes = super::fit::shapes_by_frame(model, fits, n_frames);
    crate::measure::mesh::trajectory_from_shapes(shapes.iter().map(|s| s.as_ref()), map, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::DMatrix;
    use crate::model::{Expressions, PcaModel};
    use rand::{Rng, SeedableRng};

    #[test]
    fn measures_from_the_cut_model_equal_those_of_the_full_meshes() {
        let head = crate::demo::head::build_head();
        let n3 = 3 * head.mesh.num_vertices();
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut noise =
            |r: usize, c: usize| DMatrix::from_fn(r, c, |_, _| rng.random_range(-0.3..0.3));
        let model = MorphableModel {
            shape: PcaModel {
                mean: head.mesh.to_flat(),
                basis: noise(n3, 4),
                eigenvalues: DVector::from_element(4, 4.0),
            },
            expressions: Some(Expressions {
                names: vec!["a".into(), "b".into()],
                deltas: noise(n3, 2),
            }),
            triangles: Vec::new(),
        };
        let fits: Vec<FrameFit> = (0..6)
            .filter(|&f| f != 2)
            .map(|f| FrameFit {
                identity: vec![0.4 * f as f64 - 1.0, 0.3, -0.2, 0.1],
                expression: vec![0.1 * f as f64, -0.2],
                failed: (f == 4).then(|| "too few landmarks".to_string()),
                ..FrameFit::unposed(f)
            })
            .collect();
        let map = head.landmarks.with_commissures_completed();
        for options in [
            MeshMeasureOptions::default(),
            MeshMeasureOptions {
                upper_lip: UpperLip::Vertices(head.upper_lip.clone()),
                ..Default::default()
            },
        ] {
            let full = head_trajectory_from_shapes(&model, &map, &fits, 7, &options);
            let cut = head_trajectory(&model, &map, &fits, 7, &options, PoseComparison::frontal());
            assert_eq!(cut, full, "{options:?}");
            assert!(
                cut.w[0].is_some()
                    && cut.w[2].is_none()
                    && cut.w[4].is_none()
                    && cut.w[6].is_none()
            );
        }
        let region = MeshMeasureOptions { upper_lip: UpperLip::Region, ..Default::default() };
        assert!(MeasuredVertices::new(&model, &map, &region).is_none());
        assert_eq!(
            head_trajectory(&model, &map, &fits, 7, &region, PoseComparison::frontal()),
            head_trajectory_from_shapes(&model, &map, &fits, 7, &region)
        );
    }

    #[test]
    fn image_plane_w_is_foreshortened_by_a_turn_and_equals_the_frontal_w_head_on() {
        let head = crate::demo::head::build_head();
        let n3 = 3 * head.mesh.num_vertices();
        let model = MorphableModel {
            shape: PcaModel {
                mean: head.mesh.to_flat(),
                basis: DMatrix::zeros(n3, 0),
                eigenvalues: DVector::zeros(0),
            },
            expressions: None,
            triangles: Vec::new(),
        };
        let map = head.landmarks.with_commissures_completed();
        let opts = MeshMeasureOptions::default();
        let posed =
            |yaw: f64, roll: f64| FrameFit { yaw, roll, scale: 3.0, ..FrameFit::unposed(0) };
        let measure = |fit: FrameFit, pose| {
            let t = head_trajectory(&model, &map, &[fit], 1, &opts, pose);
            (t.w[0].unwrap(), t.h[0].unwrap())
        };
        let frontal = measure(posed(0.0, 0.0), PoseComparison::frontal());
        let head_on = measure(posed(0.0, 0.0), PoseComparison::ImagePlane);
        assert!((frontal.0 - head_on.0).abs() < 1e-9 && (frontal.1 - head_on.1).abs() < 1e-9);
        // A roll (in-plane) changes nothing; a 60° turn shows a narrower mouth in the image
        // while the mesh's frontal W stays.
        let rolled = measure(posed(0.0, 30.0), PoseComparison::ImagePlane);
        assert!((rolled.0 - frontal.0).abs() < 1e-9, "{rolled:?} vs {frontal:?}");
        let turned = measure(posed(60.0, 0.0), PoseComparison::ImagePlane);
        assert_eq!(measure(posed(60.0, 0.0), PoseComparison::frontal()), frontal);
        assert!(turned.0 < 0.8 * frontal.0, "{turned:?} vs {frontal:?}");
    }
}
