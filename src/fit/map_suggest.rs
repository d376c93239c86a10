//! A whole landmark map suggested from a few hand labels: every unlabelled landmark gets its
//! own vertex (a minimum-cost unique assignment, not each landmark's nearest vertex), a
//! confidence from how far the vertex's projection lands from the tracked point, and is kept
//! only when the map it makes passes the anatomy checks of [`crate::model::map_check`].
//!
//! Start with [`suggest_map`]. With the pose estimated from the labels, the accepted
//! suggestions re-estimate it and the assignment is made again ([`ROUNDS`] times): a pose
//! from four labels is rough, one from forty is not.
//!
//! The speaker in the frame is not the head: a pose alone leaves every landmark off by the
//! two faces' difference in proportion (a wider mouth, closer-set eyes), often more than the
//! spacing of the vertices there. So the tracked points are first carried onto the head's
//! proportions by a thin-plate spline ([`super::thin_plate`]) through the hand labels (each
//! labelled landmark's tracked point to its vertex's projection), and matched after that.
//!
//! The jaw (iBUG 1–17) is placed differently ([`super::jaw_contour`]): on the head's frontal
//! jaw silhouette, symmetric, the tracked points giving only where along the jaw each lies.
//! A suggestion far in 3D from its neighbours along its feature (the jaw, a brow, an eye, a
//! lip) is left out: it has landed on another part of the head.

use super::assignment::assign_min_cost;
use super::camera::OrthoPose;
use super::jaw_contour::place_jaw;
use super::own_face::own_face_landmarks;
use super::suggest::{
    SeenHead, SuggestError, SuggestHead, face_size_px, pose_from_labels, see_head,
};
use super::thin_plate::ThinPlate;
use crate::landmarks::ibug::{
    INNER_LIP, JAW, LEFT_BROW, LEFT_EYE, LOWER_NOSE, NOSE_BRIDGE, OUTER_LIP, RIGHT_BROW, RIGHT_EYE,
};
use crate::landmarks::{FrameLandmarks, N_LANDMARKS};
use crate::math::{Point2, Point3, Real};
use crate::model::LandmarkMap;
use crate::model::map_check::{MapProblem, check_layout, face_axes};
use crate::track::ShapePredictor;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::ops::Range;

/// Suggestions below this confidence are left for the user.
pub const MIN_CONFIDENCE: Real = 0.3;
/// Assignment rounds when the pose comes from the labels.
pub const ROUNDS: usize = 3;
/// Candidate vertices per landmark (the nearest ones within reach).
const CANDIDATES: usize = 24;
/// A suggestion farther than this many of its feature's median spacings from both its
/// neighbours along the feature is implausible (the spacing of iBUG's points along a feature
/// varies by about 2×).
const NEIGHBOUR_FACTOR: Real = 2.5;

/// The iBUG features as chains of neighbouring points; a closed one's last point neighbours
/// its first.
const FEATURE_CHAINS: [(Range<usize>, bool); 9] = [
    (JAW, false),
    (RIGHT_BROW, false),
    (LEFT_BROW, false),
    (NOSE_BRIDGE, false),
    (LOWER_NOSE, false),
    (RIGHT_EYE, true),
    (LEFT_EYE, true),
    (OUTER_LIP, true),
    (INNER_LIP, true),
];

/// One landmark's suggested vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapSuggestion {
    pub landmark: usize,
    pub vertex: usize,
    /// Pixels between the vertex's projection and the tracked point (carried onto the head's
    /// proportions by the hand labels' warp when there are at least three).
    pub distance_px: Real,
    /// In (0, 1]: `exp(-d²/2σ²)` with σ a fixed fraction of the face's size in the image.
    pub confidence: Real,
}

/// Why a landmark was left unlabelled.
#[derive(Clone, Debug, PartialEq)]
pub enum LeftOut {
    NotVisible,
    /// No visible vertex within reach, or all of them taken by other landmarks.
    NoVertex,
    LowConfidence(MapSuggestion),
    /// The suggestion would make the map break this rule.
    Anatomy(MapSuggestion, MapProblem),
    /// A suggestion this far (head units) from its nearest neighbour along its feature,
    /// against the feature's median spacing.
    FarFromNeighbours(MapSuggestion, Real, Real),
}

