//! The demo's procedural head: a face sheet (a height field over a face-shaped grid, y up,
//! looking along +z, millimetres) with a cut between the lips, a dark mouth cavity behind it,
//! per-vertex colours and the iBUG-68 landmark map.
//!
//! The lips meet along one grid row (`Y_MOUTH`): between the mouth corners that row exists
//! twice, once for the upper lip and once for the lower, so the mouth can open into a slit
//! whose edges are the inner lip contour (iBUG 60–67) while the corners stay joined. With the
//! mouth closed both copies coincide, so the neutral head has H = 0. Articulation
//! (`visemes.rs`) moves vertices by displacement fields defined on these rest positions.

use crate::landmarks::ibug::N_LANDMARKS;
use crate::math::Point3;
use crate::model::{LandmarkMap, Mesh};

/// Height of the lip seam (mm).
pub const Y_MOUTH: f64 = -40.0;
/// Lowest and highest grid rows (mm) and the row spacing.
const Y_BOTTOM: f64 = -100.0;
const ROWS: usize = 109;
const DY: f64 = 2.0;
/// Columns per row: the grid spans the face's width at each height.
const COLS: usize = 61;
/// Column offsets from the centre column of the inner (60/64) and outer (48/54) mouth corners.
const INNER_CORNER_COLS: usize = 10;
const OUTER_CORNER_COLS: usize = 11;
/// Where the jaw hinges (temporomandibular joint), as (y, z) in mm.
pub const JAW_PIVOT: (f64, f64) = (-8.0, -5.0);

/// Colours (RGB) of the skin, lips, mouth interior, eyes and brows.
pub const SKIN: [u8; 3] = [226, 184, 152];
pub const LIP: [u8; 3] = [168, 78, 84];
pub const MOUTH_INTERIOR: [u8; 3] = [42, 16, 20];
const SCLERA: [u8; 3] = [236, 232, 226];
const IRIS: [u8; 3] = [70, 52, 40];
const BROW: [u8; 3] = [92, 64, 44];

/// What part of the head a vertex belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    Face,
    /// The dark wall behind the lips, seen through the open mouth.
    Cavity,
}

/// The demo head at rest (neutral) and what articulation needs to know about each vertex.
#[derive(Clone, Debug)]
pub struct Head {
    /// Neutral mesh (triangles as faces).
    pub mesh: Mesh,
    /// One colour per vertex.
    pub colours: Vec<[u8; 3]>,
    /// iBUG-68 (0-based) → vertex; every point is mapped.
    pub landmarks: LandmarkMap,
    /// Per vertex: moves with the lower lip and jaw (below the seam, or the lower seam copy).
    pub lower: Vec<bool>,
    pub part: Vec<Part>,
    /// Vertices of the upper lip's vermilion (for protrusion: its foremost point).
    pub upper_lip: Vec<usize>,
    /// x (mm) of the inner mouth corners at rest (±).
    pub inner_corner_x: f64,
    /// x (mm) of the outer mouth corners at rest (±).
    pub outer_corner_x: f64,
}

/// Half the face's width (mm) at height `y`: an egg outline, widest at the cheekbones and
/// narrow at the chin, so the grid's boundary is the face outline seen from the front.
pub fn half_width(y: f64) -> f64 {
    let w = if y >= 0.0 {
        let t = (y / 118.0).clamp(0.0, 1.0);
        72.0 * (1.0 - t.powf(2.5)).max(0.0).sqrt()
    } else {
        let t = (-y / 103.0).clamp(0.0, 1.0);
        72.0 * (1.0 - t.powf(2.2)).max(0.0).sqrt()
    };
    w.max(8.0)
}

fn gauss(d: f64, sigma: f64) -> f64 {
    (-(d / sigma).powi(2)).exp()
}

