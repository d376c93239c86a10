//! Articulation of the demo head: eight articulatory parameters (jaw opening, lip spread,
//! rounding, protrusion, lip raise/drop, lower-lip tuck, lip press), their displacement
//! fields, the 16 viseme targets and the 161 pose meshes (neutral + 16 × 10 intensities).
//!
//! Every parameter moves the vertices along a fixed field computed from the rest head, so a
//! posed mesh is `rest + Σ p_k·D_k`: linear in the parameters. That keeps the pose set's PCA
//! exact (every coarticulated frame lies in the span of the poses), so the demo tests the
//! fitter, not the model's ability to represent the speaker. The jaw field is the linearised
//! rotation about the hinge, accurate to a few per cent at the largest openings used (13°).

use super::head::{Head, JAW_PIVOT, Part, Y_MOUTH, jaw_weight, mouth_lateral_weight};
use crate::math::{Point3, Vector3};
use crate::model::Mesh;

/// Number of articulatory parameters.
pub const N_PARAMS: usize = 8;

/// Articulatory parameters of one mouth shape. Units: degrees for the jaw, millimetres of
/// movement (at the mouth corners or lip midline) for the rest.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Articulation {
    /// Jaw opening about the hinge, degrees.
    pub jaw_deg: f64,
    /// Each mouth corner moves outward (and a little back) by this many mm.
    pub spread_mm: f64,
    /// Each mouth corner moves inward by this many mm (lip rounding).
    pub round_mm: f64,
    /// The lips move forward by this many mm at the midline.
    pub protrude_mm: f64,
    /// The upper lip's inner edge rises (without the jaw).
    pub upper_raise_mm: f64,
    /// The lower lip's inner edge drops (without the jaw).
    pub lower_drop_mm: f64,
    /// The lower lip moves up and back under the upper teeth (labiodentals).
    pub tuck_mm: f64,
    /// The lips press together and thin (bilabial closure).
    pub press_mm: f64,
}

/// Parameter names, in array order (used in truth files).
pub const PARAM_NAMES: [&str; N_PARAMS] = [
    "jaw_deg",
    "spread_mm",
    "round_mm",
    "protrude_mm",
    "upper_raise_mm",
    "lower_drop_mm",
    "tuck_mm",
    "press_mm",
];

impl Articulation {
    pub fn to_array(self) -> [f64; N_PARAMS] {
        [
            self.jaw_deg,
            self.spread_mm,
            self.round_mm,
            self.protrude_mm,
            self.upper_raise_mm,
            self.lower_drop_mm,
            self.tuck_mm,
            self.press_mm,
        ]
    }

    pub fn from_array(a: [f64; N_PARAMS]) -> Self {
        Self {
            jaw_deg: a[0],
            spread_mm: a[1],
            round_mm: a[2],
            protrude_mm: a[3],
            upper_raise_mm: a[4],
            lower_drop_mm: a[5],
            tuck_mm: a[6],
            press_mm: a[7],
        }
    }

    /// This shape scaled by `k` (intensity 0..1).
    pub fn scaled(self, k: f64) -> Self {
        Self::from_array(self.to_array().map(|v| v * k))
    }
}

/// The 16 viseme classes of the demo, with the ARPAbet phones each covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Viseme {
    /// B P M: lips closed and pressed.
    Pbm,
    /// F V: lower lip under the upper teeth.
    Fv,
    /// TH DH.
    Th,
    /// T D N.
    Tdn,
    /// L.
    L,
    /// S Z: teeth together, lips spread.
    Sz,
    /// SH ZH CH JH: lips rounded and protruded.
    Sh,
    /// K G NG HH.
    Kg,
    /// R ER.
    R,
    /// W.
    W,
    /// IY IH Y: spread, nearly closed.
    Iy,
    /// EH EY AE.
    Eh,
    /// AA AH: wide open.
    Aa,
    /// AY AW OY.
    Ay,
    /// AO OW: open and rounded.
    Ao,
    /// UW UH: close and rounded, protruded.
    Uw,
}

