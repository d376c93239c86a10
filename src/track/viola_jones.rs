//! Face detection with a Viola–Jones cascade (P. Viola and M. Jones, "Rapid Object Detection
//! using a Boosted Cascade of Simple Features", CVPR 2001; R. Lienhart and J. Maydt's
//! extended feature set, ICIP 2002, whose cascades Debian's `opencv-data` ships).
//!
//! The image is scanned at scales `1, f, f², …` by shrinking it (bilinear) rather than
//! growing the features, so every feature keeps its exact integer rectangles; on each level
//! an integral image and an integral of squares give any rectangle sum in four look-ups
//! (§2.1). A window is normalised by its standard deviation over the window less a one-pixel
//! border (as OpenCV's evaluator does) and must pass every stage (§4). Overlapping hits are
//! grouped as OpenCV's `groupRectangles` does (clusters of similar boxes, kept when they
//! have more than `min_neighbors` members, averaged).

use super::cascade::GrayView;
use super::haar_file::{HaarCascade, WeakClassifier};
use super::similarity::FaceBox;

/// How to scan for faces.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectOptions {
    /// Scale step between pyramid levels (OpenCV's default 1.1).
    pub scale_factor: f64,
    /// A face is kept when more than this many windows agree on it (OpenCV's default 3).
    pub min_neighbors: usize,
    /// Smallest face side searched, in pixels (`None`: the cascade's window).
    pub min_size: Option<f64>,
    /// Largest face side searched, in pixels (`None`: the image).
    pub max_size: Option<f64>,
    /// Only windows whose centre lies in this region are scanned (`None`: the whole image).
    pub region: Option<FaceBox>,
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self { scale_factor: 1.1, min_size: None, max_size: None, min_neighbors: 3, region: None }
    }
}

/// A detected face: its box (square, in image pixels) and how many windows supported it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Detection {
    pub face: FaceBox,
    pub neighbors: usize,
}

/// Sums and sums of squares over rectangles of one image, in O(1) each.
struct Integral {
    width: usize,
    sum: Vec<i64>,
    sq: Vec<f64>,
}

impl Integral {
    fn new(pixels: &[u8], width: usize, height: usize) -> Self {
        let stride = width + 1;
        let mut sum = vec![0i64; stride * (height + 1)];
        let mut sq = vec![0f64; stride * (height + 1)];
        for y in 0..height {
            let (mut row, mut row_sq) = (0i64, 0f64);
            for x in 0..width {
                let v = i64::from(pixels[y * width + x]);
                row += v;
                row_sq += (v * v) as f64;
                sum[(y + 1) * stride + x + 1] = sum[y * stride + x + 1] + row;
                sq[(y + 1) * stride + x + 1] = sq[y * stride + x + 1] + row_sq;
            }
        }
        Self { width, sum, sq }
    }

    #[inline]
    fn rect(&self, x: usize, y: usize, w: usize, h: usize) -> i64 {
        let s = self.width + 1;
        self.sum[(y + h) * s + x + w] - self.sum[y * s + x + w] - self.sum[(y + h) * s + x]
            + self.sum[y * s + x]
    }

    #[inline]
    fn rect_sq(&self, x: usize, y: usize, w: usize, h: usize) -> f64 {
        let s = self.width + 1;
        self.sq[(y + h) * s + x + w] - self.sq[y * s + x + w] - self.sq[(y + h) * s + x]
            + self.sq[y * s + x]
    }
}

/// `image` shrunk by `scale` (≥ 1) with bilinear interpolation, pixel centres aligned.
fn shrink(image: GrayView<'_>, scale: f64) -> (Vec<u8>, usize, usize) {
    let w = ((image.width as f64 / scale).round() as usize).max(1);
    let h = ((image.height as f64 / scale).round() as usize).max(1);
    let mut out = vec![0u8; w * h];
    let sx = image.width as f64 / w as f64;
    let sy = image.height as f64 / h as f64;
    for y in 0..h {
        let fy = ((y as f64 + 0.5) * sy - 0.5).clamp(0.0, (image.height - 1) as f64);
        let (y0, ty) = (fy.floor() as usize, fy - fy.floor());
        let y1 = (y0 + 1).min(image.height - 1);
        for x in 0..w {
            let fx = ((x as f64 + 0.5) * sx - 0.5).clamp(0.0, (image.width - 1) as f64);
            let (x0, tx) = (fx.floor() as usize, fx - fx.floor());
            let x1 = (x0 + 1).min(image.width - 1);
            let p = |xx: usize, yy: usize| f64::from(image.pixels[yy * image.width + xx]);
            let top = p(x0, y0) * (1.0 - tx) + p(x1, y0) * tx;
            let bottom = p(x0, y1) * (1.0 - tx) + p(x1, y1) * tx;
            out[y * w + x] = (top * (1.0 - ty) + bottom * ty).round() as u8;
        }
    }
    (out, w, h)
}

