//! The head screen's state: how the head is turned and framed (`HeadView`, `HeadFraming`),
//! what of the mesh may be labelled and drawn, and the heads the session's motion was
//! transferred onto (`TransferredHeads`), one of which the screen may show in place of the
//! model, moving with the current frame.
//!
//! A transferred head is set up once, on a job (`PreparedHead`); each frame's shape is
//! computed on a job too and kept here for drawing.

use crate::math::{Matrix3, Point3};
use crate::model::face_locate::{FaceLocation, locate_face};
use crate::model::map_check::face_axes;
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Everything the head screen keeps. The mesh itself is the session's (`App::mesh`); what is
/// derived from it for this screen is here.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadScreen {
    pub view: HeadView,
    /// What the head is framed on; recomputed with `App::frame_head` when mesh, model or map
    /// change.
    pub framing: HeadFraming,
    /// Unique mesh edges for the wireframe, computed once when the mesh is set.
    pub edges: Arc<Vec<[u32; 2]>>,
    /// Vertices landmarks may be labelled on (`None`: all): not a figure's helper or joint
    /// geometry (see `io::obj::labelable_vertices`).
    pub label_candidates: Option<Arc<Vec<bool>>>,
    /// Vertices whose triangles hide what is behind them from suggestions (`None`: all): the
    /// skin, eyeballs and teeth, not see-through shells (see `io::obj::occluding_vertices`).
    pub occluders: Option<Arc<Vec<bool>>>,
    /// The triangles the mesh is drawn and picked with: those of the `occluders` (the skin
    /// with the eyes, teeth and tongue as surfaces, not holes onto the socket behind them).
    pub triangles: Arc<Vec<[u32; 3]>>,
    /// The face found on the mesh's geometry ([`locate_face`]), once per mesh: what the view
    /// is framed on before five landmarks are labelled.
    pub face: Option<FaceLocation>,
    /// The session's transferred heads the screen can show.
    pub heads: TransferredHeads,
    /// Whose map the screen labels: the model's (what `fit` uses) or the head's own (what
    /// transfer and indices use, when the head is another mesh).
    pub label_role: crate::session::MapRole,
    /// The file name of the mesh being labelled, shown with the role.
    pub label_mesh_name: String,
    /// The session's head is another mesh than the model, so there are two maps.
    pub head_has_own_map: bool,
    /// The file name of the other mesh with a map (empty when there is one map): what
    /// `SwitchLabelledMesh` labels instead.
    pub other_mesh_name: String,
}

/// Head view state: rotation in degrees, zoom, the 2D cursor (view units, −1..1 across the
/// smaller side) and the landmark being labelled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadView {
    pub yaw: f64,
    pub pitch: f64,
    pub zoom: f64,
    pub cursor: (f64, f64),
    pub label: usize,
    /// (landmark, vertex) the cursor was put on by a suggestion; Enter assigns the vertex
    /// even when it is hidden from this angle. Moving the cursor or the label drops it.
    pub suggested: Option<(usize, usize)>,
    /// Draw the mesh as a braille wireframe instead of shaded.
    pub wireframe: bool,
}

impl Default for HeadView {
    fn default() -> Self {
        Self {
            yaw: 0.0,
            pitch: 0.0,
            zoom: 1.0,
            cursor: (0.0, 0.0),
            label: 48,
            suggested: None,
            wireframe: false,
        }
    }
}

/// What the head views frame (model units): a sphere around the face, not the whole body of
/// a full-figure mesh, and the turn that shows the face upright from the front, so
/// labelling starts where the landmarks are on a head standing any way up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadFraming {
    pub centre: Point3,
    pub radius: f64,
    /// Model → view (x to the viewer's right, y up, z towards the viewer) before the user's
    /// own turn.
    pub rotation: Matrix3,
}

impl Default for HeadFraming {
    fn default() -> Self {
        Self { centre: Point3::origin(), radius: 1.0, rotation: Matrix3::identity() }
    }
}

/// Mapped landmarks that frame the view on their own (fewer frame it on the geometry).
pub const FRAMING_LABELS: usize = 5;

