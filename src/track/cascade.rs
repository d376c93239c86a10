//! The cascade of regression trees (Kazemi & Sullivan, "One Millisecond Face Alignment with
//! an Ensemble of Regression Trees", CVPR 2014): from a start shape in a face box, each stage
//! reads its feature pixels at offsets anchored on the current shape (warped by the
//! similarity from the mean shape, §2.3.1), walks every tree of its forest by pixel-intensity
//! differences against thresholds (§2.3.2), and adds the leaves' shape increments (eq. 1).
//!
//! Everything is done as dlib's `shape_predictor::operator()` does it, so the same file gives
//! the same points: shapes live in the box-normalised frame, a feature pixel is the nearest
//! pixel (`floor(x + 0.5)`) of a grey image (`(r + g + b) / 3`, integer), 0 outside it, and
//! the increments are summed in `f32` in the trees' order.
//!
//! Two departures, both opt-in through [`CascadeStart`]: the cascade may start from any shape
//! (tracking from the previous frame, re-aligning a corrected frame) rather than the mean
//! shape, and points may be *held*: put on given positions before the first stage and after
//! every stage, so the trees see a face whose held points are where the user put them. With
//! a [`HeldCarry`] the other points are moved too, each time by the conditional mean of their
//! residual given the held points' (the predictor's own shape prior, `shape_prior`): the
//! user's correction at the start, then whatever each stage's trees undo of it (`realign`).

use super::predictor_file::{Forest, ShapePredictor, Stage};
use super::shape_prior::HeldCarry;
use super::similarity::{FaceBox, similarity_scaled_rotation};
use nalgebra::Vector2;

/// A grey 8-bit image borrowed row-major (`width · height` bytes).
#[derive(Clone, Copy, Debug)]
pub struct GrayView<'a> {
    pub width: usize,
    pub height: usize,
    pub pixels: &'a [u8],
}

impl GrayView<'_> {
    /// The pixel nearest `p` (dlib's rounding), 0 outside the image.
    #[inline]
    fn nearest(&self, p: Vector2<f64>) -> f32 {
        let (x, y) = ((p.x + 0.5).floor(), (p.y + 0.5).floor());
        if x >= 0.0 && y >= 0.0 && x < self.width as f64 && y < self.height as f64 {
            f32::from(self.pixels[y as usize * self.width + x as usize])
        } else {
            0.0
        }
    }
}

/// A grey 8-bit image owned row-major.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrayImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<u8>,
}

impl GrayImage {
    /// An RGB image (3 bytes per pixel, row-major) in dlib's grey levels.
    pub fn from_rgb(width: usize, height: usize, rgb: &[u8]) -> Self {
        Self { width, height, pixels: gray_from_rgb(rgb) }
    }

    pub fn view(&self) -> GrayView<'_> {
        GrayView { width: self.width, height: self.height, pixels: &self.pixels }
    }
}

/// An RGB image's grey levels as dlib computes them: `(r + g + b) / 3`, rounded down.
pub fn gray_from_rgb(rgb: &[u8]) -> Vec<u8> {
    rgb.chunks_exact(3)
        .map(|p| ((u16::from(p[0]) + u16::from(p[1]) + u16::from(p[2])) / 3) as u8)
        .collect()
}

/// Where the cascade starts and which points it keeps fixed.
#[derive(Clone, Debug, Default)]
pub struct CascadeStart<'a> {
    /// The start shape in pixels (`None`: the mean shape placed in the box, as dlib does).
    pub shape: Option<&'a [Vector2<f64>]>,
    /// Points put on these pixel positions before the first stage and after every stage.
    pub held: &'a [(usize, Vector2<f64>)],
    /// How the other points move with the held ones (`None`: they do not). Used only when
    /// it was made for exactly the held points, in their order.
    pub carry: Option<&'a HeldCarry>,
}

