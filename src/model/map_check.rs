//! Checking a landmark map against facial anatomy: landmarks that share a vertex, left/right
//! crossings (a point on the wrong side of the midline, a mirror pair swapped), contours out
//! of order (the jaw line, brows, nose base, lips), eyes not above the nose tip or the mouth
//! not below it, and eye/mouth proportions outside the human range.
//!
//! Start with [`check_map`] (a map on a mesh, the head's axes found from the map itself),
//! [`check_map_on_surface`] (the same, and the mesh checked to be a surface a map can be
//! labelled on) or [`check_layout`] (points already in face axes, as the suggester has them
//! from a camera).
//!
//! Face axes: x towards the subject's left (image right on a frontal view), y up, z out of
//! the face. iBUG numbers the subject's right side first (landmark 0 is on the image's left).

use crate::math::{Point3, Real, Vector3};
use crate::model::LandmarkMap;
use std::collections::BTreeMap;
use std::fmt;

/// iBUG-68 mirror pairs (0-based): (subject's right, subject's left).
pub const MIRROR_PAIRS: [(usize, usize); 29] = [
    (0, 16),
    (1, 15),
    (2, 14),
    (3, 13),
    (4, 12),
    (5, 11),
    (6, 10),
    (7, 9),
    (17, 26),
    (18, 25),
    (19, 24),
    (20, 23),
    (21, 22),
    (31, 35),
    (32, 34),
    (36, 45),
    (37, 44),
    (38, 43),
    (39, 42),
    (40, 47),
    (41, 46),
    (48, 54),
    (49, 53),
    (50, 52),
    (59, 55),
    (58, 56),
    (60, 64),
    (61, 63),
    (67, 65),
];

/// Landmarks on the midline (chin, nose bridge and tip, philtrum and lip centres).
const MIDLINE: [usize; 10] = [8, 27, 28, 29, 30, 33, 51, 57, 62, 66];

/// Chains that run from the subject's right to their left (x increasing along each).
const LEFT_TO_RIGHT: [&[usize]; 10] = [
    &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16],
    &[17, 18, 19, 20, 21],
    &[22, 23, 24, 25, 26],
    &[31, 32, 33, 34, 35],
    &[36, 39, 42, 45],
    &[48, 49, 50, 51, 52, 53, 54],
    &[48, 59, 58, 57, 56, 55, 54],
    &[60, 61, 62, 63, 64],
    &[60, 67, 66, 65, 64],
    &[17, 21, 22, 26],
];

/// Eyes and brows: above the nose tip.
const ABOVE_NOSE: [usize; 22] =
    [17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47];

/// Human ranges of unit-free eye/mouth proportions, wide enough for any adult face seen
/// frontally (anthropometric norms, L. G. Farkas, *Anthropometry of the Head and Face*, 1994:
/// en–en ≈ 31–35 mm, ex–ex ≈ 86–92 mm, ch–ch ≈ 48–55 mm), so only a misplaced landmark
/// leaves them.
pub const PROPORTIONS: [Proportion; 3] = [
    Proportion {
        name: "intercanthal / biocular width (40–43 over 37–46)",
        num: (39, 42),
        den: (36, 45),
        range: (0.25, 0.5),
    },
    Proportion {
        name: "mouth width / intercanthal width (49–55 over 40–43)",
        num: (48, 54),
        den: (39, 42),
        range: (1.0, 2.6),
    },
    Proportion {
        name: "mouth width / biocular width (49–55 over 37–46)",
        num: (48, 54),
        den: (36, 45),
        range: (0.4, 0.85),
    },
];

/// A ratio of two landmark distances and its plausible range (`name` numbers landmarks
/// 1-based, as every message does; `num` and `den` are 0-based).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Proportion {
    pub name: &'static str,
    pub num: (usize, usize),
    pub den: (usize, usize),
    pub range: (Real, Real),
}

