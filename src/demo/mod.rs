//! The built-in synthetic speaker (`docs/design.md`, "The demo speaker"): from a fixed seed, a head with a modelled
//! lip region, its 161 viseme poses and their PCA model, GRID sentences with phone timings,
//! coarticulated mouth motion, rendered front and side frames, "tracked" landmarks with noise
//! and injected gross errors, and the truth (W, H, P, pose) of every frame.
//!
//! Start with [`generate`]; [`DemoOptions::default`] is what `lipmap demo` writes into
//! `sessions/demo/`. Layout of `out_dir`:
//!
//! ```text
//! head.obj  head_map.toml  model.lmm  manifest.json  poses/pose_000.obj … pose_160.obj
//! speaker_00/                      (speaker 0 is the head itself; others are reshaped)
//!   s1_bin_blue_at_f_two_now/
//!     phones.csv                   start,end,phone (ARPAbet, `sil` for silence)
//!     front/frame_00000.png …      720×480, 24 fps, frame f at time f/fps
//!     side/frame_00000.png …       profile view, same timing
//!     landmarks_tracked.csv        lipmap CSV: truth + noise + injected errors
//!     landmarks_true.csv           lipmap CSV: exact projections of the mapped vertices
//!     truth.csv                    per frame: phone, W, H, P (model space), pose, side camera
//!     errors.csv                   the injected gross errors: frame,kind,point,other,dx,dy
//! ```
//!
//! Two protrusion truths are in `truth.csv`, both (foremost z − inner-eye-corner plane z) /
//! |nasion − nose tip| in model space:
//! - `p_lip`: the foremost point of the whole upper lip (every vermilion vertex of
//!   `head.upper_lip`). This is what a profile silhouette shows, so it is the truth of P
//!   measured from the side view (`workflow::side_view_protrusion`), and what a fitted head's
//!   P is measured as when the clip's P comes from a side view (`UpperLip::Region`).
//! - `p`: the foremost of the mapped upper-lip landmark vertices (`UpperLip::MappedLandmarks`,
//!   outer 48–54, inner 60–64), the mesh measure's default, for heads evaluated against
//!   landmark-only P. Between landmark vertices the lip can be further forward, so `p` moves
//!   a few per cent differently from `p_lip`.

mod camera_motion;
pub mod coart;
pub mod corpus;
pub mod head;
pub mod lexicon;
pub mod speakers;
mod tracker;
mod truth;
pub mod visemes;
pub mod voice;

pub use camera_motion::SIDE_BACKGROUND;
use camera_motion::{frame_cameras, head_motion};
pub use tracker::InjectedError;
use tracker::{points_to_track, simulate_tracker};
use truth::{TruthRow, format_errors, format_truth};

use crate::io::model_file::{Precision, write_model_file};
use crate::landmarks::N_LANDMARKS;
use crate::math::{Point2, Point3, Vector3};
use crate::measure::{MeshMeasureOptions, measure_points, measure_shape};
use crate::model::pca::{Keep, build_pca_from_shapes};
use crate::model::{Mesh, MorphableModel};
use crate::render::{Camera, RenderOptions, render_mesh};
use anyhow::{Context, Result};
use head::Head;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;
use speakers::{MouthWarp, Speaker, SpeakerSpec};
use std::path::{Path, PathBuf};
use visemes::{Articulation, ArticulationFields};

/// The seed `lipmap demo` uses unless told otherwise.
pub const DEFAULT_SEED: u64 = 20_241_121;

