//! A synthetic, deterministic `App` for the TUI's tests, snapshots and benchmarks: a drawn
//! face whose mouth opens and closes, 68 landmarks with one tracker glitch, a sphere-ish
//! head mesh with a partial landmark map, fits, an alignment and analysis tables.
//!
//! Nothing here is random, so snapshots are stable.

use crate::tui::app::{App, FrameImage};

use crate::alignment::{Alignment, Phone};
use crate::fit::FrameFit;
use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, Track};
use crate::math::Point3;
use crate::model::{LandmarkMap, Mesh};
use crate::tui::screens::analysis::{AnalysisData, AnalysisRow, AnalysisTable, Trajectory};
use std::f64::consts::PI;
use std::sync::Arc;

/// Frame at which the synthetic tracker jumps point 48 by a quarter of the face.
pub const GLITCH_FRAME: usize = 7;

/// Mouth opening of frame `f`, 0..1.
pub fn mouth_open(f: usize) -> f64 {
    0.5 + 0.5 * (f as f64 * 0.45).sin()
}

/// The 68 synthetic landmarks of frame `f` for a `width × height` image.
pub fn face_points(f: usize, width: u32, height: u32) -> Vec<LandmarkPoint> {
    let (cx, cy) = (f64::from(width) / 2.0, f64::from(height) * 0.45);
    let s = f64::from(width.min(height)) * 0.32;
    let open = mouth_open(f);
    let mut p = vec![(0.0, 0.0); N_LANDMARKS];
    for (k, q) in p.iter_mut().enumerate().take(17) {
        let t = PI * k as f64 / 16.0;
        *q = (cx - s * t.cos(), cy + 0.1 * s + 1.1 * s * t.sin());
    }
    for k in 0..5 {
        let x = 0.15 + 0.65 * (1.0 - k as f64 / 4.0);
        p[17 + k] = (cx - s * x, cy - 0.55 * s);
        p[22 + k] = (cx + s * (0.15 + 0.65 * k as f64 / 4.0), cy - 0.55 * s);
    }
    for k in 0..4 {
        p[27 + k] = (cx, cy - 0.4 * s + 0.15 * s * k as f64);
    }
    for k in 0..5 {
        p[31 + k] = (cx + s * (-0.2 + 0.1 * k as f64), cy + 0.15 * s);
    }
    for (base, ex) in [(36, -0.4), (42, 0.4)] {
        for k in 0..6 {
            let t = PI + 2.0 * PI * k as f64 / 6.0;
            p[base + k] = (cx + s * (ex + 0.15 * t.cos()), cy - 0.35 * s + 0.06 * s * t.sin());
        }
    }
    let mouth_y = cy + 0.55 * s;
    for k in 0..12 {
        let t = PI + 2.0 * PI * k as f64 / 12.0;
        p[48 + k] = (cx + 0.35 * s * t.cos(), mouth_y + (0.1 + 0.1 * open) * s * t.sin());
    }
    for k in 0..8 {
        let t = PI + 2.0 * PI * k as f64 / 8.0;
        p[60 + k] = (cx + 0.25 * s * t.cos(), mouth_y + 0.1 * open * s * t.sin());
    }
    p.into_iter()
        .map(|(x, y)| LandmarkPoint { confidence: Some(0.95), ..LandmarkPoint::tracked(x, y) })
        .collect()
}

/// The synthetic tracker output: `face_points` with a glitch at `GLITCH_FRAME`.
pub fn synthetic_track(n_frames: usize, width: u32, height: u32) -> Track {
    Track::new(
        (0..n_frames)
            .map(|f| {
                let mut pts = face_points(f, width, height);
                if f == GLITCH_FRAME {
                    pts[48].x -= f64::from(width.min(height)) * 0.08;
                }
                let mut fl = FrameLandmarks::new(f, pts);
                fl.timestamp = Some(f as f64 / 25.0);
                fl
            })
            .collect(),
    )
}

/// A frame image: a blue-grey gradient with a skin-coloured face and a dark mouth.
pub fn face_image(f: usize, width: u32, height: u32) -> FrameImage {
    let pts = face_points(f, width, height);
    let (cx, cy) = (f64::from(width) / 2.0, f64::from(height) * 0.45);
    let s = f64::from(width.min(height)) * 0.32;
    let (mx, my) = (pts[62].x, (pts[62].y + pts[66].y) / 2.0);
    let (mrx, mry) = (0.25 * s, ((pts[66].y - pts[62].y) / 2.0).max(0.5));
    let mut rgb = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            let (xf, yf) = (f64::from(x), f64::from(y));
            let face = ((xf - cx) / (1.05 * s)).powi(2) + ((yf - cy) / (1.35 * s)).powi(2) <= 1.0;
            let mouth = ((xf - mx) / mrx).powi(2) + ((yf - my) / mry).powi(2) <= 1.0;
            let px = if mouth {
                [90, 20, 30]
            } else if face {
                [225, 180, 150]
            } else {
                [40, (60 + 100 * y / height.max(1)) as u8, (90 + 120 * x / width.max(1)) as u8]
            };
            rgb.extend_from_slice(&px);
        }
    }
    FrameImage { width, height, rgb }
}