/// One thing wrong with a map (landmarks 0-based).
#[derive(Clone, Debug, PartialEq)]
pub enum MapProblem {
    SharedVertex {
        vertex: usize,
        landmarks: Vec<usize>,
    },
    VertexOutOfRange {
        landmark: usize,
        vertex: usize,
    },
    WrongSide {
        landmark: usize,
    },
    PairSwapped {
        right: usize,
        left: usize,
    },
    OutOfOrder {
        first: usize,
        second: usize,
    },
    NotAbove {
        landmark: usize,
        reference: usize,
    },
    NotBelow {
        landmark: usize,
        reference: usize,
    },
    Proportion {
        name: &'static str,
        value: Real,
        range: (Real, Real),
    },
    /// The map maps no landmark.
    NoLandmarks,
    /// The mesh has no faces: it is not a surface a map can be labelled on.
    NoFaces,
    /// Faces of (numerically) zero area: all of them (the vertices lie on a line or in one
    /// point), or some.
    ZeroAreaFaces {
        count: usize,
        faces: usize,
    },
}

impl MapProblem {
    /// The landmarks the problem involves.
    pub fn landmarks(&self) -> Vec<usize> {
        match self {
            Self::SharedVertex { landmarks, .. } => landmarks.clone(),
            Self::VertexOutOfRange { landmark, .. } | Self::WrongSide { landmark } => {
                vec![*landmark]
            }
            Self::PairSwapped { right, left } => vec![*right, *left],
            Self::OutOfOrder { first, second } => vec![*first, *second],
            Self::NotAbove { landmark, reference } | Self::NotBelow { landmark, reference } => {
                vec![*landmark, *reference]
            }
            Self::Proportion { name, .. } => PROPORTIONS
                .iter()
                .filter(|p| p.name == *name)
                .flat_map(|p| [p.num.0, p.num.1, p.den.0, p.den.1])
                .collect(),
            Self::NoLandmarks | Self::NoFaces | Self::ZeroAreaFaces { .. } => Vec::new(),
        }
    }
}

/// Landmarks in messages are 1-based, as in eos's map files and the iBUG figure.
impl fmt::Display for MapProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use crate::landmarks::PointNo as N;
        let one =
            |ls: &[usize]| ls.iter().map(|&l| N(l).to_string()).collect::<Vec<_>>().join(", ");
        match self {
            Self::SharedVertex { vertex, landmarks } => {
                write!(f, "landmarks {} share vertex {vertex}", one(landmarks))
            }
            Self::VertexOutOfRange { landmark, vertex } => {
                write!(f, "landmark {} is on vertex {vertex}, beyond the mesh", N(*landmark))
            }
            Self::WrongSide { landmark } => {
                write!(f, "landmark {} is on the wrong side of the midline", N(*landmark))
            }
            Self::PairSwapped { right, left } => {
                write!(f, "landmarks {} and {} are swapped left/right", N(*right), N(*left))
            }
            Self::OutOfOrder { first, second } => {
                write!(f, "landmarks {} and {} are out of order", N(*first), N(*second))
            }
            Self::NotAbove { landmark, reference } => {
                write!(f, "landmark {} is not above landmark {}", N(*landmark), N(*reference))
            }
            Self::NotBelow { landmark, reference } => {
                write!(f, "landmark {} is not below landmark {}", N(*landmark), N(*reference))
            }
            Self::Proportion { name, value, range } => write!(
                f,
                "{name} is {value:.2}, outside the human range {:.2}–{:.2}",
                range.0, range.1
            ),
            Self::NoLandmarks => write!(f, "it maps no landmark"),
            Self::NoFaces => write!(f, "the mesh has no faces, so it is not a head's surface"),
            Self::ZeroAreaFaces { count, faces } if count == faces => write!(
                f,
                "every one of the mesh's {faces} faces has zero area (its vertices lie on a line \
                 or in one point), so it is not a head's surface"
            ),
            Self::ZeroAreaFaces { count, faces } => {
                write!(f, "{count} of the mesh's {faces} faces have zero area")
            }
        }
    }
}

/// Everything [`check_map`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapCheck {
    pub problems: Vec<MapProblem>,
    /// Whether the head's axes could be found (else only shared vertices, the vertex range
    /// and proportions were checked).
    pub axes_found: bool,
}