impl Viseme {
    pub const ALL: [Viseme; 16] = [
        Viseme::Pbm,
        Viseme::Fv,
        Viseme::Th,
        Viseme::Tdn,
        Viseme::L,
        Viseme::Sz,
        Viseme::Sh,
        Viseme::Kg,
        Viseme::R,
        Viseme::W,
        Viseme::Iy,
        Viseme::Eh,
        Viseme::Aa,
        Viseme::Ay,
        Viseme::Ao,
        Viseme::Uw,
    ];

    /// Short lower-case name (`pbm`, `fv`, …).
    pub fn name(self) -> &'static str {
        match self {
            Viseme::Pbm => "pbm",
            Viseme::Fv => "fv",
            Viseme::Th => "th",
            Viseme::Tdn => "tdn",
            Viseme::L => "l",
            Viseme::Sz => "sz",
            Viseme::Sh => "sh",
            Viseme::Kg => "kg",
            Viseme::R => "r",
            Viseme::W => "w",
            Viseme::Iy => "iy",
            Viseme::Eh => "eh",
            Viseme::Aa => "aa",
            Viseme::Ay => "ay",
            Viseme::Ao => "ao",
            Viseme::Uw => "uw",
        }
    }

    /// The full-intensity mouth shape of this viseme.
    pub fn target(self) -> Articulation {
        let a = |jaw, spread, round, protrude, up, down, tuck, press| Articulation {
            jaw_deg: jaw,
            spread_mm: spread,
            round_mm: round,
            protrude_mm: protrude,
            upper_raise_mm: up,
            lower_drop_mm: down,
            tuck_mm: tuck,
            press_mm: press,
        };
        match self {
            Viseme::Pbm => a(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.5),
            Viseme::Fv => a(3.0, 0.5, 0.0, 0.0, 0.5, 0.0, 4.0, 0.0),
            Viseme::Th => a(4.0, 1.5, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0),
            Viseme::Tdn => a(3.5, 1.5, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0),
            Viseme::L => a(5.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0),
            Viseme::Sz => a(2.0, 3.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0),
            Viseme::Sh => a(3.0, 0.0, 3.0, 4.0, 1.5, 1.5, 0.0, 0.0),
            Viseme::Kg => a(6.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0),
            Viseme::R => a(4.0, 0.0, 3.0, 3.0, 0.5, 0.0, 0.0, 0.0),
            Viseme::W => a(2.0, 0.0, 6.0, 6.0, 0.0, 0.0, 0.0, 0.0),
            Viseme::Iy => a(4.0, 5.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
            Viseme::Eh => a(8.0, 3.5, 0.0, 0.0, 1.5, 0.5, 0.0, 0.0),
            Viseme::Aa => a(13.0, 1.5, 0.0, 0.0, 2.0, 1.0, 0.0, 0.0),
            Viseme::Ay => a(11.0, 2.0, 0.0, 0.0, 1.5, 1.0, 0.0, 0.0),
            Viseme::Ao => a(9.0, 0.0, 4.5, 4.0, 0.5, 1.0, 0.0, 0.0),
            Viseme::Uw => a(4.0, 0.0, 6.5, 7.0, 0.0, 0.0, 0.0, 0.0),
        }
    }
}