/// Runs the whole cascade on `image` in `face`, from `start`, and returns the shape in
/// pixels. Held indices past the shape are ignored; a start shape of the wrong length is
/// replaced by the mean shape.
pub fn run_cascade(
    predictor: &ShapePredictor,
    image: GrayView<'_>,
    face: &FaceBox,
    start: &CascadeStart<'_>,
) -> Vec<Vector2<f64>> {
    let n = predictor.num_parts();
    let mut shape: Vec<f32> = match start.shape {
        Some(s) if s.len() == n => s
            .iter()
            .flat_map(|&p| {
                let q = face.to_normalised(p);
                [q.x, q.y]
            })
            .collect(),
        _ => predictor.mean_shape.iter().flat_map(|p| [p.x, p.y]).collect(),
    };
    let (indices, targets): (Vec<usize>, Vec<Vector2<f32>>) =
        start.held.iter().filter(|(i, _)| *i < n).map(|&(i, p)| (i, face.to_normalised(p))).unzip();
    let carry = start.carry.filter(|c| c.held() == indices.as_slice());
    // `after`: the stage whose trees just ran (`None` before the first).
    let hold = |shape: &mut [f32], after: Option<usize>| match carry {
        Some(c) => c.carry(after, shape, &targets),
        None => {
            for (&i, p) in indices.iter().zip(&targets) {
                shape[2 * i] = p.x;
                shape[2 * i + 1] = p.y;
            }
        }
    };
    hold(&mut shape, None);
    let mut scratch = Scratch::default();
    for (t, stage) in predictor.stages.iter().enumerate() {
        feature_pixels(predictor, stage, image, face, &shape, &mut scratch);
        add_forest(&stage.trees, &scratch.features, &mut shape, &mut scratch.leaf_at);
        hold(&mut shape, Some(t));
    }
    shape.chunks_exact(2).map(|p| face.to_image(Vector2::new(p[0], p[1]))).collect()
}

/// Buffers a run reuses from stage to stage.
#[derive(Default)]
struct Scratch {
    /// The current shape as points.
    current: Vec<Vector2<f32>>,
    /// The stage's feature pixel intensities.
    features: Vec<f32>,
    /// Per tree, where the leaf it reached starts in the stage's leaves.
    leaf_at: Vec<usize>,
}

/// The intensities of a stage's feature pixels for the current `shape` (flat x, y pairs in
/// the box-normalised frame), into `scratch.features`.
fn feature_pixels(
    predictor: &ShapePredictor,
    stage: &Stage,
    image: GrayView<'_>,
    face: &FaceBox,
    shape: &[f32],
    scratch: &mut Scratch,
) {
    let current = &mut scratch.current;
    current.clear();
    current.extend(shape.chunks_exact(2).map(|p| Vector2::new(p[0], p[1])));
    let warp = similarity_scaled_rotation(&predictor.mean_shape, current);
    let out = &mut scratch.features;
    out.clear();
    out.extend(stage.anchors.iter().zip(&stage.offsets).map(|(&a, d)| {
        let p = warp * d + current[a as usize];
        image.nearest(face.to_image(p))
    }));
}

/// Trees whose leaves are added together, element by element: the leaves of a group are
/// fetched at once (each tree's is somewhere in the stage's megabytes, so a leaf at a time
/// waits on memory for each), while every element still gets its increments in the trees'
/// order, as dlib sums them.
const LEAF_GROUP: usize = 8;

