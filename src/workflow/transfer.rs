//! Transferring a session's fitted motion onto another head (`lipmap transfer`, `eval`, the
//! TUI): load the head and its landmark map, set the transfer up from the session's model,
//! move the head frame by frame, write `shapes.npy` (and OBJs), and record the head in the
//! session so `eval` can measure it again.
//!
//! Start at [`transfer_session`]; [`set_up_for_head`] and [`transferred_utterance`] serve
//! `eval` and the TUI.

use super::error::{Error, Result};
use super::fit::fit_clip_cached;
use super::measure_fits::measure_posed;
use super::resources::Resources;
use super::{Progress, ProgressFn};
use crate::eval::Utterance;
use crate::fit::{FrameFit, fitted_shape};
use crate::io::atomic::write_atomic_bytes;
use crate::io::{landmark_map_toml, npy_model, obj};
use crate::math::DVector;
use crate::measure::{Measure, MeshMeasureOptions, MouthMeasures, PoseComparison, Trajectory};
use crate::model::{LandmarkMap, Mesh};
use crate::session::{Session, TransferredHead};
use crate::transfer::{Interpolation, SourceFace, TargetHead, Transfer, TransferOptions};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A head to transfer onto, read from its files.
#[derive(Clone, Debug)]
pub struct TargetFiles {
    pub mesh: Mesh,
    /// Skin mask (helper/joint geometry excluded); empty when the OBJ has no such groups.
    pub skin: Vec<bool>,
    /// The head's landmark map, mouth corners completed.
    pub map: LandmarkMap,
}

/// Reads a head OBJ and its landmark map.
///
/// # Errors
/// Either file's format error, naming the file and line.
pub fn load_target(head: &Path, mapping: &Path) -> Result<TargetFiles> {
    let mesh = obj::read_obj(head)?;
    let skin = obj::labelable_vertices(head)?.unwrap_or_default();
    let map = landmark_map_toml::read_landmark_map(mapping)?.with_commissures_completed();
    Ok(TargetFiles { mesh, skin, map })
}

/// The map beside a head when none is named: `HEAD.toml`, else `HEAD_map.toml`.
///
/// # Errors
/// Neither exists.
pub fn default_mapping(head: &Path) -> Result<PathBuf> {
    let stem = head.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let dir = head.parent().unwrap_or(Path::new(""));
    [format!("{stem}.toml"), format!("{stem}_map.toml")]
        .into_iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            Error::Invalid(format!(
                "{}: no landmark map given, nor {stem}.toml or {stem}_map.toml beside it (give \
                 one with --mapping MAP.toml)",
                head.display()
            ))
        })
}

/// The map file of the session's head, read only, when `head` is that head and the file
/// holds the map the session uses (a map labelled in the TUI and not saved since has no
/// file to name: the error says how to write one). `None` for any other head.
///
/// # Errors
/// The session's head has no map yet, or only a labelled one without its file; a map file
/// that does not parse.
pub fn session_head_map_file(session: &Session, head: &Path) -> Result<Option<PathBuf>> {
    if !is_session_head(session, head) {
        return Ok(None);
    }
    let role = crate::session::MapRole::Head;
    let r = session.map_of(role);
    let used = r.resolve()?.filter(|m| !m.is_empty());
    let filed = match &r.file {
        Some(f) => Some(landmark_map_toml::read_landmark_map(f)?),
        None => None,
    };
    match (used, &r.file) {
        (None, _) => Err(no_head_map(head)),
        (Some(m), Some(file)) if filed.is_some_and(|f| f.to_vertex == m.to_vertex) => {
            Ok(Some(file.clone()))
        }
        (Some(_), _) => Err(Error::Invalid(format!(
            "the head {}'s map is labelled in the TUI but not saved to its file: S in the head \
             view (2) saves it, or give one with --mapping MAP.toml",
            head.display()
        ))),
    }
}

