//! Following a point from one frame to the next by its image patch: pyramidal Lucas–Kanade
//! (J.-Y. Bouguet, "Pyramidal Implementation of the Lucas Kanade Feature Tracker:
//! Description of the algorithm", Intel Corporation, 2000), with the forward–backward check
//! of Kalal, Mikolajczyk & Matas ("Forward-Backward Error: Automatic Detection of Tracking
//! Failures", ICPR 2010) to say when a patch is lost.
//!
//! Bouguet's algorithm, in his symbols: the images I (the frame the point is in) and J (the
//! next) are halved level by level (§2.1: the 1/4–1/2–1/4 low-pass then every other pixel).
//! From the coarsest level L down, the displacement `d` of the window of half-size `w`
//! around `u^L = u / 2^L` is found by Newton steps on the sum of squared differences:
//! `G = Σ [I_x², I_x I_y; I_x I_y, I_y²]` over the window of I (§2.3, eq. 24), then
//! repeatedly `b = Σ δI [I_x; I_y]` with `δI = I(x) − J(x + g + ν)` and `ν += G⁻¹ b`
//! (eqs. 28–32), until the step is below ε or after K steps. The next finer level starts
//! from `g^{L−1} = 2 (g^L + d^L)` (eq. 33), and `d = g^0 + d^0`.
//!
//! Departures: the guess at the coarsest level is the caller's (Bouguet starts from 0), so
//! a caller that knows roughly where the point went (the face's motion by the tracker) needs
//! the pyramid only for the rest. `G` is inverted only on its eigen-directions whose
//! eigenvalue is at least [`FlowOptions::min_eigenvalue`] per window pixel (Shi & Tomasi's
//! texture measure, "Good Features to Track", CVPR 1994): a window on an edge (a lip's line,
//! the points a user corrects) is followed across the edge and keeps the guess's motion along
//! it, where Bouguet's full inverse would take noise for motion; a window with no texture in
//! any direction is not followed. A window partly outside the image is not followed either
//! (its pixels would be made up).
//!
//! Start at [`Pyramid::new`], then [`follow_point_checked`].

use super::cascade::GrayView;
use nalgebra::{Matrix2, Vector2};

/// One level of a [`Pyramid`]: grey levels as `f32`, row-major.
#[derive(Clone, Debug, PartialEq)]
struct Level {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl Level {
    fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// The pixel at `(x, y)` with coordinates clamped into the image (the border repeated,
    /// as Bouguet's low-pass filter treats it).
    fn clamped(&self, x: isize, y: isize) -> f32 {
        let cx = x.clamp(0, self.width as isize - 1) as usize;
        let cy = y.clamp(0, self.height as isize - 1) as usize;
        self.at(cx, cy)
    }

    /// Bilinear interpolation at `(x, y)`, which must lie within `[0, width−1] × [0,
    /// height−1]`.
    fn bilinear(&self, x: f64, y: f64) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (ax, ay) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as usize, y0 as usize);
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let top = self.at(x0, y0) * (1.0 - ax) + self.at(x1, y0) * ax;
        let bottom = self.at(x0, y1) * (1.0 - ax) + self.at(x1, y1) * ax;
        top * (1.0 - ay) + bottom * ay
    }

    /// Whether the square of half-size `r` around `(x, y)` lies inside the image.
    fn holds(&self, x: f64, y: f64, r: f64) -> bool {
        x - r >= 0.0
            && y - r >= 0.0
            && x + r <= (self.width - 1) as f64
            && y + r <= (self.height - 1) as f64
    }

    /// The next coarser level (Bouguet §2.1, eq. 2): each pixel the 3×3 weighted mean
    /// (1/4 centre, 1/8 sides, 1/16 corners) around the finer level's pixel (2x, 2y).
    fn halved(&self) -> Self {
        let (width, height) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let (fx, fy) = (2 * x as isize, 2 * y as isize);
                let p = |dx: isize, dy: isize| self.clamped(fx + dx, fy + dy);
                let sides = p(-1, 0) + p(1, 0) + p(0, -1) + p(0, 1);
                let corners = p(-1, -1) + p(1, -1) + p(-1, 1) + p(1, 1);
                data.push(0.25 * p(0, 0) + 0.125 * sides + 0.0625 * corners);
            }
        }
        Self { width, height, data }
    }
}