impl HeadFraming {
    /// The bounding box's centre and half diagonal of `points`, unturned; `None` when empty.
    pub fn around<'a>(points: impl IntoIterator<Item = &'a Point3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?.coords;
        let (lo, hi) =
            it.fold((first, first), |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)));
        Some(Self {
            centre: Point3::from((lo + hi) / 2.0),
            radius: ((hi - lo).norm() / 2.0).max(1e-12),
            rotation: Matrix3::identity(),
        })
    }

    /// The face of `mesh`: once [`FRAMING_LABELS`] landmarks are mapped, their box enlarged
    /// by half, turned as the geometry's face (else by the axes the labels give); else the
    /// face found on the geometry (`face`, see [`locate_face`]); else the vertices the
    /// model's expressions move, when they are a part of the mesh (the head of a full
    /// figure with facial blendshapes); else the whole mesh.
    pub fn of_face(
        mesh: &Mesh,
        model: Option<&MorphableModel>,
        map: Option<&LandmarkMap>,
        face: Option<&FaceLocation>,
    ) -> Self {
        let n = mesh.vertices.len();
        let pick =
            |idx: &[usize]| HeadFraming::around(idx.iter().filter_map(|&v| mesh.vertices.get(v)));
        let geometric =
            face.map(|f| Self { centre: f.centre(), radius: f.radius(), rotation: f.axes });
        let whole = HeadFraming::around(&mesh.vertices).unwrap_or_default();
        let labelled: std::collections::BTreeMap<usize, Point3> = map
            .map(|m| m.pairs().filter_map(|(l, v)| Some((l, *mesh.vertices.get(v)?))).collect())
            .unwrap_or_default();
        let mapped: Vec<usize> =
            map.map(|m| m.to_vertex.values().copied().collect()).unwrap_or_default();
        if labelled.len() >= FRAMING_LABELS
            && let Some(f) = pick(&mapped)
        {
            // The geometry's turn when it found the face: the axes of a few labels lean
            // with whichever side was labelled first (one eye corner and both mouth
            // corners tilt "up" towards that eye).
            let rotation = geometric
                .map(|g| g.rotation)
                .or_else(|| face_axes(&labelled))
                .unwrap_or_else(Matrix3::identity);
            return Self { radius: (f.radius * 1.5).min(whole.radius), rotation, ..f };
        }
        if let Some(g) = geometric {
            return g;
        }
        let moved: Vec<usize> = model
            .and_then(|m| m.expressions.as_ref().filter(|_| m.num_vertices() == n))
            .map(|e| {
                (0..n).filter(|&v| e.deltas.rows(3 * v, 3).iter().any(|d| d.abs() > 1e-9)).collect()
            })
            .unwrap_or_default();
        match pick(&moved) {
            Some(f) if moved.len() * 5 < n * 4 => Self { radius: f.radius * 1.15, ..f },
            _ => whole,
        }
    }
}

/// The face on `mesh` from its geometry, its `eligible` vertices only (`None`: all): see
/// [`locate_face`].
pub fn face_of_mesh(mesh: &Mesh, eligible: Option<&[bool]>) -> Option<FaceLocation> {
    locate_face(&mesh.vertices, &mesh.triangles(), eligible)
}

/// The unique edges of `mesh`'s faces for a wireframe, leaving out the vertices `keep`
/// excludes (a figure's helper and joint geometry, which would hide the face's own edges).
pub fn wire_edges(mesh: &Mesh, keep: Option<&[bool]>) -> Vec<[u32; 2]> {
    let kept = |v: u32| keep.is_none_or(|k| k.get(v as usize) == Some(&true));
    let mut edges = BTreeSet::new();
    for f in &mesh.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            if kept(a) && kept(b) {
                edges.insert(if a < b { [a, b] } else { [b, a] });
            }
        }
    }
    edges.into_iter().collect()
}

/// A transferred head set up for the view: the transfer (computed once, on a job), the
/// head's mesh at rest (skin faces only), its wireframe edges and the framing of its face.
#[derive(Debug)]
pub struct PreparedHead {
    pub name: String,
    /// `biharmonic` or `barycentric`.
    pub mode: String,
    pub transfer: crate::transfer::Transfer,
    pub mesh: Arc<Mesh>,
    pub edges: Arc<Vec<[u32; 2]>>,
    pub framing: HeadFraming,
}

/// A set-up is equal only to itself: comparing two transfers' factorisations would say
/// nothing more and cost a great deal.
impl PartialEq for PreparedHead {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl PreparedHead {
    /// The view's set-up of a transfer onto `mesh`, whose landmarks `map` names; `skin`
    /// (empty: all) marks the vertices that are not helper or joint geometry.
    pub fn new(
        name: String,
        mode: String,
        transfer: crate::transfer::Transfer,
        mesh: Mesh,
        skin: &[bool],
        map: &LandmarkMap,
    ) -> Self {
        let keep = (!skin.is_empty()).then_some(skin);
        let mut mesh = mesh;
        // Helper and joint geometry is neither drawn nor lets its faces hide the skin (a
        // figure's proxy shells wrap the head and would hide it from the side).
        if let Some(k) = keep {
            mesh.faces.retain(|f| f.iter().all(|&v| k.get(v as usize) == Some(&true)));
        }
        let edges = Arc::new(wire_edges(&mesh, keep));
        let framing = HeadFraming::of_face(&mesh, None, Some(map), None);
        Self { name, mode, transfer, mesh: Arc::new(mesh), edges, framing }
    }
}

/// Where one transferred head's set-up stands.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum HeadSetup {
    #[default]
    NotStarted,
    Preparing,
    Ready(Arc<PreparedHead>),
    Failed(String),
}