/// Components the demo's PCA model keeps: all of them. The poses span exactly the
/// 8-dimensional space of the articulatory parameters (see `visemes`); the jaw alone carries
/// 94 % of the variance, so the thesis's 98 % rule would keep two components and drop the
/// lip shapes (press and tuck carry under 10⁻⁵ each but decide /b/ and /f/). Keeping all 8
/// makes every demo frame representable, so a fit's error is the fitter's, not the model's.
pub const DEMO_MODEL_COMPONENTS: usize = visemes::N_PARAMS;

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoOptions {
    pub seed: u64,
    /// Number of speakers (≥ 1); speaker 0 is the head itself.
    pub speakers: usize,
    /// Speaker classes; `None` = [`speakers::default_specs`]. Entry 0 may be `Some` to
    /// reshape speaker 0 too.
    pub speaker_specs: Option<Vec<Option<SpeakerSpec>>>,
    /// GRID sentences per speaker.
    pub sentences: usize,
    pub out_dir: PathBuf,
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    /// Render and write PNG frames (front and, with `side_view`, side).
    pub write_frames: bool,
    pub side_view: bool,
    /// Write the 161 pose OBJs and build + write the PCA model.
    pub write_model: bool,
    /// Standard deviation of the tracker noise, pixels.
    pub noise_px: f64,
    /// Fraction of frames given a gross tracker error (at least one per sentence).
    pub gross_error_rate: f64,
    /// Cap on frames per sentence (to keep tests short); `None` = the whole sentence.
    pub max_frames: Option<usize>,
}

impl Default for DemoOptions {
    fn default() -> Self {
        Self {
            seed: DEFAULT_SEED,
            speakers: 1,
            speaker_specs: None,
            sentences: 4,
            out_dir: PathBuf::from("sessions/demo"),
            width: 720,
            height: 480,
            fps: 24.0,
            write_frames: true,
            side_view: true,
            write_model: true,
            noise_px: 0.7,
            gross_error_rate: 0.03,
            max_frames: None,
        }
    }
}

/// Files of one sentence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClipOutput {
    pub name: String,
    pub words: Vec<String>,
    pub fps: f64,
    pub n_frames: usize,
    pub width: u32,
    pub height: u32,
    pub dir: PathBuf,
    pub front_dir: Option<PathBuf>,
    pub side_dir: Option<PathBuf>,
    pub phones_csv: PathBuf,
    pub tracked_csv: PathBuf,
    pub true_csv: PathBuf,
    pub truth_csv: PathBuf,
    pub errors_csv: PathBuf,
    pub injected_errors: Vec<InjectedError>,
}

/// Files and facts of one speaker.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SpeakerOutput {
    pub index: usize,
    pub dir: PathBuf,
    /// Classes it was made for (`None` for speaker 0, the head itself).
    pub made_for: Option<(String, String)>,
    pub vertical_mouth_height: f64,
    pub mouth_width: f64,
    /// This speaker's own head (the demo head for speaker 0) and its pose model (when
    /// models are written); the landmark map is the demo head's.
    pub head_obj: PathBuf,
    pub model: Option<PathBuf>,
    pub clips: Vec<ClipOutput>,
}

/// Everything [`generate`] wrote.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DemoOutput {
    pub out_dir: PathBuf,
    pub head_obj: PathBuf,
    /// eos TOML landmark map (1-based iBUG ids).
    pub landmark_map: PathBuf,
    pub poses: Vec<PathBuf>,
    pub model: Option<PathBuf>,
    pub manifest: PathBuf,
    /// Vertices of the head's upper-lip vermilion (for `UpperLip::Vertices`).
    pub upper_lip_vertices: Vec<usize>,
    pub speakers: Vec<SpeakerOutput>,
}

/// A speaker's articulated mesh vertices for one mouth shape.
fn speaker_vertices(
    head: &Head,
    fields: &ArticulationFields,
    warp: &MouthWarp,
    a: &Articulation,
) -> Vec<Point3> {
    warp.apply_all(&fields.apply(&head.mesh.vertices, a))
}

fn quantise(p: &Point3) -> Point3 {
    p.map(|c| (c * 1e4).round() / 1e4)
}