/// The face's depth z (mm, forward) at rest at (x, y): a rounded front plus nose, brows,
/// eye sockets, cheeks, lips and chin, each a smooth bump so the shading reads as a face.
pub fn face_depth(x: f64, y: f64) -> f64 {
    let u = (x / half_width(y)).clamp(-1.0, 1.0);
    let mut z = 82.0 * (1.0 - 0.82 * u * u).sqrt();
    if y > 55.0 {
        z -= 0.006 * (y - 55.0).powi(2);
    }
    if y < -88.0 {
        z -= 0.25 * (-88.0 - y).powi(2);
    }
    // Brow ridge and eye sockets with the eyeballs in them.
    z += 4.0 * gauss(y - 50.0, 7.0) * (-(x / 50.0).powi(4)).exp();
    for side in [-1.0, 1.0] {
        let (ex, ey) = (side * 31.0, 32.0);
        z -= 9.0 * (-((x - ex).powi(2) / 225.0 + (y - ey).powi(2) / 81.0)).exp();
        z += 4.0 * (-((x - ex).powi(2) + (y - ey).powi(2)) / 64.0).exp();
        // Cheeks and nose wings (alae).
        z += 6.0 * (-((x - side * 38.0).powi(2) / 324.0 + (y + 5.0).powi(2) / 400.0)).exp();
        z += 5.0 * (-((x - side * 14.0).powi(2) + (y + 12.0).powi(2)) / 36.0).exp();
    }
    // Nose: a ridge from the nasion (3 mm) to the tip (22 mm), falling to the subnasale.
    let ridge = if y >= -2.0 {
        let t = ((y + 2.0) / 36.0).clamp(0.0, 1.5);
        (22.0 - 19.0 * t.powf(0.8)).max(0.0) * if y > 34.0 { gauss(y - 34.0, 8.0) } else { 1.0 }
    } else {
        22.0 * (1.0 - ((-2.0 - y) / 13.0).min(1.0).powf(1.5))
    };
    let nose_width = 6.0 + 6.0 * gauss(y + 6.0, 8.0);
    z += ridge * gauss(x, nose_width);
    // Upper jaw under the upper lip, the lips, the groove under the lower lip and the chin.
    z += 3.0 * gauss(x, 25.0) * gauss(y + 25.0, 10.0);
    z += 6.0 * (-(x / 22.0).powi(4)).exp() * gauss(y - (Y_MOUTH + 5.0), 6.0);
    z += 6.0 * (-(x / 21.0).powi(4)).exp() * gauss(y - (Y_MOUTH - 6.0), 6.0);
    z -= 3.0 * gauss(x, 20.0) * gauss(y + 58.0, 4.0);
    z += 7.0 * gauss(x, 18.0) * gauss(y + 78.0, 10.0);
    z
}

/// Upper and lower vermilion borders (mm) at x, for a mouth with outer corners at ±`cx`;
/// `None` outside the mouth.
fn lip_borders(x: f64, cx: f64) -> Option<(f64, f64)> {
    let t = x.abs() / cx;
    if t > 1.0 {
        return None;
    }
    // The Cupid's bow: two peaks either side of a shallow central dip.
    let bow = 1.2 * gauss(x.abs() - 0.3 * cx, 0.18 * cx) - 0.8 * gauss(x, 0.12 * cx);
    let upper = Y_MOUTH + (9.5 * (1.0 - t * t).powf(0.6) + bow).max(0.0);
    let lower = Y_MOUTH - 10.0 * (1.0 - t * t).powf(0.7);
    Some((upper, lower))
}

/// Target rest positions (x, y) of the 68 iBUG points, before snapping to vertices.
fn landmark_targets(cx_outer: f64) -> [(f64, f64); N_LANDMARKS] {
    let mut t = [(0.0, 0.0); N_LANDMARKS];
    // Jaw 0–16 are placed on the outline separately (see `jaw_vertices`).
    let brows = [(-55.0, 45.0), (-45.0, 51.0), (-34.0, 53.0), (-23.0, 52.0), (-13.0, 49.0)];
    for (i, &(x, y)) in brows.iter().enumerate() {
        t[17 + i] = (x, y);
        t[26 - i] = (-x, y);
    }
    for (i, y) in [34.0, 22.0, 10.0, -2.0].into_iter().enumerate() {
        t[27 + i] = (0.0, y);
    }
    let lower_nose = [(-16.0, -13.0), (-8.0, -16.0), (0.0, -17.0)];
    for (i, &(x, y)) in lower_nose.iter().enumerate() {
        t[31 + i] = (x, y);
        t[35 - i] = (-x, y);
    }
    // Right eye 36–41 (image left, −x): outer corner, upper lid ×2, inner corner, lower ×2.
    let eye =
        [(-47.0, 32.0), (-40.0, 36.0), (-25.0, 36.0), (-17.0, 32.0), (-25.0, 28.0), (-40.0, 28.0)];
    t[36..42].copy_from_slice(&eye);
    // Left eye 42–47 mirrors it: 42 inner corner, 43–44 upper lid, 45 outer, 46–47 lower.
    let mirror = [3usize, 2, 1, 0, 5, 4];
    for (k, &m) in mirror.iter().enumerate() {
        t[42 + k] = (-eye[m].0, eye[m].1);
    }
    // Outer lip: 48 right corner, 49–53 along the upper border, 54 left corner, 55–59 lower.
    let border = |x: f64, upper: bool| {
        let (u, l) = lip_borders(x, cx_outer).unwrap_or((Y_MOUTH, Y_MOUTH));
        if upper { u } else { l }
    };
    let xs = [-0.62, -0.3, 0.0, 0.3, 0.62].map(|f| f * cx_outer);
    for (k, &x) in xs.iter().enumerate() {
        t[49 + k] = (x, border(x, true));
        t[59 - k] = (x, border(x, false));
    }
    t[48] = (-cx_outer, Y_MOUTH);
    t[54] = (cx_outer, Y_MOUTH);
    t
}

fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Builds the demo head.
pub fn build_head() -> Head {
    let centre = COLS / 2;
    let row_mouth = ((Y_MOUTH - Y_BOTTOM) / DY).round() as usize;
    let x_at = |row: usize, col: usize| {
        let y = Y_BOTTOM + row as f64 * DY;
        let u = -1.0 + 2.0 * col as f64 / (COLS - 1) as f64;
        (u * half_width(y), y)
    };
    let mut vertices = Vec::with_capacity(ROWS * COLS + 600);
    let mut lower = Vec::with_capacity(vertices.capacity());
    for row in 0..ROWS {
        for col in 0..COLS {
            let (x, y) = x_at(row, col);
            vertices.push(Point3::new(x, y, face_depth(x, y)));
            lower.push(y < Y_MOUTH - 1e-9);
        }
    }
    let grid = |row: usize, col: usize| (row * COLS + col) as u32;
    // The lower copy of the seam row between the inner corners.
    let (c0, c1) = (centre - INNER_CORNER_COLS, centre + INNER_CORNER_COLS);
    let mut seam_lower = vec![u32::MAX; COLS];
    for (col, slot) in seam_lower.iter_mut().enumerate().take(c1).skip(c0 + 1) {
        *slot = vertices.len() as u32;
        vertices.push(vertices[grid(row_mouth, col) as usize]);
        lower.push(true);
    }
    let mut faces: Vec<Vec<u32>> = Vec::with_capacity(2 * ROWS * COLS);
    for row in 0..ROWS - 1 {
        for col in 0..COLS - 1 {
            let (a, b) = (grid(row, col), grid(row, col + 1));
            let (mut c2, mut d2) = (grid(row + 1, col + 1), grid(row + 1, col));
            // Quads just below the seam use the lower copy of the seam row.
            if row + 1 == row_mouth {
                if seam_lower[col + 1] != u32::MAX {
                    c2 = seam_lower[col + 1];
                }
                if seam_lower[col] != u32::MAX {
                    d2 = seam_lower[col];
                }
            }
            // Split along the diagonal facing the centre so the halves mirror each other.
            if col < centre {
                faces.push(vec![a, b, c2]);
                faces.push(vec![a, c2, d2]);
            } else {
                faces.push(vec![a, b, d2]);
                faces.push(vec![b, c2, d2]);
            }
        }
    }
    let n_face = vertices.len();
    let cx_inner = x_at(row_mouth, c1).0;
    let cx_outer = x_at(row_mouth, centre + OUTER_CORNER_COLS).0;

    // The mouth cavity: a patch 9 mm behind the face, spanning the mouth with room to open.
    let (cav_cols, cav_rows) = (24usize, 19usize);
    let cav_base = vertices.len() as u32;
    for r in 0..cav_rows {
        for c in 0..cav_cols {
            let x = -(cx_outer + 5.0) + 2.0 * (cx_outer + 5.0) * c as f64 / (cav_cols - 1) as f64;
            let y = Y_MOUTH - 28.0 + 2.0 * r as f64;
            vertices.push(Point3::new(x, y, face_depth(x, y) - 9.0));
            lower.push(y < Y_MOUTH - 1e-9);
        }
    }
    for r in 0..cav_rows - 1 {
        for c in 0..cav_cols - 1 {
            let v = |rr: usize, cc: usize| cav_base + (rr * cav_cols + cc) as u32;
            faces.push(vec![v(r, c), v(r, c + 1), v(r + 1, c + 1)]);
            faces.push(vec![v(r, c), v(r + 1, c + 1), v(r + 1, c)]);
        }
    }
    let mut part = vec![Part::Face; n_face];
    part.resize(vertices.len(), Part::Cavity);

    // Colours: lips inside the vermilion borders, eyes, brows, skin elsewhere.
    let mut colours = Vec::with_capacity(vertices.len());
    let mut upper_lip = Vec::new();
    for (i, p) in vertices.iter().enumerate() {
        if part[i] == Part::Cavity {
            colours.push(MOUTH_INTERIOR);
            continue;
        }
        let (x, y) = (p.x, p.y);
        // Lip colour fades into skin over about a millimetre either side of the vermilion
        // border, so the 2 mm grid does not draw a staircase.
        let inside = lip_borders(x, cx_outer + 0.5).map_or(-10.0, |(up, lo)| (up - y).min(y - lo));
        let k = smoothstep((inside + 1.0) / 2.0);
        let mut c: [u8; 3] = std::array::from_fn(|ch| {
            (SKIN[ch] as f64 + k * (LIP[ch] as f64 - SKIN[ch] as f64)).round() as u8
        });
        if inside >= -0.5 && !lower[i] {
            upper_lip.push(i);
        }
        for side in [-1.0, 1.0] {
            let (ex, ey) = (side * 32.0, 32.0);
            let e = ((x - ex) / 15.5).powi(2) + ((y - ey) / 4.5).powi(2);
            if e <= 1.0 {
                c = if ((x - ex).powi(2) + (y - ey).powi(2)).sqrt() < 4.5 { IRIS } else { SCLERA };
            }
            // Brows: a band following the brow landmarks' arch.
            let bx = (x - side * 34.0) / 22.0;
            if bx.abs() <= 1.0 && (y - (53.0 - 8.0 * bx * bx)).abs() < 2.5 {
                c = BROW;
            }
        }
        colours.push(c);
    }

    // Landmarks: lips from the grid's own structure, the rest snapped to the nearest vertex.
    let mut to_vertex = std::collections::BTreeMap::new();
    let targets = landmark_targets(cx_outer);
    let nearest = |(x, y): (f64, f64), want_lower: Option<bool>| {
        (0..n_face)
            .filter(|&i| want_lower.is_none_or(|l| lower[i] == l))
            .min_by(|&a, &b| {
                let da = (vertices[a].x - x).powi(2) + (vertices[a].y - y).powi(2);
                let db = (vertices[b].x - x).powi(2) + (vertices[b].y - y).powi(2);
                da.total_cmp(&db)
            })
            .unwrap_or(0)
    };
    for (l, &target) in targets.iter().enumerate().skip(17).take(31) {
        to_vertex.insert(l, nearest(target, None));
    }
    for (l, &target) in targets.iter().enumerate().take(60).skip(49) {
        // 49–53 on the upper lip, 55–59 on the lower; 54 is the corner, set below.
        to_vertex.insert(l, nearest(target, Some(l > 54)));
    }
    to_vertex.insert(48, grid(row_mouth, centre - OUTER_CORNER_COLS) as usize);
    to_vertex.insert(54, grid(row_mouth, centre + OUTER_CORNER_COLS) as usize);
    let half = INNER_CORNER_COLS / 2;
    to_vertex.insert(60, grid(row_mouth, c0) as usize);
    to_vertex.insert(61, grid(row_mouth, centre - half) as usize);
    to_vertex.insert(62, grid(row_mouth, centre) as usize);
    to_vertex.insert(63, grid(row_mouth, centre + half) as usize);
    to_vertex.insert(64, grid(row_mouth, c1) as usize);
    to_vertex.insert(65, seam_lower[centre + half] as usize);
    to_vertex.insert(66, seam_lower[centre] as usize);
    to_vertex.insert(67, seam_lower[centre - half] as usize);
    for (l, v) in jaw_vertices(&vertices, row_mouth).into_iter().enumerate() {
        to_vertex.insert(l, v);
    }

    Head {
        mesh: Mesh { vertices, faces },
        colours,
        landmarks: LandmarkMap { to_vertex },
        lower,
        part,
        upper_lip,
        inner_corner_x: cx_inner,
        outer_corner_x: cx_outer,
    }
}