/// The viseme of an ARPAbet phone (stress digits ignored); `None` for silence or unknown.
pub fn phone_viseme(phone: &str) -> Option<Viseme> {
    let p = crate::alignment::PhoneInventory::default().key_of(phone);
    Some(match p.as_str() {
        "B" | "P" | "M" => Viseme::Pbm,
        "F" | "V" => Viseme::Fv,
        "TH" | "DH" => Viseme::Th,
        "T" | "D" | "N" => Viseme::Tdn,
        "L" => Viseme::L,
        "S" | "Z" => Viseme::Sz,
        "SH" | "ZH" | "CH" | "JH" => Viseme::Sh,
        "K" | "G" | "NG" | "HH" => Viseme::Kg,
        "R" | "ER" => Viseme::R,
        "W" => Viseme::W,
        "IY" | "IH" | "Y" => Viseme::Iy,
        "EH" | "EY" | "AE" => Viseme::Eh,
        "AA" | "AH" => Viseme::Aa,
        "AY" | "AW" | "OY" => Viseme::Ay,
        "AO" | "OW" => Viseme::Ao,
        "UW" | "UH" => Viseme::Uw,
        _ => return None,
    })
}

/// The per-parameter displacement fields of a head: `fields[k][v]` is vertex v's movement
/// (mm) per unit of parameter k.
#[derive(Clone, Debug)]
pub struct ArticulationFields {
    pub fields: Vec<Vec<Vector3>>,
}

impl ArticulationFields {
    /// The fields of `head`, computed from its rest positions.
    pub fn new(head: &Head) -> Self {
        let cxi = head.inner_corner_x;
        let cxo = head.outer_corner_x;
        let n = head.mesh.vertices.len();
        let mut fields = vec![vec![Vector3::zeros(); n]; N_PARAMS];
        let g = |d: f64, s: f64| (-(d / s).powi(2)).exp();
        for (v, p) in head.mesh.vertices.iter().enumerate() {
            let (x, y, z) = (p.x, p.y, p.z);
            let dy = y - Y_MOUTH;
            let lower = head.lower[v];
            let sign = if x < 0.0 { -1.0 } else { 1.0 };
            // Jaw: linearised rotation about the hinge's x axis, per degree. A rotation by α
            // moves (y, z) by α·(−(z − zp), y − yp): the chin goes down and back.
            let w = jaw_weight(x, y, lower, cxi);
            let (yp, zp) = JAW_PIVOT;
            fields[0][v] =
                Vector3::new(0.0, -(z - zp), y - yp) * (w * std::f64::consts::PI / 180.0);
            // Spread/rounding: corners move 1 mm per unit, the mouth's middle proportionally,
            // fading beyond the corners and away from the seam.
            let lateral = if x.abs() <= cxi { x.abs() / cxi } else { g(x.abs() - cxi, 14.0) };
            let s = lateral * g(dy, 13.0);
            fields[1][v] = Vector3::new(sign * s, 0.0, -0.35 * s);
            // Rounding pulls the corners in and pushes the lips' middle out a little.
            let lip_body = (-(x / (cxo + 4.0)).powi(4)).exp() * g(dy, 12.0);
            fields[2][v] = Vector3::new(-sign * s, 0.0, 0.3 * lip_body);
            // Protrusion: the lips move forward, most at the midline, and evert: the
            // vermilion borders roll outward (up for the upper lip, down for the lower) while
            // the seam stays, so a frontal camera sees protrusion as fuller lips, as it does
            // on real speakers. Without that P would be invisible in the front view.
            let evert = (-(x / (cxo + 2.0)).powi(4)).exp() * (dy / 9.0) * g(dy, 9.0) * 0.5;
            fields[3][v] = Vector3::new(-0.12 * sign * s, evert, lip_body);
            // The inner lip edges move apart without the jaw; zero at the corners.
            let mid = mouth_lateral_weight(x, cxi);
            if !lower && dy >= 0.0 {
                fields[4][v] = Vector3::new(0.0, mid * g(dy, 9.0), 0.0);
            }
            if lower {
                fields[5][v] = Vector3::new(0.0, -mid * g(dy, 9.0), 0.0);
                fields[6][v] = Vector3::new(0.0, mid * g(dy, 9.0), -0.8 * mid * g(dy, 9.0));
            }
            // Press: the vermilion borders move towards the seam (the lips thin), the seam
            // itself stays, so a closed mouth stays closed.
            let thin = (-(x / (cxo + 2.0)).powi(4)).exp() * (dy / 9.0) * g(dy, 9.0) * 1.6;
            fields[7][v] = Vector3::new(0.0, -thin, -0.3 * lip_body);
            if head.part[v] == Part::Cavity {
                // The cavity follows the lips but not their thinning.
                fields[7][v] = Vector3::zeros();
            }
        }
        Self { fields }
    }