impl MapCheck {
    /// No problem found.
    pub fn is_plausible(&self) -> bool {
        self.problems.is_empty()
    }

    /// Whether a proportion is outside the human range (the head's own indices are then not
    /// to be trusted).
    pub fn has_implausible_proportions(&self) -> bool {
        self.problems.iter().any(|p| matches!(p, MapProblem::Proportion { .. }))
    }

    /// One line: "map looks anatomically plausible" or the first problems and a count.
    pub fn summary(&self) -> String {
        match self.problems.as_slice() {
            [] => "map looks anatomically plausible".into(),
            [p] => format!("map problem: {p}"),
            [p, q] => format!("map problems: {p}; {q}"),
            [p, q, rest @ ..] => format!("map problems: {p}; {q}; and {} more", rest.len()),
        }
    }
}

/// Face axes of a head from its map: up from the mouth and chin to the eyes and brows,
/// forward from the face's mean towards the nose, x = up × forward. Rows of the returned
/// matrix are x, y, z, so `axes * v` gives a vertex in face axes. `None` without points
/// above and below the nose or without a nose point.
pub fn face_axes(points: &BTreeMap<usize, Point3>) -> Option<crate::math::Matrix3> {
    let mean_of = |ls: &mut dyn Iterator<Item = usize>| {
        let ps: Vec<&Point3> = ls.filter_map(|l| points.get(&l)).collect();
        (!ps.is_empty())
            .then(|| ps.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / ps.len() as Real)
    };
    let upper = mean_of(&mut (17..=27).chain(36..=47))?;
    let lower = mean_of(&mut (48..=67).chain(5..=11))?;
    let nose = mean_of(&mut [30usize].into_iter()).or_else(|| mean_of(&mut (31..=35)))?;
    let all = mean_of(&mut points.keys().copied().filter(|l| !(27..=35).contains(l)))?;
    let up = (upper - lower).try_normalize(1e-12)?;
    let out = nose - all;
    let forward = (out - up * up.dot(&out)).try_normalize(1e-12)?;
    let x = up.cross(&forward);
    Some(crate::math::Matrix3::from_rows(&[x.transpose(), up.transpose(), forward.transpose()]))
}

/// Checks `map` on the head `vertices`: shared vertices, vertices beyond the mesh, then the
/// layout in the face axes the map itself gives ([`face_axes`]) and the proportions.
pub fn check_map(map: &LandmarkMap, vertices: &[Point3]) -> MapCheck {
    let mut problems = shared_vertices(map);
    let mut points = BTreeMap::new();
    for (l, v) in map.pairs() {
        match vertices.get(v) {
            Some(p) => {
                points.insert(l, *p);
            }
            None => problems.push(MapProblem::VertexOutOfRange { landmark: l, vertex: v }),
        }
    }
    let axes = face_axes(&points);
    match axes {
        Some(r) => {
            let in_axes: BTreeMap<usize, Point3> =
                points.iter().map(|(&l, p)| (l, Point3::from(r * p.coords))).collect();
            problems.extend(check_layout(&in_axes));
        }
        None => problems.extend(check_proportions(&points)),
    }
    MapCheck { problems, axes_found: axes.is_some() }
}

/// [`check_map`] on a mesh with faces `triangles`: first whether the mesh is a surface a map
/// can mean anything on ([`check_surface`]), and whether the map maps anything.
pub fn check_map_on_surface(
    map: &LandmarkMap,
    vertices: &[Point3],
    triangles: &[[u32; 3]],
) -> MapCheck {
    let mut problems = check_surface(vertices, triangles);
    if map.is_empty() {
        problems.push(MapProblem::NoLandmarks);
    }
    let on_map = check_map(map, vertices);
    problems.extend(on_map.problems);
    MapCheck { problems, axes_found: on_map.axes_found }
}

/// A face's area below this fraction of the squared size of the mesh's bounding box counts
/// as zero: far below any real face (a head mesh of 20,000 faces has faces of ~1e-5 of it),
/// far above rounding.
pub const ZERO_AREA_FRACTION: Real = 1e-12;