/// A closed head-like mesh: a UV ellipsoid (y up, facing +z), quads and triangle caps.
pub fn synthetic_mesh() -> Mesh {
    let (lat, lon) = (10usize, 16usize);
    let mut vertices = vec![Point3::new(0.0, 110.0, 0.0)];
    for i in 1..lat {
        let t = PI * i as f64 / lat as f64;
        for j in 0..lon {
            let u = 2.0 * PI * j as f64 / lon as f64;
            vertices.push(Point3::new(
                75.0 * t.sin() * u.sin(),
                110.0 * t.cos(),
                90.0 * t.sin() * u.cos(),
            ));
        }
    }
    vertices.push(Point3::new(0.0, -110.0, 0.0));
    let ring = |i: usize, j: usize| (1 + (i - 1) * lon + j % lon) as u32;
    let mut faces = Vec::new();
    for j in 0..lon {
        faces.push(vec![0, ring(1, j + 1), ring(1, j)]);
    }
    for i in 1..lat - 1 {
        for j in 0..lon {
            faces.push(vec![ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)]);
        }
    }
    let last = (vertices.len() - 1) as u32;
    for j in 0..lon {
        faces.push(vec![ring(lat - 1, j), ring(lat - 1, j + 1), last]);
    }
    Mesh { vertices, faces }
}

/// A fit for every frame: residuals of a fraction of a pixel, frame 12 fitting badly.
pub fn synthetic_fits(track: &Track) -> Vec<FrameFit> {
    track
        .frames
        .iter()
        .map(|f| {
            let bad = f.frame == 12;
            let residuals = (0..N_LANDMARKS)
                .map(|i| {
                    (i >= 17).then(|| {
                        let k = if bad { 6.0 } else { 0.6 };
                        [k * ((i * 7 % 5) as f64 - 2.0) / 2.0, k * ((i * 3 % 4) as f64 - 1.5) / 1.5]
                    })
                })
                .collect();
            FrameFit {
                frame: f.frame,
                yaw: 5.0,
                pitch: -3.0,
                roll: 1.0,
                scale: 1.0,
                tx: 0.0,
                ty: 0.0,
                identity: vec![],
                expression: vec![],
                reproj_rms_px: if bad { 6.2 } else { 0.8 + 0.01 * (f.frame % 5) as f64 },
                residuals,
                failed: None,
            }
        })
        .collect()
}

/// A short alignment over `n_frames` at 25 fps.
pub fn synthetic_alignment(n_frames: usize) -> Alignment {
    let labels = ["sil", "B", "IH1", "N", "W", "AY1", "T", "sil"];
    let dur = n_frames as f64 / 25.0 / labels.len() as f64;
    Alignment {
        phones: labels
            .iter()
            .enumerate()
            .map(|(k, l)| Phone {
                start: k as f64 * dur,
                end: (k + 1) as f64 * dur,
                label: l.to_string(),
            })
            .collect(),
    }
}

/// Analysis tables and trajectories consistent with the synthetic clip.
pub fn synthetic_analysis(n_frames: usize) -> AnalysisData {
    let a = synthetic_alignment(n_frames);
    let rows = a
        .phones
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let values =
                [0.05 + 0.01 * k as f64, 0.08 + 0.013 * ((k * 5) % 7) as f64, 0.02 * k as f64];
            AnalysisRow::numbers(&p.label, &values, Some((p.start * 25.0).round() as usize))
        })
        .collect();
    let worst = (0..5)
        .map(|k| {
            let f = (k * 7 + 3) % n_frames.max(1);
            AnalysisRow::numbers(&format!("frame {f}"), &[0.3 - 0.04 * k as f64], Some(f))
        })
        .collect();
    let w = |f: usize| 0.6 + 0.1 * mouth_open(f);
    let h = |f: usize| 0.1 + 0.3 * mouth_open(f);
    AnalysisData {
        warnings: Vec::new(),
        tables: vec![
            AnalysisTable {
                title: "RMSE per phoneme".into(),
                columns: vec!["phone".into(), "W".into(), "H".into(), "P".into()],
                rows,
            },
            AnalysisTable {
                title: "worst frames".into(),
                columns: vec!["frame".into(), "error".into()],
                rows: worst,
            },
        ],
        trajectories: vec![
            Trajectory {
                name: "W".into(),
                video: (0..n_frames).map(|f| (f as f64, w(f))).collect(),
                model: (0..n_frames).map(|f| (f as f64, w(f) * 0.95 + 0.02)).collect(),
            },
            Trajectory {
                name: "H".into(),
                video: (0..n_frames).map(|f| (f as f64, h(f))).collect(),
                model: (0..n_frames).map(|f| (f as f64, h(f) * 0.9)).collect(),
            },
        ],
    }
}