/// Whether `head` names the session's head mesh: the same file however the path is spelt
/// (`../shared/x.obj` from one folder, `/work/shared/x.obj` in the session).
fn is_session_head(session: &Session, head: &Path) -> bool {
    session.head_mesh.as_deref().map(recorded_path) == Some(recorded_path(head))
}

/// What to do when the session's head has no map yet, in one line.
fn no_head_map(head: &Path) -> Error {
    Error::Invalid(format!(
        "the head {} has no map yet: label it in the TUI (view 2) or give one with --mapping \
         MAP.toml",
        head.display()
    ))
}

/// The map file of the session's head when `head` is that head (`None` for any other head):
/// its own map when it is another mesh than the model, else the model's. A map labelled in
/// the TUI is written to `write_dir` as `NAME.head_map.toml` first (beside the session when
/// it will be saved, and then recorded as the head map's file), so the transferred head
/// names a file as every other does.
///
/// # Errors
/// The session's head has no map yet (what to do, in one line); a map file that does not
/// parse; the map file cannot be written.
pub fn session_head_mapping(
    session: &mut Session,
    head: &Path,
    write_dir: &Path,
) -> Result<Option<PathBuf>> {
    if !is_session_head(session, head) {
        return Ok(None);
    }
    let role = crate::session::MapRole::Head;
    let Some(map) = session.map_of(role).resolve()?.filter(|m| !m.is_empty()) else {
        return Err(no_head_map(head));
    };
    let r = session.map_of(role).clone();
    if let (Some(file), None) = (&r.file, &r.inline) {
        return Ok(Some(file.clone()));
    }
    std::fs::create_dir_all(write_dir).map_err(|e| Error::io(write_dir, e))?;
    let file = write_dir.join(format!("{}.head_map.toml", session.name));
    landmark_map_toml::write_landmark_map(&file, &map, &crate::reference::current().names)?;
    // The model's map keys the fit cache: a file written from it is not recorded there.
    if session.head_has_own_map() {
        session.map_of_mut(role).file = Some(file.clone());
    }
    Ok(Some(file))
}

/// The interpolation named `biharmonic` or `barycentric`.
///
/// # Errors
/// Any other name.
pub fn parse_mode(name: &str) -> Result<Interpolation> {
    match name {
        "biharmonic" => Ok(Interpolation::Biharmonic),
        "barycentric" => Ok(Interpolation::Barycentric),
        other => Err(Error::Invalid(format!(
            "unknown transfer mode `{other}` (biharmonic or barycentric)"
        ))),
    }
}

/// The name [`parse_mode`] reads.
pub fn mode_name(mode: Interpolation) -> &'static str {
    match mode {
        Interpolation::Biharmonic => "biharmonic",
        Interpolation::Barycentric => "barycentric",
    }
}

/// Sets up the transfer from the session's model onto `target`. The motion's reference is
/// the session's head mesh when it is the model's neutral (same vertex count), else the
/// model's mean. Errors of the setup name the head file.
///
/// # Errors
/// [`Error::Invalid`] with the transfer's reason (too few landmarks labelled on both sides,
/// a map for another mesh, degenerate or non-manifold triangles, …).
pub fn set_up_for_head(
    res: &Resources,
    target: &TargetFiles,
    mode: Interpolation,
    head: &Path,
) -> Result<Transfer> {
    let reference = match &res.head {
        Some(mesh) if mesh.vertices.len() == res.model.num_vertices() => mesh.to_flat(),
        _ => res.model.shape.mean.clone(),
    };
    let source_map = res.map.with_commissures_completed();
    let source = SourceFace {
        reference: &reference,
        triangles: &res.model.triangles,
        landmarks: &source_map,
        identity: None,
        face: None,
    };
    let head_side = TargetHead { mesh: &target.mesh, skin: &target.skin, landmarks: &target.map };
    let options = TransferOptions { interpolation: mode, ..TransferOptions::default() };
    Transfer::new(source, head_side, &options)
        .map_err(|e| Error::Invalid(format!("{}: {e}", head.display())))
}