/// Faces in `image`, most supported first.
pub fn detect_faces(
    cascade: &HaarCascade,
    image: GrayView<'_>,
    opts: &DetectOptions,
) -> Vec<Detection> {
    let [ww, wh] = cascade.window.map(|v| v as usize);
    let factor = opts.scale_factor.max(1.01);
    let base = ww.max(wh) as f64;
    let mut scale = opts.min_size.map_or(1.0, |m| (m / base).max(1.0));
    let max_side = opts.max_size.unwrap_or(f64::INFINITY);
    let mut hits = Vec::new();
    while image.width as f64 / scale >= ww as f64 && image.height as f64 / scale >= wh as f64 {
        if base * scale > max_side {
            break;
        }
        let (small, w, h) = if scale == 1.0 {
            (image.pixels.to_vec(), image.width, image.height)
        } else {
            shrink(image, scale)
        };
        let integral = Integral::new(&small, w, h);
        // OpenCV's step: every other window on fine levels, every window on coarse ones.
        let step = if scale > 2.0 { 1 } else { 2 };
        let (sx, sy) = (image.width as f64 / w as f64, image.height as f64 / h as f64);
        for y in (0..=h.saturating_sub(wh)).step_by(step) {
            for x in (0..=w.saturating_sub(ww)).step_by(step) {
                if let Some(r) = &opts.region {
                    let cx = (x as f64 + ww as f64 / 2.0) * sx;
                    let cy = (y as f64 + wh as f64 / 2.0) * sy;
                    if cx < r.left || cy < r.top || cx > r.left + r.width || cy > r.top + r.height {
                        continue;
                    }
                }
                if window_passes(cascade, &integral, x, y) {
                    hits.push(FaceBox {
                        left: x as f64 * sx,
                        top: y as f64 * sy,
                        width: ww as f64 * sx,
                        height: wh as f64 * sy,
                    });
                }
            }
        }
        scale *= factor;
    }
    group_detections(&hits, opts.min_neighbors, 0.2)
}

/// Whether the window at (`x`, `y`) passes every stage.
fn window_passes(cascade: &HaarCascade, ii: &Integral, x: usize, y: usize) -> bool {
    let [ww, wh] = cascade.window.map(|v| v as usize);
    let (nw, nh) = (ww - 2, wh - 2);
    let area = (nw * nh) as f64;
    let s = ii.rect(x + 1, y + 1, nw, nh) as f64;
    let q = ii.rect_sq(x + 1, y + 1, nw, nh);
    let var = area * q - s * s;
    let norm = if var > 0.0 { var.sqrt() } else { 1.0 };
    cascade.stages.iter().all(|stage| {
        let total: f32 =
            stage.classifiers.iter().map(|c| weak_value(cascade, c, ii, x, y, norm)).sum();
        total >= stage.threshold
    })
}

/// The leaf value a weak classifier gives the window.
fn weak_value(
    cascade: &HaarCascade,
    c: &WeakClassifier,
    ii: &Integral,
    x: usize,
    y: usize,
    norm: f64,
) -> f32 {
    let mut node = 0usize;
    loop {
        let n = &c.nodes[node];
        let value: f64 = cascade.features[n.feature as usize]
            .iter()
            .map(|r| {
                f64::from(r.weight)
                    * ii.rect(x + r.x as usize, y + r.y as usize, r.w as usize, r.h as usize) as f64
            })
            .sum();
        let next = if value < f64::from(n.threshold) * norm { n.left } else { n.right };
        if next <= 0 {
            return c.leaves[(-next) as usize];
        }
        node = next as usize;
    }
}