impl fmt::Display for LeftOut {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotVisible => write!(f, "not tracked as visible in this frame"),
            Self::NoVertex => write!(f, "no free visible vertex near the tracked point"),
            Self::LowConfidence(s) => write!(
                f,
                "vertex {} is {:.1} px off (confidence {:.2})",
                s.vertex, s.distance_px, s.confidence
            ),
            Self::Anatomy(s, p) => write!(f, "vertex {} would break anatomy: {p}", s.vertex),
            Self::FarFromNeighbours(s, d, median) => write!(
                f,
                "vertex {} is {d:.3} from its nearest neighbour along its feature (spacing {median:.3})",
                s.vertex
            ),
        }
    }
}

/// What [`suggest_map`] proposes: the suggestions that pass, and what it left and why.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapProposal {
    pub accepted: Vec<MapSuggestion>,
    pub left: Vec<(usize, LeftOut)>,
}

impl MapProposal {
    /// `map` with the accepted suggestions added.
    pub fn applied_to(&self, map: &LandmarkMap) -> LandmarkMap {
        let mut out = map.clone();
        out.to_vertex.extend(self.accepted.iter().map(|s| (s.landmark, s.vertex)));
        out
    }

    /// Lowest confidence among the accepted suggestions.
    pub fn lowest_confidence(&self) -> Option<Real> {
        self.accepted.iter().map(|s| s.confidence).reduce(Real::min)
    }

    /// One line: how many were labelled and how many left, with the commonest reason.
    pub fn summary(&self) -> String {
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for (_, why) in &self.left {
            *counts
                .entry(match why {
                    LeftOut::NotVisible => "not visible",
                    LeftOut::NoVertex => "no free vertex",
                    LeftOut::LowConfidence(_) => "too far off",
                    LeftOut::Anatomy(..) => "anatomy",
                    LeftOut::FarFromNeighbours(..) => "far from their neighbours",
                })
                .or_default() += 1;
        }
        let reasons: Vec<String> = counts.iter().map(|(k, n)| format!("{n} {k}")).collect();
        let lowest = self
            .lowest_confidence()
            .map_or(String::new(), |c| format!(" (lowest confidence {c:.2})"));
        if self.left.is_empty() {
            format!("suggested {} landmarks{lowest}", self.accepted.len())
        } else {
            format!(
                "suggested {} landmarks{lowest}, left {}: {}",
                self.accepted.len(),
                self.left.len(),
                reasons.join(", ")
            )
        }
    }
}

/// Suggests a vertex for every landmark `map` leaves unmapped, seeing `head` through `pose`
/// (a fitted frame's) or, when `None`, a pose estimated from the mapped landmarks and then
/// re-estimated from the accepted suggestions. Hand labels are never changed, and their
/// vertices are not given to another landmark.
///
/// # Errors
/// As [`pose_from_labels`] when no pose is given; `NoVertices`.
pub fn suggest_map(
    head: &SuggestHead,
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
    pose: Option<OrthoPose>,
) -> Result<MapProposal, SuggestError> {
    if head.vertices.is_empty() {
        return Err(SuggestError::NoVertices);
    }
    let rounds = if pose.is_some() { 1 } else { ROUNDS };
    let mut pose = match pose {
        Some(p) => p,
        None => pose_from_labels(head.vertices, map, frame, image_height)?,
    };
    let mut proposal = MapProposal::default();
    for round in 0..rounds {
        proposal = propose_once(head, map, frame, image_height, &pose);
        if round + 1 < rounds {
            // A pose that fails on the larger set keeps the last one.
            match pose_from_labels(head.vertices, &proposal.applied_to(map), frame, image_height) {
                Ok(p) => pose = p,
                Err(_) => break,
            }
        }
    }
    Ok(proposal)
}

/// Suggests the rest of `map` on the head's own face ([`own_face_landmarks`]: the head
/// drawn from the front, `predictor` run on the drawing with the labels held) instead of a
/// video frame: every landmark where this head has it, not where the speaker has it.
///
/// # Errors
/// As [`own_face_landmarks`].
pub fn suggest_map_on_own_face(
    head: &SuggestHead,
    map: &LandmarkMap,
    predictor: &ShapePredictor,
) -> Result<MapProposal, SuggestError> {
    let own = own_face_landmarks(head, map, predictor)?;
    suggest_map(head, map, &own.landmarks, own.image_height, Some(own.pose))
}