/// The whole synthetic app: `n_frames` frames of `width × height`, every image decoded and
/// cached (a warm cache), mesh and map set; fits and analysis when `with_fits`.
pub fn synthetic_app(n_frames: usize, width: u32, height: u32, with_fits: bool) -> App {
    let track = synthetic_track(n_frames, width, height);
    let mut app = App::new("synthetic · clip1", track.clone(), track);
    app.frames.cache.capacity = n_frames.max(1);
    for f in 0..n_frames {
        app.cache_image(f, Arc::new(face_image(f, width, height)));
    }
    app.frames.cache.size = Some((width, height));
    app.alignment = Some(synthetic_alignment(n_frames));
    app.set_mesh(Arc::new(synthetic_mesh()));
    let mut map = LandmarkMap::default();
    // Vertices near the front of the ellipsoid for a few points.
    for (l, v) in
        [(30usize, 1 + 5 * 16), (48, 1 + 6 * 16 + 1), (54, 1 + 6 * 16 + 15), (8, 1 + 8 * 16)]
    {
        map.to_vertex.insert(l, v);
    }
    app.map = Some(map);
    if with_fits {
        for f in synthetic_fits(&app.track) {
            app.fits.by_frame.insert(f.frame, f);
        }
        app.analysis.data = synthetic_analysis(n_frames);
        app.recompute_flags();
    }
    app
}

/// A `Write` that counts and discards bytes: a stand-in terminal for measuring what ratatui
/// would send (escape sequences included) when a frame is drawn.
#[derive(Clone, Debug, Default)]
pub struct CountingWriter(pub Arc<std::sync::atomic::AtomicUsize>);

impl std::io::Write for CountingWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.fetch_add(buf.len(), std::sync::atomic::Ordering::Relaxed);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A crossterm terminal whose output is only counted.
pub type CountingTerminal = ratatui::Terminal<ratatui::backend::CrosstermBackend<CountingWriter>>;

/// A fixed-size crossterm terminal writing into a `CountingWriter`; returns the counter.
///
/// # Errors
/// Never in practice (no terminal is queried); kept for the `Terminal` API.
pub fn counting_terminal(
    width: u16,
    height: u16,
) -> std::io::Result<(CountingTerminal, Arc<std::sync::atomic::AtomicUsize>)> {
    let w = CountingWriter::default();
    let counter = w.0.clone();
    let area = ratatui::layout::Rect::new(0, 0, width, height);
    let t = ratatui::Terminal::with_options(
        ratatui::backend::CrosstermBackend::new(w),
        ratatui::TerminalOptions { viewport: ratatui::Viewport::Fixed(area) },
    )?;
    Ok((t, counter))
}