/// Clusters of similar boxes (corners within `eps` of the smaller box's mean side), kept
/// when they have more than `min_neighbors` members, averaged; a kept box inside a better
/// supported one is dropped. Most supported first.
pub fn group_detections(hits: &[FaceBox], min_neighbors: usize, eps: f64) -> Vec<Detection> {
    let n = hits.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let similar = |a: &FaceBox, b: &FaceBox| {
        let delta = eps * (a.width.min(b.width) + a.height.min(b.height)) * 0.5;
        (a.left - b.left).abs() <= delta
            && (a.top - b.top).abs() <= delta
            && (a.left + a.width - b.left - b.width).abs() <= delta
            && (a.top + a.height - b.top - b.height).abs() <= delta
    };
    for i in 0..n {
        for j in i + 1..n {
            if similar(&hits[i], &hits[j]) {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                parent[a] = b;
            }
        }
    }
    let mut clusters: std::collections::BTreeMap<usize, (FaceBox, usize)> = Default::default();
    for (i, h) in hits.iter().enumerate() {
        let r = root(&mut parent, i);
        let e = clusters
            .entry(r)
            .or_insert((FaceBox { left: 0.0, top: 0.0, width: 0.0, height: 0.0 }, 0));
        e.0.left += h.left;
        e.0.top += h.top;
        e.0.width += h.width;
        e.0.height += h.height;
        e.1 += 1;
    }
    let kept: Vec<Detection> = clusters
        .into_values()
        .filter(|(_, k)| *k > min_neighbors)
        .map(|(b, k)| {
            let k_f = k as f64;
            Detection {
                face: FaceBox {
                    left: b.left / k_f,
                    top: b.top / k_f,
                    width: b.width / k_f,
                    height: b.height / k_f,
                },
                neighbors: k,
            }
        })
        .collect();
    let mut out: Vec<Detection> = kept
        .iter()
        .filter(|d| {
            !kept.iter().any(|o| {
                let (dx, dy) = (o.face.width * eps, o.face.height * eps);
                !std::ptr::eq(*d, o)
                    && d.face.left >= o.face.left - dx
                    && d.face.top >= o.face.top - dy
                    && d.face.left + d.face.width <= o.face.left + o.face.width + dx
                    && d.face.top + d.face.height <= o.face.top + o.face.height + dy
                    && (o.neighbors > d.neighbors.max(3) || d.neighbors < 3)
            })
        })
        .copied()
        .collect();
    out.sort_by_key(|b| std::cmp::Reverse(b.neighbors));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::haar_file::{parse_haar_cascade, tests::TINY};
    use std::path::Path;

    #[test]
    fn rectangle_sums_are_exact() {
        let px: Vec<u8> = (0..30).map(|i| (i * 7 % 256) as u8).collect();
        let ii = Integral::new(&px, 6, 5);
        let direct: i64 = (1..4)
            .flat_map(|y| (2..5).map(move |x| (x, y)))
            .map(|(x, y)| i64::from(px[y * 6 + x]))
            .sum();
        assert_eq!(ii.rect(2, 1, 3, 3), direct);
    }

    #[test]
    fn a_dark_left_bright_right_square_is_found_where_it_is() {
        let cascade = parse_haar_cascade(TINY, Path::new("c.xml")).unwrap();
        let (w, h) = (40, 30);
        let mut px = vec![128u8; w * h];
        for y in 10..18 {
            for x in 20..28 {
                px[y * w + x] = if x < 24 { 10 } else { 250 };
            }
        }
        let img = GrayView { width: w, height: h, pixels: &px };
        let found =
            detect_faces(&cascade, img, &DetectOptions { min_neighbors: 0, ..Default::default() });
        assert!(!found.is_empty());
        let c = &found[0].face;
        let (cx, cy) = (c.left + c.width / 2.0, c.top + c.height / 2.0);
        assert!((cx - 24.0).abs() < 3.0 && (cy - 14.0).abs() < 3.0, "{found:?}");
    }

    #[test]
    fn lone_hits_are_dropped_and_clusters_averaged() {
        let b = |l: f64| FaceBox { left: l, top: 0.0, width: 20.0, height: 20.0 };
        let g = group_detections(&[b(0.0), b(1.0), b(2.0), b(3.0), b(100.0)], 3, 0.2);
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].neighbors, 4);
        assert!((g[0].face.left - 1.5).abs() < 1e-9);
    }
}