fn propose_once(
    head: &SuggestHead,
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
    pose: &OrthoPose,
) -> MapProposal {
    let seen = see_head(head, frame, pose, image_height);
    // σ: 3 % of the face, about the spread of a landmark between two people's faces once
    // the pose is right; the reach (4σ) leaves what is certainly another feature out.
    let face = face_size_px(frame).max(20.0);
    let sigma = 0.03 * face;
    let taken: BTreeSet<usize> = map.to_vertex.values().copied().collect();
    let warp = labels_warp(map, frame, &seen);
    let mut left = Vec::new();
    let mut wanted = Vec::new();
    for l in (0..N_LANDMARKS).filter(|l| map.vertex(*l).is_none()) {
        match frame.points.get(l).filter(|p| p.visible) {
            Some(p) => {
                let tracked = Point2::new(p.x, p.y);
                wanted.push((l, warp.as_ref().map_or(tracked, |w| w.apply(&tracked))));
            }
            None => left.push((l, LeftOut::NotVisible)),
        }
    }
    // The jaw is placed on the head's silhouette once the rest is known (its axes, nose
    // tip, eye corners); until then it takes no vertex from the others.
    let (jaw_wanted, wanted): (Vec<_>, Vec<_>) = wanted.into_iter().partition(|(l, _)| *l < 17);
    let nearest = |l: usize, target: Point2, vertex: usize| {
        let d = (seen.projected[vertex].0 - target).norm();
        MapSuggestion {
            landmark: l,
            vertex,
            distance_px: d,
            confidence: (-0.5 * (d / sigma).powi(2)).exp(),
        }
    };
    let assigned = assign_unique(&seen, &taken, &wanted, 4.0 * sigma);
    let mut suggestions = Vec::new();
    for ((l, target), vertex) in wanted.iter().zip(assigned) {
        let Some(vertex) = vertex else {
            left.push((*l, LeftOut::NoVertex));
            continue;
        };
        let s = nearest(*l, *target, vertex);
        if s.confidence >= MIN_CONFIDENCE {
            suggestions.push(s);
        } else {
            left.push((*l, LeftOut::LowConfidence(s)));
        }
    }
    let known = MapProposal { accepted: suggestions.clone(), left: Vec::new() }.applied_to(map);
    let mut used: BTreeSet<usize> = known.to_vertex.values().copied().collect();
    let placed = place_jaw(head, &known, pose, image_height, &jaw_wanted, &used);
    used.extend(placed.iter().map(|p| p.vertex));
    // A head with no surface to find a silhouette on (a bare point set), or labels that do
    // not yet give the face's axes: those jaw points are matched like every other landmark.
    let unplaced: Vec<(usize, Point2)> = jaw_wanted
        .iter()
        .filter(|(l, _)| !placed.iter().any(|p| p.landmark == *l))
        .copied()
        .collect();
    let fallback = assign_unique(&seen, &used, &unplaced, 4.0 * sigma);
    let mut jaw = Vec::new();
    for (l, _) in &jaw_wanted {
        if let Some(p) = placed.iter().find(|p| p.landmark == *l) {
            // The two sides of a turned head disagree by a few σ by nature (the far side's
            // tracked points lie on the cheek): three times the reach of the other landmarks.
            let d = p.asymmetry_px;
            jaw.push(MapSuggestion {
                landmark: *l,
                vertex: p.vertex,
                distance_px: d,
                confidence: (-0.5 * (d / (3.0 * sigma)).powi(2)).exp(),
            });
            continue;
        }
        let i =
            unplaced.iter().position(|(k, _)| k == l).expect("every unplaced jaw point is listed");
        match fallback[i] {
            Some(vertex) => jaw.push(nearest(*l, unplaced[i].1, vertex)),
            None => left.push((*l, LeftOut::NoVertex)),
        }
    }
    for s in jaw {
        if s.confidence >= MIN_CONFIDENCE {
            suggestions.push(s);
        } else {
            left.push((s.landmark, LeftOut::LowConfidence(s)));
        }
    }
    let (suggestions, far) = leave_out_far_from_neighbours(head.vertices, map, suggestions);
    left.extend(far);
    let (accepted, rejected) = screen_by_anatomy(head.vertices, map, pose, suggestions);
    left.extend(rejected);
    left.sort_by_key(|(l, _)| *l);
    MapProposal { accepted, left }
}