/// The transferred head's shape at one frame, as its job computed it.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadFrame {
    pub head: usize,
    pub frame: usize,
    pub shape: Result<Arc<Mesh>, String>,
}

/// The session's transferred heads (by name, in the session's order), their set-ups, which
/// one the head view shows (`None`: the model, for labelling) and the shown head's shape at
/// the last frame computed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransferredHeads {
    pub names: Vec<String>,
    pub setups: Vec<HeadSetup>,
    pub shown: Option<usize>,
    pub current: Option<HeadFrame>,
}

impl TransferredHeads {
    /// Heads named `names`, none set up yet, the model shown.
    pub fn named(names: Vec<String>) -> Self {
        let setups = vec![HeadSetup::NotStarted; names.len()];
        Self { names, setups, shown: None, current: None }
    }

    /// The shown head's set-up, when it is ready.
    pub fn shown_ready(&self) -> Option<(usize, &Arc<PreparedHead>)> {
        let h = self.shown?;
        match self.setups.get(h)? {
            HeadSetup::Ready(p) => Some((h, p)),
            _ => None,
        }
    }

    /// The next in the cycle model → each head → model.
    pub fn next_shown(&self) -> Option<usize> {
        match self.shown {
            None if !self.names.is_empty() => Some(0),
            Some(h) if h + 1 < self.names.len() => Some(h + 1),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{DMatrix, DVector, Point3};
    use crate::model::{Expressions, PcaModel};

    /// A tall "body" of 100 vertices with a small "face" of 10 at the top, which only the
    /// expressions move.
    fn figure() -> (Mesh, MorphableModel) {
        let mut vertices: Vec<Point3> =
            (0..100).map(|i| Point3::new((i % 10) as f64, -(i as f64) * 2.0, 0.0)).collect();
        vertices.extend((0..10).map(|i| Point3::new(4.0 + 0.1 * i as f64, 10.0, 1.0)));
        let mesh = Mesh { vertices, faces: Vec::new() };
        let flat = DVector::from_iterator(330, mesh.vertices.iter().flat_map(|p| [p.x, p.y, p.z]));
        let mut deltas = DMatrix::zeros(330, 1);
        for v in 100..110 {
            deltas[(3 * v + 1, 0)] = 0.5;
        }
        let model = MorphableModel {
            shape: PcaModel::mean_only(flat),
            expressions: Some(Expressions { names: vec!["jawOpen".into()], deltas }),
            triangles: Vec::new(),
        };
        (mesh, model)
    }

    #[test]
    fn head_framing_prefers_labels_then_geometry_then_expressions() {
        let (mesh, model) = figure();
        // Only the expressions: the vertices they move.
        let face = HeadFraming::of_face(&mesh, Some(&model), None, None);
        assert!((face.centre.y - 10.0).abs() < 1e-9 && face.radius < 1.0, "{face:?}");
        // A face found on the geometry wins over the expressions, and turns the view.
        let turned =
            *nalgebra::Rotation3::from_axis_angle(&crate::math::Vector3::x_axis(), 1.0).matrix();
        let found = FaceLocation {
            axes: turned,
            nose_tip: Point3::new(4.5, 10.0, 1.0),
            scale: 0.01,
            residual_mm: 1.0,
        };
        let geometric = HeadFraming::of_face(&mesh, Some(&model), None, Some(&found));
        assert_eq!(geometric.rotation, turned);
        assert!((geometric.centre - found.centre()).norm() < 1e-12);
        // Five mapped vertices frame the view instead.
        let mut map = LandmarkMap::default();
        for (l, v) in [(0, 100), (8, 103), (16, 109), (30, 105), (48, 107)] {
            map.to_vertex.insert(l, v);
        }
        let mapped = HeadFraming::of_face(&mesh, None, Some(&map), Some(&found));
        assert!((mapped.centre.y - 10.0).abs() < 1e-9 && mapped.radius < 1.0, "{mapped:?}");
        // ... still turned as the face found on the geometry, not by a few labels' lean.
        assert_eq!(mapped.rotation, turned);
        // Without a face anywhere: the whole mesh.
        let whole = HeadFraming::of_face(&mesh, None, None, None);
        assert!(whole.radius > 50.0, "{whole:?}");
    }
}
