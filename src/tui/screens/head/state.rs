//! The head screen's state: how the head is turned and framed (`HeadView`, `HeadFraming`),
//! what of the mesh may be labelled and drawn, and the heads the session's motion was
//! transferred onto (`TransferredHeads`), one of which the screen may show in place of the
//! model, moving with the current frame.
//!
//! A transferred head is set up once, on a job (`PreparedHead`); each frame's shape is
//! computed on a job too and kept here for drawing.

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
    /// The session's transferred heads the screen can show.
    pub heads: TransferredHeads,
    /// Whose map the screen labels: the model's (what `fit` uses) or the head's own (what
    /// transfer and indices use, when the head is another mesh).
    pub label_role: crate::session::MapRole,
    /// The file name of the mesh being labelled, shown with the role.
    pub label_mesh_name: String,
    /// The session's head is another mesh than the model, so there are two maps.
    pub head_has_own_map: bool,
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

/// The sphere the head views frame (model units): the face, not the whole body of a
/// full-figure mesh, so labelling starts where the landmarks are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadFraming {
    pub centre: crate::math::Point3,
    pub radius: f64,
}

impl Default for HeadFraming {
    fn default() -> Self {
        Self { centre: crate::math::Point3::origin(), radius: 1.0 }
    }
}

impl HeadFraming {
    /// The bounding box's centre and half diagonal of `points`; `None` when empty.
    pub fn around<'a>(points: impl IntoIterator<Item = &'a crate::math::Point3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?.coords;
        let (lo, hi) =
            it.fold((first, first), |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)));
        Some(Self {
            centre: crate::math::Point3::from((lo + hi) / 2.0),
            radius: ((hi - lo).norm() / 2.0).max(1e-12),
        })
    }

    /// The face of `mesh`: the mapped landmarks' box enlarged by half, once five or more are
    /// mapped (the face itself); else the vertices the model's expressions move, when they
    /// are a part of the mesh (the head of a full figure with facial blendshapes); else the
    /// front of the head found from the geometry ([`face_region`], the vertices `eligible`
    /// excludes left out).
    pub fn of_face(
        mesh: &Mesh,
        model: Option<&MorphableModel>,
        map: Option<&LandmarkMap>,
        eligible: Option<&[bool]>,
    ) -> Self {
        let n = mesh.vertices.len();
        let pick =
            |idx: &[usize]| HeadFraming::around(idx.iter().filter_map(|&v| mesh.vertices.get(v)));
        let whole = pick(&face_region(&mesh.vertices, eligible))
            .or_else(|| HeadFraming::around(&mesh.vertices))
            .unwrap_or_default();
        let mapped: Vec<usize> =
            map.map(|m| m.to_vertex.values().copied().collect()).unwrap_or_default();
        if mapped.len() >= 5
            && let Some(f) = pick(&mapped)
        {
            return Self { radius: (f.radius * 1.5).min(whole.radius), ..f };
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

/// Figures are about this many heads tall (crown to soles).
const HEADS_PER_FIGURE: f64 = 7.5;

/// The front of the head of a mesh, as vertex indices (those `eligible` allows, all when
/// `None`): for a full figure (its longest side over 2.5 times the others), the top
/// 1/[`HEADS_PER_FIGURE`] along that side; then the front half of that along the shorter
/// remaining axis (a figure's depth, not its arm span), taking +axis as the front as
/// MakeHuman, eos and the demo head face. Empty when nothing is eligible.
pub fn face_region(vertices: &[crate::math::Point3], eligible: Option<&[bool]>) -> Vec<usize> {
    let ok = |v: usize| eligible.is_none_or(|e| e.get(v) == Some(&true));
    let idx: Vec<usize> = (0..vertices.len()).filter(|&v| ok(v)).collect();
    let Some(all) = HeadFraming::around(idx.iter().map(|&v| &vertices[v])) else {
        return idx;
    };
    let (lo, hi) = idx.iter().fold((all.centre.coords, all.centre.coords), |(lo, hi), &v| {
        (lo.inf(&vertices[v].coords), hi.sup(&vertices[v].coords))
    });
    let extent = hi - lo;
    let up = extent.imax();
    let others: Vec<usize> = (0..3).filter(|&a| a != up).collect();
    let (a, b) = (others[0], others[1]);
    if extent[up] < 2.5 * extent[a].max(extent[b]) {
        // A head or a bust: the whole of it is the head; its front is still the face.
        let depth = if extent[a] < extent[b] { a } else { b };
        return front_half(vertices, idx, depth);
    }
    let top = hi[up] - extent[up] / HEADS_PER_FIGURE;
    let head: Vec<usize> = idx.into_iter().filter(|&v| vertices[v][up] >= top).collect();
    let depth = if extent[a] < extent[b] { a } else { b };
    front_half(vertices, head, depth)
}

/// The vertices of `idx` in front of their middle along `axis`.
fn front_half(vertices: &[crate::math::Point3], idx: Vec<usize>, axis: usize) -> Vec<usize> {
    let (lo, hi) = idx
        .iter()
        .map(|&v| vertices[v][axis])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(x), h.max(x)));
    let mid = (lo + hi) / 2.0;
    let front: Vec<usize> = idx.iter().copied().filter(|&v| vertices[v][axis] >= mid).collect();
    if front.is_empty() { idx } else { front }
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
        let framing = HeadFraming::of_face(&mesh, None, Some(map), keep);
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
    fn head_framing_finds_the_face_of_a_full_figure() {
        let (mesh, model) = figure();
        // No model, no map: the front of the figure's top, from the geometry alone.
        let geometric = HeadFraming::of_face(&mesh, None, None, None);
        assert!((geometric.centre.y - 10.0).abs() < 1e-9, "{geometric:?}");
        assert!(geometric.radius < 1.0, "{geometric:?}");
        // Helper geometry is never framed: without the face vertices, the top of the column.
        let mut eligible = vec![true; 110];
        eligible[100..].iter_mut().for_each(|e| *e = false);
        let helper_free = HeadFraming::of_face(&mesh, None, None, Some(&eligible));
        assert!(helper_free.centre.y < 0.0 && helper_free.centre.y > -18.0, "{helper_free:?}");
        assert!(helper_free.radius < 15.0, "{helper_free:?}");
        let face = HeadFraming::of_face(&mesh, Some(&model), None, None);
        assert!((face.centre.y - 10.0).abs() < 1e-9 && face.radius < 1.0, "{face:?}");
        // Without expressions, five mapped vertices frame the view instead.
        let mut map = LandmarkMap::default();
        for (l, v) in [(0, 100), (8, 103), (16, 109), (30, 105), (48, 107)] {
            map.to_vertex.insert(l, v);
        }
        let mapped = HeadFraming::of_face(&mesh, None, Some(&map), None);
        assert!((mapped.centre.y - 10.0).abs() < 1e-9 && mapped.radius < 1.0, "{mapped:?}");
    }
}