/// `suggestions` without those far from their neighbours along their feature (hand labels
/// and the other suggestions): a vertex seen through a hole in the surface, or a jaw point
/// on the cheek, lies several of the feature's spacings from both neighbours, where a
/// misplaced but plausible one does not. The others are returned left out, with why.
fn leave_out_far_from_neighbours(
    vertices: &[Point3],
    map: &LandmarkMap,
    suggestions: Vec<MapSuggestion>,
) -> (Vec<MapSuggestion>, Vec<(usize, LeftOut)>) {
    let known: BTreeMap<usize, Point3> = map
        .pairs()
        .chain(suggestions.iter().map(|s| (s.landmark, s.vertex)))
        .filter_map(|(l, v)| Some((l, *vertices.get(v)?)))
        .collect();
    let suggested: BTreeSet<usize> = suggestions.iter().map(|s| s.landmark).collect();
    let far: Vec<(usize, Real, Real)> = FEATURE_CHAINS
        .iter()
        .flat_map(|(chain, closed)| {
            let points: Vec<(usize, Point3)> =
                known.range(chain.clone()).map(|(l, p)| (*l, *p)).collect();
            far_from_neighbours(&points, *closed, &suggested, NEIGHBOUR_FACTOR)
        })
        .collect();
    let mut left = Vec::new();
    let mut kept = Vec::new();
    for s in suggestions {
        match far.iter().find(|f| f.0 == s.landmark) {
            Some(&(_, d, median)) => {
                left.push((s.landmark, LeftOut::FarFromNeighbours(s, d, median)))
            }
            None => kept.push(s),
        }
    }
    (kept, left)
}

/// The points of one feature (`points`, in landmark order, those known) farther from their
/// neighbours along it than `factor` times its median spacing, among `suggested`: each is
/// (landmark, distance to its nearest neighbour, the median spacing). Fewer than three
/// spacings give no median to judge by.
fn far_from_neighbours(
    points: &[(usize, Point3)],
    closed: bool,
    suggested: &BTreeSet<usize>,
    factor: Real,
) -> Vec<(usize, Real, Real)> {
    let n = points.len();
    let wraps = closed && n >= 3;
    let gap = |i: usize, j: usize| (points[j].1 - points[i].1).norm();
    let mut gaps: Vec<Real> = (1..n).map(|i| gap(i - 1, i)).collect();
    if wraps {
        gaps.push(gap(n - 1, 0));
    }
    if gaps.len() < 3 {
        return Vec::new();
    }
    gaps.sort_by(Real::total_cmp);
    let median = gaps[gaps.len() / 2];
    let neighbours = |i: usize| -> [Option<usize>; 2] {
        if wraps {
            [Some((i + n - 1) % n), Some((i + 1) % n)]
        } else {
            [i.checked_sub(1), (i + 1 < n).then_some(i + 1)]
        }
    };
    (0..n)
        .filter(|&i| suggested.contains(&points[i].0))
        .filter_map(|i| {
            let near = neighbours(i)
                .into_iter()
                .flatten()
                .map(|j| gap(i, j))
                .fold(Real::INFINITY, Real::min);
            (near > factor * median).then_some((points[i].0, near, median))
        })
        .collect()
}

/// The thin-plate spline taking the labelled landmarks' tracked points (visible ones) to
/// their vertices' projections; `None` (match the tracked points as they are) with fewer
/// than three or a degenerate set.
fn labels_warp(map: &LandmarkMap, frame: &FrameLandmarks, seen: &SeenHead) -> Option<ThinPlate> {
    let (from, to): (Vec<Point2>, Vec<Point2>) = map
        .pairs()
        .filter_map(|(l, v)| {
            let p = frame.points.get(l).filter(|p| p.visible)?;
            Some((Point2::new(p.x, p.y), seen.projected.get(v)?.0))
        })
        .unzip();
    ThinPlate::fit(&from, &to)
}