/// Jaw contour 0–16 on the face outline: from the right side at ear level (image left), down
/// round the chin (8, the gnathion, at the bottom centre) and up the left side, evenly spaced
/// by arc length along the grid's boundary.
fn jaw_vertices(vertices: &[Point3], _row_mouth: usize) -> [usize; 17] {
    let grid = |row: usize, col: usize| row * COLS + col;
    let top_row = ((12.0 - Y_BOTTOM) / DY).round() as usize;
    // Boundary path: left column from the top row down, then the bottom row to the centre.
    let mut path: Vec<usize> = (0..=top_row).rev().map(|r| grid(r, 0)).collect();
    path.extend((1..=COLS / 2).map(|c| grid(0, c)));
    let mut arc = vec![0.0];
    for w in path.windows(2) {
        let d = vertices[w[1]] - vertices[w[0]];
        let step = (d.x * d.x + d.y * d.y).sqrt();
        arc.push(arc.last().copied().unwrap_or(0.0) + step);
    }
    let total = arc.last().copied().unwrap_or(0.0);
    let mut out = [0usize; 17];
    for k in 0..=8 {
        let target = total * k as f64 / 8.0;
        let i = arc
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - target).abs().total_cmp(&(b.1 - target).abs()))
            .map_or(0, |(i, _)| i);
        let v = path[i];
        out[k] = v;
        // The mirror vertex: same row, mirrored column.
        let (row, col) = (v / COLS, v % COLS);
        out[16 - k] = grid(row, COLS - 1 - col);
    }
    out
}