    /// The rest vertices moved by `a`.
    pub fn apply(&self, rest: &[Point3], a: &Articulation) -> Vec<Point3> {
        let params = a.to_array();
        rest.iter()
            .enumerate()
            .map(|(v, p)| {
                let mut q = *p;
                for (k, &pk) in params.iter().enumerate() {
                    if pk != 0.0 {
                        q += self.fields[k][v] * pk;
                    }
                }
                q
            })
            .collect()
    }
}

/// Number of intensities per viseme in the pose set.
pub const INTENSITIES: usize = 10;

/// The pose set: neutral first, then for each viseme in [`Viseme::ALL`] order its intensities
/// 1/10 … 10/10: `1 + 16·10 = 161` shapes with the head's topology. Also returns each pose's
/// label (`neutral`, `aa_07`, …).
pub fn pose_meshes(head: &Head, fields: &ArticulationFields) -> Vec<(String, Mesh)> {
    let mut out = Vec::with_capacity(1 + Viseme::ALL.len() * INTENSITIES);
    out.push(("neutral".to_string(), head.mesh.clone()));
    for v in Viseme::ALL {
        for i in 1..=INTENSITIES {
            let a = v.target().scaled(i as f64 / INTENSITIES as f64);
            let vertices = fields.apply(&head.mesh.vertices, &a);
            let mesh = Mesh { vertices, faces: head.mesh.faces.clone() };
            out.push((format!("{}_{i:02}", v.name()), mesh));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::head::build_head;

    #[test]
    fn every_grid_phone_has_a_viseme() {
        for p in ["B", "IH1", "N", "UW0", "AY1", "DH", "JH", "sil"] {
            assert_eq!(phone_viseme(p).is_some(), p != "sil", "{p}");
        }
    }

    #[test]
    fn jaw_opens_the_mouth_and_spread_widens_it() {
        let head = build_head();
        let f = ArticulationFields::new(&head);
        let lm = |vs: &[Point3], l: usize| vs[head.landmarks.vertex(l).unwrap()];
        let open = f.apply(&head.mesh.vertices, &Viseme::Aa.target());
        let h = (lm(&open, 62) - lm(&open, 66)).norm();
        assert!((15.0..30.0).contains(&h), "open height {h}");
        let pbm = f.apply(&head.mesh.vertices, &Viseme::Pbm.target());
        assert!((lm(&pbm, 62) - lm(&pbm, 66)).norm() < 1e-9);
        let iy = f.apply(&head.mesh.vertices, &Viseme::Iy.target());
        let w0 = (lm(&head.mesh.vertices, 60) - lm(&head.mesh.vertices, 64)).norm();
        let w1 = (lm(&iy, 60) - lm(&iy, 64)).norm();
        assert!((w1 - w0 - 10.0).abs() < 0.5, "spread {w0} -> {w1}");
        let uw = f.apply(&head.mesh.vertices, &Viseme::Uw.target());
        assert!(lm(&uw, 51).z > lm(&head.mesh.vertices, 51).z + 5.0);
    }

    #[test]
    fn pose_set_has_161_meshes_of_one_topology() {
        let head = build_head();
        let poses = pose_meshes(&head, &ArticulationFields::new(&head));
        assert_eq!(poses.len(), 161);
        assert!(poses.iter().all(
            |(_, m)| m.faces == head.mesh.faces && m.vertices.len() == head.mesh.vertices.len()
        ));
        assert_eq!(poses[10].0, "pbm_10");
    }
}