/// Gives each wanted (landmark, image point) its own visible vertex not in `taken`, least
/// summed squared distance, among each landmark's nearest [`CANDIDATES`] within `reach` px.
fn assign_unique(
    seen: &SeenHead,
    taken: &BTreeSet<usize>,
    wanted: &[(usize, Point2)],
    reach: Real,
) -> Vec<Option<usize>> {
    let candidates: Vec<Vec<(usize, Real)>> = wanted
        .iter()
        .map(|(_, target)| {
            let mut near: Vec<(usize, Real)> = seen
                .projected
                .iter()
                .enumerate()
                .filter(|(v, _)| seen.visible[*v] && !taken.contains(v))
                .map(|(v, (p, _))| (v, (p - target).norm_squared()))
                .filter(|(_, d2)| d2.is_finite() && *d2 <= reach * reach)
                .collect();
            near.sort_by(|a, b| a.1.total_cmp(&b.1));
            near.truncate(CANDIDATES);
            near
        })
        .collect();
    let columns: Vec<usize> =
        candidates.iter().flatten().map(|(v, _)| *v).collect::<BTreeSet<_>>().into_iter().collect();
    let column_of: BTreeMap<usize, usize> =
        columns.iter().enumerate().map(|(c, &v)| (v, c)).collect();
    // One "unassigned" column per landmark, dearer than any candidate and cheaper than a
    // vertex out of reach.
    let (rows, cols) = (wanted.len(), columns.len() + wanted.len());
    let unassigned = 2.0 * reach * reach;
    let mut cost = vec![4.0 * reach * reach; rows * cols];
    for (r, near) in candidates.iter().enumerate() {
        for (v, d2) in near {
            cost[r * cols + column_of[v]] = *d2;
        }
        for c in columns.len()..cols {
            cost[r * cols + c] = unassigned;
        }
    }
    let Some(of_row) = assign_min_cost(&cost, rows, cols) else {
        return vec![None; rows];
    };
    of_row
        .into_iter()
        .enumerate()
        .map(|(r, c)| (cost[r * cols + c] < unassigned).then(|| columns[c]))
        .collect()
}