/// The transferred head's vertices for each usable fit, as (frame, flat vertices).
///
/// # Errors
/// A fitted shape the transfer refuses (non-finite values), naming the frame.
pub fn transfer_fits(
    res: &Resources,
    transfer: &Transfer,
    fits: &[FrameFit],
) -> Result<Vec<(usize, DVector)>> {
    fits.iter()
        .filter(|f| f.is_usable())
        .map(|f| Ok((f.frame, transfer_fit(res, transfer, f)?)))
        .collect()
}

/// The transferred head's vertices (flat) for one fit.
fn transfer_fit(res: &Resources, transfer: &Transfer, fit: &FrameFit) -> Result<DVector> {
    transfer
        .apply(&fitted_shape(&res.model, fit))
        .map_err(|e| Error::Invalid(format!("frame {}: {e}", fit.frame)))
}

/// What a transfer run asks for.
#[derive(Clone, Debug)]
pub struct TransferRequest {
    pub head: PathBuf,
    /// `None`: [`default_mapping`].
    pub mapping: Option<PathBuf>,
    pub mode: Interpolation,
    /// Only this clip (default: all).
    pub clips: Vec<usize>,
    pub out_dir: PathBuf,
    /// Also write one OBJ per frame.
    pub objs: bool,
    /// Transfer with a map that fails the map checks (`lipmap map check`) anyway.
    pub accept_map_warnings: bool,
}

/// What a transfer run did.
#[derive(Clone, Debug)]
pub struct TransferReport {
    /// The name the head is recorded under in the session.
    pub head_name: String,
    pub setup: Duration,
    /// Mean time of one frame's transfer (the fit and the writing excluded).
    pub per_frame: Duration,
    /// RMS landmark residual of the placement before and after adapting the source.
    pub residual_rigid: f64,
    pub residual: f64,
    pub controls: usize,
    pub triangles_dropped: usize,
    /// The head's outer-eye-corner distance in its own units (both corners labelled): the
    /// yardstick the residuals are read against.
    pub eye_distance: Option<f64>,
    /// (clip name, frames written, folder).
    pub clips: Vec<(String, usize, PathBuf)>,
    /// The map problems accepted (`accept_map_warnings`), one line each, and the clips whose
    /// cached fits were made with a model map that fails the anatomy check.
    pub warnings: Vec<super::Warning>,
}