/// Whether vertices and `triangles` make a surface: faces at all, and faces of some area (a
/// mesh whose vertices lie on a line has faces of zero area only). Faces naming a vertex
/// past the mesh are left to the reader that made them.
pub fn check_surface(vertices: &[Point3], triangles: &[[u32; 3]]) -> Vec<MapProblem> {
    if triangles.is_empty() {
        return vec![MapProblem::NoFaces];
    }
    let (lo, hi) = vertices.iter().fold(
        (Vector3::repeat(Real::INFINITY), Vector3::repeat(Real::NEG_INFINITY)),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let size2 = if vertices.is_empty() { 0.0 } else { (hi - lo).norm_squared() };
    let zero = triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|v| vertices.get(v as usize));
            match (a, b, c) {
                (Some(a), Some(b), Some(c)) => {
                    0.5 * (b - a).cross(&(c - a)).norm() <= ZERO_AREA_FRACTION * size2
                }
                _ => false,
            }
        })
        .count();
    if zero == 0 {
        return Vec::new();
    }
    vec![MapProblem::ZeroAreaFaces { count: zero, faces: triangles.len() }]
}

/// Groups of landmarks mapped to one vertex.
pub fn shared_vertices(map: &LandmarkMap) -> Vec<MapProblem> {
    let mut by_vertex: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (l, v) in map.pairs() {
        by_vertex.entry(v).or_default().push(l);
    }
    by_vertex
        .into_iter()
        .filter(|(_, ls)| ls.len() > 1)
        .map(|(vertex, landmarks)| MapProblem::SharedVertex { vertex, landmarks })
        .collect()
}

/// Layout problems of points given in face axes (x to the subject's left, y up): sides of
/// the midline, mirror pairs, chain order, eyes above and mouth below the nose tip, and the
/// proportions. Tolerances are a small fraction of the face's size, so points on or next to
/// the midline are not flagged for lying on it.
pub fn check_layout(points: &BTreeMap<usize, Point3>) -> Vec<MapProblem> {
    let mut problems = Vec::new();
    let span = |f: fn(&Point3) -> Real| {
        let (lo, hi) = points
            .values()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), p| (lo.min(f(p)), hi.max(f(p))));
        if hi > lo { hi - lo } else { 0.0 }
    };
    let size = span(|p| p.x).max(span(|p| p.y));
    if size <= 0.0 {
        return check_proportions(points);
    }
    let tol = 0.01 * size;
    let x = |l: usize| points.get(&l).map(|p| p.x);
    let y = |l: usize| points.get(&l).map(|p| p.y);
    // Swapped pairs first: a swap also puts both points on the wrong side, and the swap is
    // the cause a one-line summary should name.
    for &(r, l) in &MIRROR_PAIRS {
        if let (Some(xr), Some(xl)) = (x(r), x(l))
            && xr >= xl
        {
            problems.push(MapProblem::PairSwapped { right: r, left: l });
        }
    }
    let mut mid: Vec<Real> = MIDLINE.iter().filter_map(|&l| x(l)).collect();
    mid.sort_by(Real::total_cmp);
    if let Some(&m) = mid.get(mid.len() / 2) {
        for &(r, l) in &MIRROR_PAIRS {
            if x(r).is_some_and(|xr| xr > m + tol) {
                problems.push(MapProblem::WrongSide { landmark: r });
            }
            if x(l).is_some_and(|xl| xl < m - tol) {
                problems.push(MapProblem::WrongSide { landmark: l });
            }
        }
    }
    for chain in LEFT_TO_RIGHT {
        let mapped: Vec<usize> = chain.iter().copied().filter(|&l| x(l).is_some()).collect();
        for w in mapped.windows(2) {
            if let (Some(a), Some(b)) = (x(w[0]), x(w[1]))
                && a > b + tol
            {
                problems.push(MapProblem::OutOfOrder { first: w[0], second: w[1] });
            }
        }
    }
    if let Some(yn) = y(30) {
        for &l in &ABOVE_NOSE {
            if y(l).is_some_and(|yl| yl <= yn) {
                problems.push(MapProblem::NotAbove { landmark: l, reference: 30 });
            }
        }
        for l in (48..=67).chain(7..=9) {
            if y(l).is_some_and(|yl| yl >= yn) {
                problems.push(MapProblem::NotBelow { landmark: l, reference: 30 });
            }
        }
    }
    for (upper, lower) in [(51, 57), (57, 8)] {
        if let (Some(a), Some(b)) = (y(upper), y(lower))
            && a <= b
        {
            problems.push(MapProblem::NotBelow { landmark: lower, reference: upper });
        }
    }
    problems.extend(check_proportions(points));
    problems
}