fn write_png(img: &image::RgbImage, path: &Path) -> Result<()> {
    crate::io::atomic::write_atomic(path, |w| {
        let enc = PngEncoder::new_with_quality(w, CompressionType::Fast, FilterType::Sub);
        img.write_with_encoder(enc).map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// A frame to render: which clip, which frame, the mouth shape and the cameras.
struct RenderJob {
    speaker: usize,
    front_path: PathBuf,
    side_path: Option<PathBuf>,
    articulation: Articulation,
    front: Camera,
    side: Camera,
}

/// Generates the demo into `opts.out_dir` (created if missing; existing files overwritten).
///
/// # Errors
/// Invalid options (no speakers, zero-sized images, non-positive fps), a speaker class that
/// cannot be reached, and any I/O failure, naming the file.
pub fn generate(opts: &DemoOptions) -> Result<DemoOutput> {
    anyhow::ensure!(opts.speakers >= 1, "at least one speaker is needed");
    anyhow::ensure!(
        opts.width >= 16 && opts.height >= 16,
        "image too small: {}×{}",
        opts.width,
        opts.height
    );
    anyhow::ensure!(opts.fps.is_finite() && opts.fps > 0.0, "fps must be positive");
    let out = &opts.out_dir;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;

    let (head, fields) = demo_head();

    let head_obj = out.join("head.obj");
    crate::io::obj::write_obj(&head_obj, &head.mesh)?;
    let landmark_map = out.join("head_map.toml");
    // The shipped names: the demo's files are the same whatever tables a user installed.
    let names = crate::landmarks::LandmarkNames::builtin();
    crate::io::landmark_map_toml::write_landmark_map(&landmark_map, &head.landmarks, &names)?;

    let mut poses = Vec::new();
    let mut model_path = None;
    let mut pose_set: Vec<Mesh> = Vec::new();
    if opts.write_model {
        let pose_dir = out.join("poses");
        std::fs::create_dir_all(&pose_dir)
            .with_context(|| format!("creating {}", pose_dir.display()))?;
        let meshes: Vec<Mesh> = visemes::pose_meshes(&head, &fields)
            .into_iter()
            .map(|(_, mut m)| {
                m.vertices.iter_mut().for_each(|p| *p = quantise(p));
                m
            })
            .collect();
        poses = (0..meshes.len()).map(|i| pose_dir.join(format!("pose_{i:03}.obj"))).collect();
        meshes
            .par_iter()
            .zip(poses.par_iter())
            .try_for_each(|(m, p)| crate::io::obj::write_obj(p, m))?;
        let shapes: Vec<_> = meshes.iter().map(Mesh::to_flat).collect();
        let shape = build_pca_from_shapes(&shapes, Keep::Components(DEMO_MODEL_COMPONENTS))
            .map_err(|e| anyhow::anyhow!("building the demo PCA model: {e}"))?;
        let model = MorphableModel { shape, expressions: None, triangles: head.mesh.triangles() };
        let path = out.join("model.lmm");
        write_model_file(&path, &model, Precision::F64)?;
        model_path = Some(path);
        pose_set = meshes;
    }

    let mut rng = StdRng::seed_from_u64(opts.seed);
    let specs =
        opts.speaker_specs.clone().unwrap_or_else(|| speakers::default_specs(opts.speakers));
    let measure_opts = MeshMeasureOptions::default();
    let lip_region_opts = MeshMeasureOptions {
        upper_lip: crate::measure::UpperLip::Vertices(head.upper_lip.clone()),
        ..MeshMeasureOptions::default()
    };
    let mut speaker_outputs = Vec::new();
    let mut speaker_list: Vec<Speaker> = Vec::new();
    let mut jobs = Vec::new();
    for si in 0..opts.speakers {
        let spec = specs.get(si).copied().flatten();
        let scale = if si == 0 { 1.0 } else { rng.random_range(0.95..1.05) };
        let speaker = speakers::make_speaker(&head, si, spec, scale)
            .map_err(|e| anyhow::anyhow!("speaker {si}: {e}"))?;
        let sdir = out.join(format!("speaker_{si:02}"));
        std::fs::create_dir_all(&sdir).with_context(|| format!("creating {}", sdir.display()))?;
        // Each reshaped speaker also gets its own head and pose model, so a speaker can be
        // fitted onto its own (corresponding) head or onto another, as `eval --heads`
        // compares them.
        let (speaker_head, speaker_model) = if si == 0 || pose_set.is_empty() {
            (head_obj.clone(), model_path.clone())
        } else {
            let warped = |m: &Mesh| Mesh {
                vertices: m.vertices.iter().map(|p| quantise(&speaker.warp.apply(p))).collect(),
                faces: Vec::new(),
            };
            let neutral = Mesh { faces: head.mesh.faces.clone(), ..warped(&head.mesh) };
            let hpath = sdir.join("head.obj");
            crate::io::obj::write_obj(&hpath, &neutral)?;
            let shapes: Vec<_> = pose_set.iter().map(|m| warped(m).to_flat()).collect();
            let shape = build_pca_from_shapes(&shapes, Keep::Components(DEMO_MODEL_COMPONENTS))
                .map_err(|e| anyhow::anyhow!("building speaker {si}'s PCA model: {e}"))?;
            let model =
                MorphableModel { shape, expressions: None, triangles: head.mesh.triangles() };
            let mpath = sdir.join("model.lmm");
            write_model_file(&mpath, &model, Precision::F64)?;
            (hpath, Some(mpath))
        };
        let mut clips = Vec::new();
        for ci in 0..opts.sentences {
            let words = lexicon::random_sentence(&mut rng);
            let alignment = lexicon::time_sentence(&words, &mut rng).map_err(anyhow::Error::msg)?;
            let name = format!("s{}_{}", ci + 1, words.join("_"));
            let dir = sdir.join(&name);
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            let mut n_frames = (alignment.duration() * opts.fps - 1e-9).ceil().max(1.0) as usize;
            if let Some(cap) = opts.max_frames {
                n_frames = n_frames.min(cap.max(1));
            }
            let traj = coart::mouth_trajectory(&alignment, opts.fps, n_frames);
            let motion = head_motion(&mut rng, n_frames, opts.fps);
            let mut rows = Vec::with_capacity(n_frames);
            let mut true_points = Vec::with_capacity(n_frames);
            for f in 0..n_frames {
                let a = traj[f];
                let verts = speaker_vertices(&head, &fields, &speaker.warp, &a);
                let flat = Mesh { vertices: verts, faces: Vec::new() }.to_flat();
                let m = measure_shape(&flat, &head.landmarks, &measure_opts)
                    .map_err(|e| anyhow::anyhow!("measuring frame {f} of {name}: {e}"))?;
                let p_lip = measure_shape(&flat, &head.landmarks, &lip_region_opts)
                    .map_err(|e| anyhow::anyhow!("measuring frame {f} of {name}: {e}"))?
                    .p
                    .unwrap_or(f64::NAN);
                let verts = Mesh::from_flat(flat.as_slice(), Vec::new()).vertices;
                let (front, side) = frame_cameras(&motion[f], opts.width, opts.height);
                let pts: Vec<Point2> = (0..N_LANDMARKS)
                    .map(|l| front.project(&verts[head.landmarks.vertex(l).unwrap_or(0)]))
                    .collect();
                let img = measure_points(&pts.iter().map(|p| Some(*p)).collect::<Vec<_>>())
                    .map_err(|e| anyhow::anyhow!("image measures of frame {f} of {name}: {e}"))?;
                // Side-image columns of the foremost upper-lip vertex and of the reference
                // plane (inner eye corners), for checking a profile analysis.
                let lip_side_u = head
                    .upper_lip
                    .iter()
                    .map(|&v| side.project(&verts[v]).x)
                    .fold(f64::NEG_INFINITY, f64::max);
                let eye = |l: usize| side.project(&verts[head.landmarks.vertex(l).unwrap_or(0)]).x;
                let ref_side_u = 0.5 * (eye(39) + eye(42));
                let t = f as f64 / opts.fps;
                let phone = alignment.phone_at(t).map_or("sil".to_string(), |p| p.label.clone());
                let viseme = visemes::phone_viseme(&phone).map_or("sil", |v| v.name()).to_string();
                rows.push(TruthRow {
                    time: t,
                    phone,
                    viseme,
                    w: m.w,
                    h: m.h,
                    p: m.p.unwrap_or(f64::NAN),
                    p_lip,
                    w_img: img.w,
                    h_img: img.h,
                    motion: motion[f],
                    front,
                    side,
                    lip_side_u,
                    ref_side_u,
                    articulation: a,
                });
                true_points.push(pts);
            }
            let (tracked, errors) = simulate_tracker(
                &true_points,
                opts.fps,
                opts.noise_px,
                opts.gross_error_rate,
                &mut rng,
            );
            let phones_csv = dir.join("phones.csv");
            crate::io::phones_csv::write_phones_csv(&alignment, &phones_csv)?;
            let tracked_csv = dir.join("landmarks_tracked.csv");
            crate::io::track_csv::write_track_csv(&tracked, &tracked_csv)?;
            let true_csv = dir.join("landmarks_true.csv");
            crate::io::track_csv::write_track_csv(
                &points_to_track(&true_points, opts.fps),
                &true_csv,
            )?;
            let truth_csv = dir.join("truth.csv");
            crate::io::atomic::write_atomic_bytes(&truth_csv, format_truth(&rows).as_bytes())
                .with_context(|| format!("writing {}", truth_csv.display()))?;
            let errors_csv = dir.join("errors.csv");
            crate::io::atomic::write_atomic_bytes(&errors_csv, format_errors(&errors).as_bytes())
                .with_context(|| format!("writing {}", errors_csv.display()))?;
            let (front_dir, side_dir) = if opts.write_frames {
                let fd = dir.join("front");
                std::fs::create_dir_all(&fd)
                    .with_context(|| format!("creating {}", fd.display()))?;
                let sd = if opts.side_view {
                    let sd = dir.join("side");
                    std::fs::create_dir_all(&sd)
                        .with_context(|| format!("creating {}", sd.display()))?;
                    Some(sd)
                } else {
                    None
                };
                for (f, r) in rows.iter().enumerate() {
                    jobs.push(RenderJob {
                        speaker: si,
                        front_path: fd.join(format!("frame_{f:05}.png")),
                        side_path: sd.as_ref().map(|d| d.join(format!("frame_{f:05}.png"))),
                        articulation: r.articulation,
                        front: r.front,
                        side: r.side,
                    });
                }
                (Some(fd), sd)
            } else {
                (None, None)
            };
            clips.push(ClipOutput {
                name,
                words: words.iter().map(|w| w.to_string()).collect(),
                fps: opts.fps,
                n_frames,
                width: opts.width,
                height: opts.height,
                dir,
                front_dir,
                side_dir,
                phones_csv,
                tracked_csv,
                true_csv,
                truth_csv,
                errors_csv,
                injected_errors: errors,
            });
        }
        speaker_outputs.push(SpeakerOutput {
            index: si,
            dir: sdir,
            made_for: spec
                .map(|s| (s.vertical_mouth_height.to_string(), s.mouth_width.to_string())),
            vertical_mouth_height: speaker.vertical_mouth_height,
            mouth_width: speaker.mouth_width,
            head_obj: speaker_head,
            model: speaker_model,
            clips,
        });
        speaker_list.push(speaker);
    }

    let triangles = head.mesh.triangles();
    let side_opts = RenderOptions {
        background: SIDE_BACKGROUND,
        light: Vector3::new(0.2, 0.3, 1.0),
        ambient: 0.6,
    };
    let front_opts = RenderOptions::default();
    jobs.par_iter().try_for_each(|job| -> Result<()> {
        let warp = &speaker_list[job.speaker].warp;
        let verts = speaker_vertices(&head, &fields, warp, &job.articulation);
        let img = render_mesh(&verts, &triangles, &head.colours, &job.front, &front_opts)?;
        write_png(&img, &job.front_path)?;
        if let Some(p) = &job.side_path {
            let img = render_mesh(&verts, &triangles, &head.colours, &job.side, &side_opts)?;
            write_png(&img, p)?;
        }
        Ok(())
    })?;

    let manifest = out.join("manifest.json");
    let output = DemoOutput {
        out_dir: out.clone(),
        head_obj,
        landmark_map,
        poses,
        model: model_path,
        manifest: manifest.clone(),
        upper_lip_vertices: head.upper_lip.clone(),
        speakers: speaker_outputs,
    };
    let json = serde_json::to_string_pretty(&output)?;
    crate::io::atomic::write_atomic_bytes(&manifest, json.as_bytes())
        .with_context(|| format!("writing {}", manifest.display()))?;
    Ok(output)
}

/// The demo head, its articulation fields and the rendering colours, for callers that want
/// to pose and render it themselves (TUI previews, benchmarks).
///
/// Vertices are rounded to 0.1 µm, as `generate` writes them, so this head is exactly the
/// one in `head.obj`.
pub fn demo_head() -> (Head, ArticulationFields) {
    let mut head = head::build_head();
    for p in &mut head.mesh.vertices {
        *p = quantise(p);
    }
    let fields = ArticulationFields::new(&head);
    (head, fields)
}