/// Fits the requested clips (cached), transfers every fitted frame onto the head, writes
/// `OUT/CLIP/shapes.npy` (frames × 3N, f32), `OUT/CLIP/frames.csv` (the frame number of each
/// row) and with `objs` `OUT/CLIP/frame_NNNNN.obj`, and records the head in the session
/// (the caller saves it). Progress: one stage per clip.
///
/// # Errors
/// As [`load_target`], [`set_up_for_head`], [`fit_clip_cached`]; an unwritable output.
pub fn transfer_session(
    session: &mut Session,
    res: &Resources,
    request: &TransferRequest,
    progress: ProgressFn<'_>,
) -> Result<TransferReport> {
    let mapping = match &request.mapping {
        Some(m) => m.clone(),
        None => default_mapping(&request.head)?,
    };
    let target = load_target(&request.head, &mapping)?;
    // The map as written (before the mouth corners are completed), checked as `map check`
    // checks it: a left/right swap would mirror every frame's motion.
    let mut warnings = super::map::check_map_to_use(
        &landmark_map_toml::read_landmark_map(&mapping)?,
        &mapping,
        &request.head.display().to_string(),
        &target.mesh.vertices,
        &target.mesh.triangles(),
        request.accept_map_warnings,
    )?;
    let start = Instant::now();
    let transfer = set_up_for_head(res, &target, request.mode, &request.head)?;
    let setup = start.elapsed();
    let settings = session.fit_settings.clone();
    let (mut applied, mut frames_done) = (Duration::ZERO, 0usize);
    let mut clips = Vec::new();
    // Clip names come from the session file, which anyone may have edited: each clip's
    // folder is its safe file name, made a real folder inside --out (never a link out).
    let names: Vec<String> =
        request.clips.iter().map(|&c| Ok(session.clip(c)?.name.clone())).collect::<Result<_>>()?;
    let files = super::export::safe_file_names(&names);
    std::fs::create_dir_all(&request.out_dir).map_err(|e| Error::io(&request.out_dir, e))?;
    for ((&c, name), file) in request.clips.iter().zip(names).zip(files) {
        progress(Progress::Stage { what: format!("transferring {name}"), total: 0 });
        let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
        let clip_fits = fit_clip_cached(session, res, c, &settings, Some(&steps))?;
        warnings.extend(clip_fits.map_warning);
        let fits = clip_fits.fits;
        let start = Instant::now();
        let shapes = transfer_fits(res, &transfer, &fits)?;
        applied += start.elapsed();
        frames_done += shapes.len();
        let dir = request.out_dir.join(&file);
        super::export::ensure_real_dir(&dir)?;
        write_clip(&dir, &target.mesh, &shapes, request.objs)?;
        clips.push((name, shapes.len(), dir));
    }
    progress(Progress::Finished);
    let head_name = record_head(session, &request.head, &mapping, request.mode);
    Ok(TransferReport {
        head_name,
        setup,
        per_frame: applied / frames_done.max(1) as u32,
        residual_rigid: transfer.placement.residual_rigid,
        residual: transfer.placement.residual,
        controls: transfer.target_controls.len(),
        triangles_dropped: transfer.triangles_dropped,
        eye_distance: eye_distance(&target.mesh, &target.map),
        clips,
        warnings,
    })
}

/// The distance between a head's labelled outer eye corners, in its own units.
fn eye_distance(mesh: &Mesh, map: &crate::model::LandmarkMap) -> Option<f64> {
    use crate::landmarks::ibug::point::{LEFT_EXOCANTHION, RIGHT_EXOCANTHION};
    let at = |l: usize| map.vertex(l).and_then(|v| mesh.vertices.get(v));
    let d = (at(RIGHT_EXOCANTHION)? - at(LEFT_EXOCANTHION)?).norm();
    (d > 0.0).then_some(d)
}

fn write_clip(dir: &Path, mesh: &Mesh, shapes: &[(usize, DVector)], objs: bool) -> Result<()> {
    let n3 = 3 * mesh.vertices.len();
    let data: Vec<f32> = shapes.iter().flat_map(|(_, s)| s.iter().map(|&x| x as f32)).collect();
    npy_model::write_npy_f32(&dir.join("shapes.npy"), &[shapes.len() as u64, n3 as u64], &data)?;
    let csv: String = std::iter::once("frame\n".to_string())
        .chain(shapes.iter().map(|(f, _)| format!("{f}\n")))
        .collect();
    let frames_csv = dir.join("frames.csv");
    write_atomic_bytes(&frames_csv, csv.as_bytes()).map_err(|e| Error::io(&frames_csv, e))?;
    if objs {
        for (frame, shape) in shapes {
            let mut moved = mesh.clone();
            for (p, c) in moved.vertices.iter_mut().zip(shape.as_slice().chunks_exact(3)) {
                *p = crate::math::Point3::new(c[0], c[1], c[2]);
            }
            obj::write_obj(&dir.join(format!("frame_{frame:05}.obj")), &moved)?;
        }
    }
    Ok(())
}

/// A path as recorded for a transferred head: the file's canonical path when it exists (so
/// `../data/base.obj` and `/abs/data/base.obj` are one head), else made absolute.
fn recorded_path(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).or_else(|_| std::path::absolute(p)).unwrap_or_else(|_| p.to_path_buf())
}