/// Adds the leaf each tree of the forest reaches on `features` to `shape`: first every
/// tree is walked (its splits are contiguous), then the reached leaves are summed.
fn add_forest(forest: &Forest, features: &[f32], shape: &mut [f32], leaf_at: &mut Vec<usize>) {
    let len = shape.len();
    leaf_at.clear();
    let mut start = 0;
    for tree in forest.iter() {
        let n_splits = tree.splits.len();
        let mut i = 0;
        while i < n_splits {
            let s = &tree.splits[i];
            i = if features[s.a as usize] - features[s.b as usize] > s.threshold {
                2 * i + 1
            } else {
                2 * i + 2
            };
        }
        leaf_at.push(start + (i - n_splits) * len);
        start += tree.leaves.len();
    }
    let leaves = forest.all_leaves();
    let mut groups = leaf_at.chunks_exact(LEAF_GROUP);
    for g in &mut groups {
        let group: [&[f32]; LEAF_GROUP] = std::array::from_fn(|k| &leaves[g[k]..g[k] + len]);
        for (j, v) in shape.iter_mut().enumerate() {
            let mut acc = *v;
            for leaf in &group {
                acc += leaf[j];
            }
            *v = acc;
        }
    }
    for &at in groups.remainder() {
        for (v, d) in shape.iter_mut().zip(&leaves[at..at + len]) {
            *v += d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::predictor_file::{Split, Tree};

    /// One point, one stage, two feature pixels left and right of it: the tree moves the
    /// point toward the brighter side.
    fn seeker() -> ShapePredictor {
        ShapePredictor {
            mean_shape: vec![Vector2::new(0.5, 0.5)],
            stages: vec![
                Stage {
                    anchors: vec![0, 0],
                    offsets: vec![Vector2::new(-0.2, 0.0), Vector2::new(0.2, 0.0)],
                    trees: [Tree {
                        splits: vec![Split { a: 0, b: 1, threshold: 10.0 }],
                        leaves: vec![-0.1, 0.0, 0.1, 0.0],
                    }]
                    .into_iter()
                    .collect(),
                };
                3
            ],
        }
    }

    fn image_bright_right_of(x0: usize) -> (Vec<u8>, usize, usize) {
        let (w, h) = (100, 50);
        let px = (0..w * h).map(|i| if i % w >= x0 { 200 } else { 20 }).collect();
        (px, w, h)
    }

    #[test]
    fn the_trees_walk_the_shape_toward_the_evidence() {
        let (px, width, height) = image_bright_right_of(70);
        let img = GrayView { width, height, pixels: &px };
        let face = FaceBox { left: 0.0, top: 0.0, width: 100.0, height: 50.0 };
        let out = run_cascade(&seeker(), img, &face, &CascadeStart::default());
        // From x = 50: 50+20 = 70 is bright, so each of 3 stages moves it right by 10 px.
        assert!((out[0].x - 80.0).abs() < 1e-4, "{:?}", out[0]);
        let held = [(0, Vector2::new(42.0, 25.0))];
        let start = CascadeStart { shape: None, held: &held, carry: None };
        let out = run_cascade(&seeker(), img, &face, &start);
        assert!((out[0] - held[0].1).norm() < 1e-4);
    }

    #[test]
    fn grouped_leaves_sum_bit_for_bit_as_one_tree_after_another() {
        // 21 depth-2 trees (two groups and a remainder) over 3 points, leaves of mixed
        // magnitudes so that the order of the f32 additions shows in the last bits.
        let (len, n_trees) = (6, 21);
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let trees: Vec<Tree> = (0..n_trees)
            .map(|t| Tree {
                splits: (0..3)
                    .map(|k| Split {
                        a: (t + k) as u32 % 4,
                        b: (t * 3 + k) as u32 % 4,
                        threshold: next(),
                    })
                    .collect(),
                leaves: (0..4 * len).map(|i| next() * 10f32.powi(i as i32 % 5 - 2)).collect(),
            })
            .collect();
        let forest: Forest = trees.clone().into_iter().collect();
        let features = [0.3f32, -0.2, 0.05, 0.4];
        let mut shape: Vec<f32> = (0..len).map(|i| i as f32 * 0.1).collect();
        let mut expected = shape.clone();
        for t in &trees {
            let mut i = 0;
            while i < 3 {
                let s = &t.splits[i];
                i = if features[s.a as usize] - features[s.b as usize] > s.threshold {
                    2 * i + 1
                } else {
                    2 * i + 2
                };
            }
            for (v, d) in expected.iter_mut().zip(&t.leaves[(i - 3) * len..(i - 2) * len]) {
                *v += d;
            }
        }
        add_forest(&forest, &features, &mut shape, &mut Vec::new());
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&shape), bits(&expected));
    }

    #[test]
    fn pixels_outside_the_image_read_zero_and_grey_is_dlibs_mean() {
        let px = [9u8; 4];
        let img = GrayView { width: 2, height: 2, pixels: &px };
        assert_eq!(img.nearest(Vector2::new(1.49, 1.2)), 9.0);
        assert_eq!(img.nearest(Vector2::new(1.5, 0.0)), 0.0);
        assert_eq!(img.nearest(Vector2::new(-0.51, 0.0)), 0.0);
        assert_eq!(gray_from_rgb(&[255, 255, 254, 1, 1, 0]), [254, 0]);
    }
}