/// Smooth 0→1 weight used by the articulation fields: 1 in the middle of the mouth, 0 at and
/// beyond the inner corners, so the corners (shared by both lips) never tear.
pub fn mouth_lateral_weight(x: f64, cx_inner: f64) -> f64 {
    smoothstep((cx_inner - x.abs()) / (0.5 * cx_inner))
}

/// How much a vertex moves with the jaw, in [0, 1]: lower-side vertices follow it fully in
/// the middle of the mouth and more with distance below the seam; upper-side ones not at all.
pub fn jaw_weight(x: f64, y: f64, lower: bool, cx_inner: f64) -> f64 {
    if !lower {
        return 0.0;
    }
    let lateral = mouth_lateral_weight(x, cx_inner);
    let below = smoothstep((Y_MOUTH - y) / 22.0);
    lateral.max(below)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_landmark_is_mapped_to_a_distinct_face_vertex() {
        let head = build_head();
        assert_eq!(head.landmarks.len(), N_LANDMARKS);
        let mut seen = std::collections::BTreeSet::new();
        for (l, v) in head.landmarks.pairs() {
            assert!(v < head.mesh.vertices.len(), "landmark {l}");
            assert_eq!(head.part[v], Part::Face, "landmark {l}");
            assert!(seen.insert(v), "landmark {l} shares vertex {v}");
        }
        assert_eq!(head.colours.len(), head.mesh.vertices.len());
        assert!(head.mesh.first_face_out_of_range().is_none());
    }

    #[test]
    fn the_neutral_mouth_is_closed_and_lips_are_lip_coloured() {
        let head = build_head();
        let p = |l: usize| head.mesh.vertices[head.landmarks.vertex(l).unwrap()];
        assert!((p(62) - p(66)).norm() < 1e-12);
        assert!(p(60).x < p(64).x && p(48).x < p(60).x && p(64).x < p(54).x);
        assert!(p(51).y > p(62).y + 5.0 && p(57).y < p(66).y - 5.0);
        assert!(p(30).z > p(51).z, "the nose tip is foremost");
        for l in [51, 57, 61, 62, 63, 65, 66, 67] {
            let c = head.colours[head.landmarks.vertex(l).unwrap()];
            let red = |c: [u8; 3]| c[0] as i32 - c[1] as i32;
            assert!(red(c) > red(SKIN) + 20, "landmark {l}: {c:?}");
        }
        assert!(!head.upper_lip.is_empty());
    }
}