/// Drops suggestions until the map (hand labels plus what is kept) passes
/// [`check_layout`] in the face's axes, blaming for each problem the least confident
/// suggestion it involves (hand labels are never blamed).
fn screen_by_anatomy(
    vertices: &[Point3],
    map: &LandmarkMap,
    pose: &OrthoPose,
    mut kept: Vec<MapSuggestion>,
) -> (Vec<MapSuggestion>, Vec<(usize, LeftOut)>) {
    // In the face's own axes (from the map with every suggestion), as `map check` does: the
    // camera's axes are the face's only for a face turned towards the camera, and a turned
    // head's far jaw, placed on the jaw line, folds back in them. Camera axes (x to the
    // image's right, the subject's left; y up) when the map gives no face axes.
    let all: BTreeMap<usize, Point3> = map
        .pairs()
        .chain(kept.iter().map(|s| (s.landmark, s.vertex)))
        .filter_map(|(l, v)| Some((l, *vertices.get(v)?)))
        .collect();
    let axes = face_axes(&all).unwrap_or(pose.r);
    let in_camera = |v: usize| vertices.get(v).map(|p| Point3::from(axes * p.coords));
    let mut dropped = Vec::new();
    loop {
        let points: BTreeMap<usize, Point3> = map
            .pairs()
            .chain(kept.iter().map(|s| (s.landmark, s.vertex)))
            .filter_map(|(l, v)| Some((l, in_camera(v)?)))
            .collect();
        let mut blamed: BTreeMap<usize, MapProblem> = BTreeMap::new();
        for problem in check_layout(&points) {
            let culprit = problem
                .landmarks()
                .into_iter()
                .filter_map(|l| kept.iter().find(|s| s.landmark == l))
                .min_by(|a, b| a.confidence.total_cmp(&b.confidence));
            if let Some(s) = culprit {
                blamed.entry(s.landmark).or_insert(problem);
            }
        }
        if blamed.is_empty() {
            return (kept, dropped);
        }
        kept.retain(|s| match blamed.remove(&s.landmark) {
            Some(problem) => {
                dropped.push((s.landmark, LeftOut::Anatomy(*s, problem)));
                false
            }
            None => true,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::camera::rotation_from_yaw_pitch_roll_deg;
    use crate::landmarks::LandmarkPoint;

    /// A dense grid "face" (x, y in [-1, 1], bulging towards +z) at 0.02 spacing, and the
    /// index of the grid vertex nearest (x, y).
    fn grid() -> (Vec<Point3>, impl Fn(Real, Real) -> usize) {
        let n = 101;
        let v: Vec<Point3> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as Real * 0.02 - 1.0, (k / n) as Real * 0.02 - 1.0);
                Point3::new(x, y, 1.0 - 0.3 * (x * x + y * y))
            })
            .collect();
        let at = move |x: Real, y: Real| {
            let (i, j) = (((x + 1.0) / 0.02).round() as usize, ((y + 1.0) / 0.02).round() as usize);
            j * n + i
        };
        (v, at)
    }

    /// An iBUG-like layout in grid units (x to the subject's left, y up).
    fn layout(l: usize) -> (Real, Real) {
        match l {
            0..=16 => {
                let t = std::f64::consts::PI * l as Real / 16.0;
                (-0.8 * t.cos(), -0.1 - 0.8 * t.sin())
            }
            17..=26 => (-0.6 + 0.12 * (l - 17) as Real + if l >= 22 { 0.12 } else { 0.0 }, 0.55),
            27..=30 => (0.0, 0.4 - 0.1 * (l - 27) as Real),
            31..=35 => (-0.16 + 0.08 * (l - 31) as Real, 0.02),
            36..=47 => {
                let k = (l - 36) % 6;
                let side = if l < 42 { -1.0 } else { 1.0 };
                let (dx, dy) = [
                    (-0.12, 0.0),
                    (-0.06, 0.04),
                    (0.06, 0.04),
                    (0.12, 0.0),
                    (0.06, -0.04),
                    (-0.06, -0.04),
                ][k];
                (side * 0.3 + dx, 0.3 + dy)
            }
            48..=59 => {
                let t = std::f64::consts::PI * (l - 48) as Real / 6.0;
                (-0.3 * t.cos(), -0.35 + 0.1 * t.sin().abs() * if l <= 54 { 1.0 } else { -1.0 })
            }
            _ => {
                let t = std::f64::consts::PI * (l - 60) as Real / 4.0;
                (-0.22 * t.cos(), -0.35 + 0.03 * t.sin().abs() * if l <= 64 { 1.0 } else { -1.0 })
            }
        }
    }

    #[test]
    fn five_labels_give_a_unique_sane_map_matching_the_truth() {
        let (v, at) = grid();
        let truth: Vec<usize> = (0..N_LANDMARKS).map(|l| at(layout(l).0, layout(l).1)).collect();
        let mut distinct = truth.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), N_LANDMARKS, "the test layout uses 68 vertices");
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(10.0, -5.0, 3.0),
            s: 150.0,
            tx: 1.5,
            ty: 1.8,
        };
        let mut frame = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
        for (l, &t) in truth.iter().enumerate() {
            let p = pose.project(&v[t], 480.0);
            frame.points[l] = LandmarkPoint::tracked(p.x, p.y);
        }
        let mut map = LandmarkMap::default();
        for l in [8, 30, 36, 45, 48, 54] {
            map.to_vertex.insert(l, truth[l]);
        }
        let head = SuggestHead::points(&v);
        let proposal = suggest_map(&head, &map, &frame, 480.0, None).unwrap();
        assert_eq!(proposal.left, vec![], "{}", proposal.summary());
        let full = proposal.applied_to(&map);
        assert_eq!(full.len(), N_LANDMARKS);
        for (l, vtx) in full.pairs() {
            assert_eq!(vtx, truth[l], "landmark {l}");
        }
        assert!(proposal.lowest_confidence().unwrap() > 0.99);
        assert!(
            check_layout(&full.pairs().map(|(l, x)| (l, v[x])).collect::<BTreeMap<_, _>>())
                .is_empty()
        );
    }

    #[test]
    fn points_crowding_one_vertex_get_distinct_vertices_or_are_left() {
        // Four tracked points inside one vertex spacing: nearest-vertex suggestion gives them
        // all one vertex; the assignment cannot.
        let (v, at) = grid();
        let pose = OrthoPose { r: nalgebra::Matrix3::identity(), s: 100.0, tx: 1.5, ty: 1.5 };
        let mut frame = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
        let mut map = LandmarkMap::default();
        for l in [8, 30, 36, 45, 48, 54] {
            let (x, y) = layout(l);
            map.to_vertex.insert(l, at(x, y));
            let p = pose.project(&v[at(x, y)], 480.0);
            frame.points[l] = LandmarkPoint::tracked(p.x, p.y);
        }
        let centre = pose.project(&v[at(-0.3, 0.3)], 480.0);
        for (k, l) in [37, 38, 40, 41].into_iter().enumerate() {
            frame.points[l] = LandmarkPoint::tracked(centre.x + 0.1 * k as Real, centre.y);
        }
        let proposal =
            suggest_map(&SuggestHead::points(&v), &map, &frame, 480.0, Some(pose)).unwrap();
        let full = proposal.applied_to(&map);
        let mut used: Vec<usize> = full.to_vertex.values().copied().collect();
        let n = used.len();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), n, "no vertex twice");
        let crowded: Vec<&MapSuggestion> =
            proposal.accepted.iter().filter(|s| [37, 38, 40, 41].contains(&s.landmark)).collect();
        assert!(crowded.len() >= 2, "{}", proposal.summary());
        // Points not tracked are reported as such.
        assert!(proposal.left.iter().any(|(l, w)| *l == 0 && *w == LeftOut::NotVisible));
    }

    /// A suggestion far from both its neighbours along its feature (a jaw point the tracker
    /// put on the cheek; an upper-lid point on the forehead, as a vertex seen through an
    /// eye's hole would be) is left out and listed; its neighbours are kept.
    #[test]
    fn a_suggestion_far_from_its_neighbours_is_left_out_and_listed() {
        let (v, at) = grid();
        let truth: Vec<usize> = (0..N_LANDMARKS).map(|l| at(layout(l).0, layout(l).1)).collect();
        let pose = OrthoPose { r: nalgebra::Matrix3::identity(), s: 150.0, tx: 1.5, ty: 1.8 };
        // (landmark moved, grid units up (image y is down), suggested points of its feature)
        for (moved, up, neighbours) in [(5, 0.6, [4, 6]), (37, 0.3, [38, 41])] {
            let mut frame = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
            for (l, &t) in truth.iter().enumerate() {
                let p = pose.project(&v[t], 480.0);
                frame.points[l] = LandmarkPoint::tracked(p.x, p.y);
            }
            frame.points[moved].y -= up * 150.0;
            let mut map = LandmarkMap::default();
            for l in [8, 30, 36, 45, 48, 54] {
                map.to_vertex.insert(l, truth[l]);
            }
            let proposal =
                suggest_map(&SuggestHead::points(&v), &map, &frame, 480.0, Some(pose)).unwrap();
            let summary = proposal.summary();
            let why = proposal.left.iter().find(|(l, _)| *l == moved).map(|(_, w)| w.clone());
            assert!(matches!(why, Some(LeftOut::FarFromNeighbours(..))), "{moved}: {summary}");
            assert!(proposal.accepted.iter().all(|s| s.landmark != moved));
            assert!(summary.contains("1 far from their neighbours"), "{moved}: {summary}");
            assert!(
                why.unwrap().to_string().contains("from its nearest neighbour along its feature")
            );
            for n in neighbours {
                assert!(proposal.accepted.iter().any(|s| s.landmark == n), "{moved}: {summary}");
            }
        }
    }

    #[test]
    fn a_point_far_from_both_neighbours_is_reported_on_open_and_closed_chains() {
        let mut line: Vec<(usize, Point3)> =
            (0..17).map(|l| (l, Point3::new(l as Real, 0.0, 0.0))).collect();
        line[5].1 = Point3::new(5.0, 9.0, 0.0);
        let suggested: BTreeSet<usize> = (0..17).filter(|l| *l != 8).collect();
        let far = far_from_neighbours(&line, false, &suggested, 2.5);
        assert_eq!(far.len(), 1);
        assert_eq!(far[0].0, 5);
        assert!((far[0].2 - 1.0).abs() < 1e-12);
        // A ring of six (an eye): its first point's neighbours are the second and the last.
        let ring = |first: Point3| -> Vec<(usize, Point3)> {
            (0..6)
                .map(|k| {
                    let t = std::f64::consts::TAU * k as Real / 6.0;
                    (36 + k, if k == 0 { first } else { Point3::new(t.cos(), t.sin(), 0.0) })
                })
                .collect()
        };
        let all: BTreeSet<usize> = (36..42).collect();
        assert!(far_from_neighbours(&ring(Point3::new(1.0, 0.0, 0.0)), true, &all, 2.5).is_empty());
        let far = far_from_neighbours(&ring(Point3::new(1.0, 0.0, -9.0)), true, &all, 2.5);
        assert_eq!(far.iter().map(|f| f.0).collect::<Vec<_>>(), vec![36]);
    }
}