/// An image and its halvings, finest first.
#[derive(Clone, Debug, PartialEq)]
pub struct Pyramid {
    levels: Vec<Level>,
}

impl Pyramid {
    /// `image` and up to `coarser` halvings of it (none of a level under 16 pixels on a side:
    /// its halving would be too small to hold a window).
    pub fn new(image: GrayView<'_>, coarser: usize) -> Self {
        let base = Level {
            width: image.width,
            height: image.height,
            data: image.pixels.iter().map(|&v| f32::from(v)).collect(),
        };
        let mut levels = vec![base];
        while levels.len() <= coarser {
            let last = levels.last().expect("the base level");
            if last.width < 16 || last.height < 16 {
                break;
            }
            levels.push(last.halved());
        }
        Self { levels }
    }

    /// Number of levels (the image itself included).
    pub fn len(&self) -> usize {
        self.levels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.levels.is_empty()
    }
}

/// How a point is followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowOptions {
    /// Half the side of the window compared, in pixels of every level (Bouguet's `w`): the
    /// patch is `(2w+1)²` pixels.
    pub half_window: usize,
    /// Newton steps per level at most (Bouguet's K).
    pub max_steps: usize,
    /// A step shorter than this (pixels of the level) ends the level's iteration (ε).
    pub min_step: f64,
    /// The eigenvalue of `G` per window pixel below which the window has no texture to follow
    /// in that eigen-direction (grey levels² per pixel², gradients by central differences).
    /// 1.0 is a gradient of one grey level per pixel across the window in that direction.
    pub min_eigenvalue: f64,
}

impl Default for FlowOptions {
    /// Bouguet's K = 20 and ε = 0.03 px; a 7×7 window (the caller sizes it to the face).
    fn default() -> Self {
        Self { half_window: 3, max_steps: 20, min_step: 0.03, min_eigenvalue: 1.0 }
    }
}

/// Where the point `p` of `prev` is in `next` (pixels), from the displacement `guess`
/// (the caller's idea of how far it moved; zero when it has none), by pyramidal
/// Lucas–Kanade. `None` when its window leaves the image at some level, has no texture to
/// follow, or the iteration diverges.
pub fn follow_point(
    prev: &Pyramid,
    next: &Pyramid,
    p: Vector2<f64>,
    guess: Vector2<f64>,
    opts: &FlowOptions,
) -> Option<Vector2<f64>> {
    let levels = prev.levels.len().min(next.levels.len());
    if levels == 0 || !p.iter().chain(guess.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let top = levels - 1;
    let mut g = guess / f64::from(1u32 << top);
    for l in (0..levels).rev() {
        let scale = f64::from(1u32 << l);
        let d = level_displacement(&prev.levels[l], &next.levels[l], p / scale, g, opts)?;
        g = if l == 0 { g + d } else { 2.0 * (g + d) };
    }
    Some(p + g)
}

/// One level's displacement `d^L` from the guess `g` (Bouguet's inner loop, eqs. 24–32).
fn level_displacement(
    i: &Level,
    j: &Level,
    u: Vector2<f64>,
    g: Vector2<f64>,
    opts: &FlowOptions,
) -> Option<Vector2<f64>> {
    let w = opts.half_window as isize;
    // The window of I and its gradient (central differences need one pixel more).
    if !i.holds(u.x, u.y, (w + 1) as f64) {
        return None;
    }
    let side = (2 * w + 1) as usize;
    let mut patch = Vec::with_capacity(side * side);
    let mut grad = Vec::with_capacity(side * side);
    let mut gm = Matrix2::<f64>::zeros();
    for dy in -w..=w {
        for dx in -w..=w {
            let (x, y) = (u.x + dx as f64, u.y + dy as f64);
            let ix = 0.5 * f64::from(i.bilinear(x + 1.0, y) - i.bilinear(x - 1.0, y));
            let iy = 0.5 * f64::from(i.bilinear(x, y + 1.0) - i.bilinear(x, y - 1.0));
            gm += Matrix2::new(ix * ix, ix * iy, ix * iy, iy * iy);
            patch.push(i.bilinear(x, y));
            grad.push(Vector2::new(ix, iy));
        }
    }
    // G's inverse on the directions with texture only: an edge (a lip's line) fixes the
    // motion across it, not along it, which stays the guess's (the aperture problem).
    let floor = opts.min_eigenvalue * (side * side) as f64;
    let eigen = gm.symmetric_eigen();
    let mut g_inv = Matrix2::zeros();
    for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
        if lambda >= floor {
            let v = eigen.eigenvectors.column(k);
            g_inv += v * v.transpose() / lambda;
        }
    }
    if g_inv == Matrix2::zeros() {
        return None;
    }
    let mut nu = Vector2::zeros();
    for _ in 0..opts.max_steps {
        let at = u + g + nu;
        if !j.holds(at.x, at.y, w as f64) {
            return None;
        }
        let mut b = Vector2::zeros();
        let mut k = 0;
        for dy in -w..=w {
            for dx in -w..=w {
                let di = f64::from(patch[k] - j.bilinear(at.x + dx as f64, at.y + dy as f64));
                b += di * grad[k];
                k += 1;
            }
        }
        let step = g_inv * b;
        nu += step;
        if !nu.iter().all(|v| v.is_finite()) {
            return None;
        }
        if step.norm() < opts.min_step {
            break;
        }
    }
    Some(nu)
}