/// A drawn side view: a dark face profile looking right on a light background, whose upper
/// lip pushes forward as the mouth rounds, measured frame by frame like a real clip (one
/// frame per front frame, the crop and a vertical reference line set by hand).
pub fn synthetic_side(
    n_frames: usize,
    width: u32,
    height: u32,
) -> crate::tui::screens::side::SideView {
    use crate::measure::profile::{
        Facing, ProfileSetup, ProfileTrack, Rect, ReferenceLine, measure_frame,
    };
    let (w, h) = (f64::from(width), f64::from(height));
    // The face edge x(y) as fractions of the frame: forehead, nose tip, subnasale, upper
    // lip (moving), mouth, chin.
    let edge = |y: f64, lip: f64| -> f64 {
        let knots = [
            (0.0, 0.50),
            (0.35, 0.52),
            (0.50, 0.66),
            (0.58, 0.56),
            (0.66, 0.60 + lip),
            (0.72, 0.57),
            (0.80, 0.59),
            (1.0, 0.45),
        ];
        let k = knots.windows(2).position(|k| y >= k[0].0 && y <= k[1].0).unwrap_or(6);
        let ((y0, x0), (y1, x1)) = (knots[k], knots[k + 1]);
        x0 + (x1 - x0) * (y - y0) / (y1 - y0)
    };
    let images: Vec<FrameImage> = (0..n_frames)
        .map(|f| {
            let lip = 0.04 * mouth_open(f);
            let mut rgb = Vec::with_capacity((3 * width * height) as usize);
            for y in 0..height {
                let x_edge = edge(f64::from(y) / h, lip) * w;
                for x in 0..width {
                    let v = if f64::from(x) < x_edge { 60 } else { 220 };
                    rgb.extend([v, v, v]);
                }
            }
            FrameImage { width, height, rgb }
        })
        .collect();
    let crop =
        Rect::new((0.45 * w) as u32, (0.54 * h) as u32, (0.30 * w) as u32, (0.22 * h) as u32);
    let mut setup = ProfileSetup::new(crop, ReferenceLine::vertical(0.52 * w), Facing::Right);
    setup.anchor = None;
    let automatic = images
        .iter()
        .enumerate()
        .map(|(f, img)| {
            let gray =
                image::GrayImage::from_fn(width, height, |x, y| image::Luma([img.pixel(x, y)[0]]));
            measure_frame(f, &gray, &setup, Some(0.16 * h))
        })
        .collect();
    crate::tui::screens::side::SideView {
        setup,
        track: ProfileTrack::new(automatic, Some(0.16 * h)),
        fps: 25.0,
        offset_s: 0.0,
        n_frames,
        images: images.into_iter().enumerate().map(|(f, i)| (f, Arc::new(i))).collect(),
        image_errors: Default::default(),
    }
}

/// A transferred head set up from `synthetic_mesh` onto itself (ten front vertices as
/// landmarks on both sides), so moving the source moves the head.
pub fn synthetic_prepared_head() -> crate::tui::screens::head::PreparedHead {
    use crate::transfer::{SourceFace, TargetHead, Transfer, TransferOptions};
    let mesh = synthetic_mesh();
    // (iBUG point, ring, meridian): eyes and nose above the equator (the transfer's stable
    // points), mouth and chin below it, all on the front (meridian 0, z > 0).
    let front = [
        (27, 2, 0),
        (36, 2, 14),
        (45, 2, 2),
        (29, 4, 0),
        (39, 4, 15),
        (42, 4, 1),
        (48, 6, 14),
        (51, 6, 0),
        (54, 6, 2),
        (8, 8, 0),
    ];
    let map = LandmarkMap {
        to_vertex: front.iter().map(|&(l, i, j)| (l, 1 + (i - 1) * 16 + j)).collect(),
    };
    let reference = mesh.to_flat();
    let triangles = mesh.triangles();
    let source = SourceFace {
        reference: &reference,
        triangles: &triangles,
        landmarks: &map,
        identity: None,
        face: None,
    };
    let target = TargetHead { mesh: &mesh, skin: &[], landmarks: &map };
    let options = TransferOptions { controls: 40, ..TransferOptions::default() };
    let transfer = match Transfer::new(source, target, &options) {
        Ok(t) => t,
        Err(e) => panic!("the synthetic transfer sets up: {e}"),
    };
    crate::tui::screens::head::PreparedHead::new(
        "sphere".into(),
        "biharmonic".into(),
        transfer,
        mesh,
        &[],
        &map,
    )
}

/// A morphable model of `synthetic_mesh` (its mean) with one expression, `jawOpen`, that
/// lowers every vertex below the equator by 20 units at β = 1.
pub fn synthetic_model() -> crate::model::MorphableModel {
    use crate::math::{DMatrix, DVector};
    use crate::model::{Expressions, MorphableModel, PcaModel};
    let mesh = synthetic_mesh();
    let n = mesh.vertices.len();
    let mut deltas = DMatrix::zeros(3 * n, 1);
    for (v, p) in mesh.vertices.iter().enumerate() {
        if p.y < 0.0 {
            deltas[(3 * v + 1, 0)] = -20.0;
        }
    }
    MorphableModel {
        shape: PcaModel::mean_only(DVector::from_column_slice(mesh.to_flat().as_slice())),
        expressions: Some(Expressions { names: vec!["jawOpen".into()], deltas }),
        triangles: mesh.triangles(),
    }
}

/// A speech-driven series per trajectory of `synthetic_analysis`: the 3D one a frame late
/// and a little flatter, as a head driven from audio follows the video.
pub fn synthetic_speech(n_frames: usize) -> Vec<(String, Vec<(f64, f64)>)> {
    synthetic_analysis(n_frames)
        .trajectories
        .iter()
        .map(|t| {
            let late = t.model.windows(2).map(|w| (w[1].0, 0.15 + 0.7 * w[0].1)).collect();
            (t.name.clone(), late)
        })
        .collect()
}