/// Proportions outside [`PROPORTIONS`]' ranges (3D distances; only where all four points
/// are mapped).
pub fn check_proportions(points: &BTreeMap<usize, Point3>) -> Vec<MapProblem> {
    let dist = |(a, b): (usize, usize)| Some((points.get(&a)? - points.get(&b)?).norm());
    PROPORTIONS
        .iter()
        .filter_map(|p| {
            let (n, d) = (dist(p.num)?, dist(p.den)?);
            let value = if d > 0.0 { n / d } else { Real::INFINITY };
            (!(p.range.0..=p.range.1).contains(&value)).then_some(MapProblem::Proportion {
                name: p.name,
                value,
                range: p.range,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plausible frontal face in millimetres (x to the subject's left, y up, z out), after
    /// the mean iBUG-68 layout: only the points the checks use most.
    fn face() -> BTreeMap<usize, Point3> {
        let mut p = BTreeMap::new();
        for l in 0..=16 {
            // The jaw: a half ellipse from ear to ear through the chin.
            let t = std::f64::consts::PI * (l as Real / 16.0);
            p.insert(l, Point3::new(-70.0 * t.cos(), -10.0 - 70.0 * t.sin(), -20.0));
        }
        for (l, x) in (17..=21).zip([-55.0, -45.0, -35.0, -25.0, -12.0]) {
            p.insert(l, Point3::new(x, 45.0, 5.0));
            p.insert(38 - l + 5, Point3::new(-x, 45.0, 5.0));
        }
        for (l, y) in (27..=30).zip([35.0, 25.0, 15.0, 5.0]) {
            p.insert(l, Point3::new(0.0, y, 10.0 + (35.0 - y)));
        }
        for (l, x) in (31..=35).zip([-14.0, -7.0, 0.0, 7.0, 14.0]) {
            p.insert(l, Point3::new(x, -3.0, 20.0));
        }
        for (l, x, y) in
            [(36, -45.0, 30.0), (37, -38.0, 34.0), (38, -26.0, 34.0), (39, -16.0, 30.0)]
                .into_iter()
                .chain([(40, -26.0, 27.0), (41, -38.0, 27.0)])
        {
            p.insert(l, Point3::new(x, y, 0.0));
            let mirror = [45, 44, 43, 42, 47, 46][l - 36];
            p.insert(mirror, Point3::new(-x, y, 0.0));
        }
        let lips: [(usize, Real, Real); 20] = [
            (48, -26.0, -30.0),
            (49, -17.0, -24.0),
            (50, -7.0, -21.0),
            (51, 0.0, -22.0),
            (52, 7.0, -21.0),
            (53, 17.0, -24.0),
            (54, 26.0, -30.0),
            (55, 17.0, -37.0),
            (56, 8.0, -40.0),
            (57, 0.0, -41.0),
            (58, -8.0, -40.0),
            (59, -17.0, -37.0),
            (60, -22.0, -30.0),
            (61, -8.0, -28.0),
            (62, 0.0, -28.0),
            (63, 8.0, -28.0),
            (64, 22.0, -30.0),
            (65, 8.0, -32.0),
            (66, 0.0, -32.0),
            (67, -8.0, -32.0),
        ];
        for (l, x, y) in lips {
            p.insert(l, Point3::new(x, y, 15.0));
        }
        p
    }

    fn map_of(points: &BTreeMap<usize, Point3>) -> (LandmarkMap, Vec<Point3>) {
        let vertices: Vec<Point3> = points.values().copied().collect();
        let to_vertex = points.keys().enumerate().map(|(v, &l)| (l, v)).collect();
        (LandmarkMap { to_vertex }, vertices)
    }

    #[test]
    fn a_plausible_face_passes_in_any_orientation() {
        let face = face();
        assert_eq!(face.len(), 68);
        assert_eq!(check_layout(&face), vec![]);
        // Turned and moved (a scan in its own frame): the axes come from the map.
        let r = nalgebra::Rotation3::from_euler_angles(0.4, -1.1, 2.0);
        let turned: BTreeMap<usize, Point3> =
            face.iter().map(|(&l, p)| (l, r * p + Vector3::new(5.0, -3.0, 100.0))).collect();
        let (map, vertices) = map_of(&turned);
        let check = check_map(&map, &vertices);
        assert!(check.axes_found);
        assert!(check.is_plausible(), "{}", check.summary());
        let axes = face_axes(&turned).unwrap();
        let x = axes * (turned[&16] - turned[&0]);
        assert!(x.x > 100.0, "landmark 16 lies to the subject's left: {x}");
    }

    #[test]
    fn shared_swapped_disordered_and_misproportioned_maps_are_reported() {
        let face = face();
        let (mut map, vertices) = map_of(&face);
        // Two brow points on one vertex.
        let v19 = map.vertex(19).unwrap();
        map.to_vertex.insert(20, v19);
        // The eyes' outer corners swapped.
        let (a, b) = (map.vertex(36).unwrap(), map.vertex(45).unwrap());
        map.to_vertex.insert(36, b);
        map.to_vertex.insert(45, a);
        // Jaw 3 and 4 in each other's place.
        let (c, d) = (map.vertex(3).unwrap(), map.vertex(4).unwrap());
        map.to_vertex.insert(3, d);
        map.to_vertex.insert(4, c);
        let check = check_map(&map, &vertices);
        let p = &check.problems;
        assert!(p.contains(&MapProblem::SharedVertex { vertex: v19, landmarks: vec![19, 20] }));
        assert!(p.contains(&MapProblem::PairSwapped { right: 36, left: 45 }));
        assert!(p.contains(&MapProblem::WrongSide { landmark: 36 }));
        assert!(p.contains(&MapProblem::OutOfOrder { first: 3, second: 4 }));
        assert!(!check.has_implausible_proportions());
        assert!(check.summary().starts_with("map problems: landmarks 20, 21 share vertex"));

        // The inner eye corners on the nose bridge: intercanthal width near zero.
        let mut narrow = face.clone();
        narrow.insert(39, Point3::new(-2.0, 30.0, 10.0));
        narrow.insert(42, Point3::new(2.0, 30.0, 10.0));
        let problems = check_layout(&narrow);
        assert!(
            problems.iter().any(|p| matches!(p, MapProblem::Proportion { value, .. }
                if (*value - 4.0 / 90.0).abs() < 1e-9)),
            "{problems:?}"
        );
        // An eye point below the nose tip, a chin above the lower lip.
        let mut low = face.clone();
        low.insert(37, Point3::new(-38.0, 0.0, 0.0));
        low.insert(8, Point3::new(0.0, -35.0, 0.0));
        let problems = check_layout(&low);
        assert!(problems.contains(&MapProblem::NotAbove { landmark: 37, reference: 30 }));
        assert!(problems.contains(&MapProblem::NotBelow { landmark: 8, reference: 57 }));
    }

    #[test]
    fn vertices_beyond_the_mesh_and_axis_free_maps() {
        let map = LandmarkMap { to_vertex: [(48, 0), (54, 5)].into_iter().collect() };
        let check = check_map(&map, &[Point3::origin()]);
        assert!(!check.axes_found);
        assert_eq!(check.problems, vec![MapProblem::VertexOutOfRange { landmark: 54, vertex: 5 }]);
    }
}