/// A point followed into the next frame, with how well it came back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Followed {
    /// Where it is in the next frame (pixels).
    pub position: Vector2<f64>,
    /// The forward–backward error: how far from where it started the point lands when
    /// followed back from `position` into the first frame (pixels). A patch followed right
    /// comes back to itself; one that slid along an edge, into a look-alike or off what it
    /// was on does not (Kalal et al. 2010).
    pub round_trip: f64,
}

/// [`follow_point`] forward, then back from where it landed (the guess the forward
/// displacement reversed): the position and its forward–backward error. `None` when either
/// way cannot be followed.
pub fn follow_point_checked(
    prev: &Pyramid,
    next: &Pyramid,
    p: Vector2<f64>,
    guess: Vector2<f64>,
    opts: &FlowOptions,
) -> Option<Followed> {
    let position = follow_point(prev, next, p, guess, opts)?;
    let back = follow_point(next, prev, position, p - position, opts)?;
    Some(Followed { position, round_trip: (back - p).norm() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth textured image (sums of sines, 0–255) shifted by `(sx, sy)` pixels.
    fn textured(width: usize, height: usize, sx: f64, sy: f64) -> Vec<u8> {
        let mut px = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let (fx, fy) = (x as f64 - sx, y as f64 - sy);
                let v = 128.0
                    + 50.0 * (0.21 * fx + 0.1 * fy).sin()
                    + 40.0 * (0.13 * fy - 0.05 * fx).cos()
                    + 30.0 * (0.31 * fx * 0.7 + 0.27 * fy).sin();
                px.push(v.round().clamp(0.0, 255.0) as u8);
            }
        }
        px
    }

    fn view(px: &[u8], width: usize, height: usize) -> GrayView<'_> {
        GrayView { width, height, pixels: px }
    }

    #[test]
    fn a_shifted_texture_is_followed_to_a_tenth_of_a_pixel_and_comes_back() {
        let (w, h) = (96, 80);
        let a = textured(w, h, 0.0, 0.0);
        let opts = FlowOptions { half_window: 5, ..FlowOptions::default() };
        for (sx, sy) in [(2.3, -1.6), (6.5, 4.0), (-9.2, 3.1)] {
            let b = textured(w, h, sx, sy);
            let (pa, pb) = (Pyramid::new(view(&a, w, h), 2), Pyramid::new(view(&b, w, h), 2));
            let p = Vector2::new(47.0, 38.5);
            let f = follow_point_checked(&pa, &pb, p, Vector2::zeros(), &opts).unwrap();
            let moved = f.position - p;
            assert!((moved - Vector2::new(sx, sy)).norm() < 0.1, "{sx},{sy}: {moved:?}");
            assert!(f.round_trip < 0.1, "{f:?}");
        }
    }

    #[test]
    fn a_good_guess_needs_no_pyramid_and_a_flat_or_outside_window_is_not_followed() {
        let (w, h) = (64, 64);
        let a = textured(w, h, 0.0, 0.0);
        let b = textured(w, h, 7.0, 0.0);
        let opts = FlowOptions { half_window: 4, ..FlowOptions::default() };
        let (pa, pb) = (Pyramid::new(view(&a, w, h), 0), Pyramid::new(view(&b, w, h), 0));
        assert_eq!(pa.len(), 1);
        let p = Vector2::new(30.0, 30.0);
        let got = follow_point(&pa, &pb, p, Vector2::new(6.5, 0.4), &opts).unwrap();
        assert!((got - Vector2::new(37.0, 30.0)).norm() < 0.1, "{got:?}");
        // Too near the border for the window.
        assert!(follow_point(&pa, &pb, Vector2::new(2.0, 30.0), Vector2::zeros(), &opts).is_none());
        // A flat image has nothing to follow.
        let flat = vec![90u8; w * h];
        let pf = Pyramid::new(view(&flat, w, h), 1);
        assert!(follow_point(&pf, &pf, p, Vector2::zeros(), &opts).is_none());
    }

    #[test]
    fn an_edge_is_followed_across_and_keeps_the_guess_along_it() {
        // Texture in x only (vertical stripes): the motion across them is found, the motion
        // along them cannot be and is the guess's.
        let (w, h) = (96, 80);
        let stripes = |sx: f64| -> Vec<u8> {
            (0..w * h)
                .map(|k| {
                    let x = (k % w) as f64 - sx;
                    (128.0 + 60.0 * (0.23 * x).sin() + 30.0 * (0.07 * x).cos()).round() as u8
                })
                .collect()
        };
        let (a, b) = (stripes(0.0), stripes(3.4));
        let opts = FlowOptions { half_window: 5, ..FlowOptions::default() };
        let (pa, pb) = (Pyramid::new(view(&a, w, h), 2), Pyramid::new(view(&b, w, h), 2));
        let p = Vector2::new(47.0, 38.0);
        let got = follow_point(&pa, &pb, p, Vector2::new(0.0, 1.5), &opts).unwrap() - p;
        assert!((got - Vector2::new(3.4, 1.5)).norm() < 0.1, "{got:?}");
    }

    #[test]
    fn a_patch_that_changed_does_not_come_back_to_itself() {
        // The next frame is another texture: whatever the forward pass lands on, the way back
        // does not return to the start.
        let (w, h) = (96, 80);
        let a = textured(w, h, 0.0, 0.0);
        let b: Vec<u8> = textured(h, w, 3.0, 11.0).chunks(h).flat_map(|r| r.to_vec()).collect();
        let b: Vec<u8> = (0..w * h).map(|k| b[(k * 7919) % (w * h)] / 2 + a[k] / 2).collect();
        let opts = FlowOptions { half_window: 5, ..FlowOptions::default() };
        let (pa, pb) = (Pyramid::new(view(&a, w, h), 2), Pyramid::new(view(&b, w, h), 2));
        let same =
            follow_point_checked(&pa, &pa, Vector2::new(47.0, 38.0), Vector2::zeros(), &opts)
                .unwrap();
        assert!(same.round_trip < 0.05 && (same.position - Vector2::new(47.0, 38.0)).norm() < 0.05);
        let lost =
            follow_point_checked(&pa, &pb, Vector2::new(47.0, 38.0), Vector2::zeros(), &opts);
        assert!(lost.is_none_or(|f| f.round_trip > 0.5), "{lost:?}");
    }

    #[test]
    fn halving_keeps_the_mean_of_a_flat_image_and_stops_at_small_levels() {
        let flat = vec![100u8; 40 * 30];
        let p = Pyramid::new(view(&flat, 40, 30), 5);
        // 40×30 → 20×15 (under 16 high: no further level).
        assert_eq!(p.len(), 2);
        assert_eq!((p.levels[1].width, p.levels[1].height), (20, 15));
        assert!(p.levels[1].data.iter().all(|&v| (v - 100.0).abs() < 1e-4));
    }
}