/// Records (or updates) the head in the session's transferred heads; returns its name.
/// Transferring onto a head again replaces its entry (one head, one set of tables), whatever
/// path named the file; entries an older lipmap recorded twice for one file become one.
pub fn record_head(
    session: &mut Session,
    head: &Path,
    mapping: &Path,
    mode: Interpolation,
) -> String {
    let mesh = recorded_path(head);
    let mapping = recorded_path(mapping);
    let mode = mode_name(mode).to_string();
    let heads = &mut session.transferred_heads;
    if let Some(first) = heads.iter().position(|h| recorded_path(&h.mesh) == mesh) {
        let name = heads[first].name.clone();
        heads.retain(|h| h.name == name || recorded_path(&h.mesh) != mesh);
        let h = &mut heads[first];
        h.mesh = mesh;
        h.mapping = mapping;
        h.mode = mode;
        return h.name.clone();
    }
    let base = mesh.file_stem().map_or_else(|| "head".into(), |s| s.to_string_lossy().into_owned());
    let mut name = base.clone();
    let mut k = 1;
    while heads.iter().any(|h| h.name == name) {
        k += 1;
        name = format!("{base}#{k}");
    }
    heads.push(TransferredHead { name: name.clone(), mesh, mapping, mode });
    name
}

/// A transferred head set up for evaluation: the transfer onto it and its landmark map.
pub struct PreparedHead {
    pub transfer: Transfer,
    pub map: LandmarkMap,
}

/// Sets up `entry`'s transferred head (its mesh and map read, the transfer prepared) so each
/// clip's head side can be measured on it ([`transferred_utterance`]).
///
/// # Errors
/// As [`load_target`], [`set_up_for_head`].
pub fn prepare_head(res: &Resources, entry: &TransferredHead) -> Result<PreparedHead> {
    let target = load_target(&entry.mesh, &entry.mapping)?;
    let transfer = set_up_for_head(res, &target, parse_mode(&entry.mode)?, &entry.mesh)?;
    Ok(PreparedHead { transfer, map: target.map })
}

/// `utterance` (the clip measured on the fitted model) with its head side measured on the
/// transferred head instead, through the head's landmark map `map`, exactly as the fitted
/// model was: the head taken into the model's space (`Transfer::in_source_space`), W and H as
/// `pose` compares them (in the image plane, the head's landmarks seen by each frame's
/// fitted camera; frontal, in the model's frontal plane, frames turned past the limit left
/// out); frames without a usable fit stay empty.
///
/// Measured in the head's own axes instead, a transferred head could not follow the video
/// in the image plane (the video's W there is mostly the speaker's pitch and yaw, which the
/// camera gives the model and gave nothing to the head: r −0.2 to 0.1 on carphone against
/// the model's 0.95), and a head standing z-up or facing −z was measured on the wrong plane.
///
/// # Errors
/// As [`transfer_fits`].
pub fn transferred_utterance(
    res: &Resources,
    transfer: &Transfer,
    map: &LandmarkMap,
    utterance: &Utterance,
    fits: &[FrameFit],
    pose: PoseComparison,
) -> Result<Utterance> {
    let n = utterance.head.w.len();
    let options = MeshMeasureOptions::default();
    let mut frames: Vec<Option<MouthMeasures>> = vec![None; n];
    for f in fits.iter().filter(|f| f.is_usable_within(n) && pose.admits(f.yaw, f.pitch)) {
        let seen = transfer.in_source_space(&transfer_fit(res, transfer, f)?);
        frames[f.frame] = measure_posed(&seen, map, &options, f, pose);
    }
    let mut head = Trajectory::from_frames(&frames);
    for m in Measure::ALL {
        head.series_mut(m).resize(n, None);
    }
    Ok(Utterance { head, ..utterance.clone() })
}
