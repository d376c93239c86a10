//! Fitting a session's clips with the fit cache: refit only what the cache cannot give.
//!
//! Start with [`fit_session`] (what `lipmap fit SESSION` does) or, for a use case that fits
//! on its way to something else, [`fit_clip_cached`].

use super::error::{Progress, ProgressFn, Result, Warning};
use super::flags::clip_flag_lines;
use super::resources::{FitRefusal, Resources, check_before_fit, load_resources};
use super::session::{EditSession, image_height, select_clips};
use crate::fit::{FitSettings, FrameFit, fit_clip, fitted_shape};
use crate::landmarks::FrameLandmarks;
use crate::math::DVector;
use crate::model::MorphableModel;
use crate::session::Session;

/// What fitting one clip did.
#[derive(Clone, Debug)]
pub struct ClipFits {
    /// One fit per frame with landmarks, ascending by frame.
    pub fits: Vec<FrameFit>,
    /// How many frames were fitted now (the rest came from the cache).
    pub refitted: usize,
    /// Said when the fits all came from the cache although the model map now fails the
    /// anatomy check (accepted when they were made: the TUI's second `f`, or
    /// `--accept-map-warnings`): the fits are used, not silently.
    pub map_warning: Option<Warning>,
}

impl ClipFits {
    pub fn failed(&self) -> usize {
        self.fits.iter().filter(|f| !f.is_usable()).count()
    }
}

/// Fits clip `clip` with `settings`, refitting only what the cache cannot give: the stale
/// frames in per-frame mode, the whole clip in clip mode (its identity is shared, so one
/// changed frame changes them all). The new fits are stored in the session's cache.
/// `progress` receives (frames done, frames to do).
///
/// # Errors
/// Unknown clip; landmarks missing for a frame the cache names; when anything needs
/// fitting, a map the fit refuses ([`check_before_fit`]), before anything is fitted.
pub fn fit_clip_cached(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    settings: &FitSettings,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ClipFits> {
    let stale = session.stale_frames_with(clip, settings)?;
    let mut map_warning = None;
    if !stale.is_empty() {
        check_before_fit(&res.model, &res.map, settings, res.accept_map_warnings)?;
    } else if !res.accept_map_warnings
        && let Err(FitRefusal::Implausible { problems }) =
            check_before_fit(&res.model, &res.map, settings, false)
    {
        map_warning = Some(Warning(format!(
            "lipmap: warning: clip `{}`: its fits were made earlier with a model map that fails \
             the anatomy check, accepted then ({}); `lipmap map check` lists them",
            session.clip(clip)?.name,
            super::resources::problems_summary(&problems)
        )));
    }
    let height = image_height(session, clip)?;
    let track = session.fit_input_track(clip, settings)?;
    let to_fit: Vec<FrameLandmarks> = if stale.is_empty() {
        Vec::new()
    } else if settings.clip {
        track.frames.clone()
    } else {
        let stale: std::collections::BTreeSet<usize> = stale.into_iter().collect();
        track.frames.iter().filter(|f| stale.contains(&f.frame)).cloned().collect()
    };
    let refitted = to_fit.len();
    if refitted > 0 {
        let total = refitted;
        let report = |done: usize| {
            if let Some(p) = progress {
                p(done, total);
            }
        };
        let fits = fit_clip(&res.model, &res.map, &to_fit, height, settings, Some(&report));
        session.store_fits(clip, settings, fits)?;
    }
    let fits = session.cached_fits(clip, settings)?;
    Ok(ClipFits { fits, refitted, map_warning })
}

/// One clip of a session, fitted.
#[derive(Clone, Debug)]
pub struct ClipFitted {
    pub name: String,
    pub fits: ClipFits,
    /// The clip's flags as lines: a count, then one line per flagged frame
    /// ([`super::flags::flag_lines`]).
    pub flag_lines: Vec<String>,
}

/// What [`fit_session`] hands its caller as it goes: what was worked around (before any
/// clip is fitted), then each clip as soon as it is fitted.
#[derive(Debug)]
pub enum FitStep {
    Warning(Warning),
    Clip(ClipFitted),
}

/// What fitting a session came to, counted clip by clip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SessionFitted {
    pub clips: usize,
    pub frames: usize,
    /// Frames whose fit failed.
    pub failed: usize,
}

impl SessionFitted {
    /// Whether any frame of any clip failed.
    pub fn any_failed(&self) -> bool {
        self.failed > 0
    }
}

/// Fits the clips of an opened session (the one called `only`, or all) with `settings`,
/// which become the session's fit settings, then saves the session with the new fits.
/// Each clip goes to `each` as soon as it is fitted, and is not kept: a corpus's fit needs
/// in memory one clip at a time. Progress: a stage per clip, then its frames.
///
/// # Errors
/// As [`load_resources`], [`select_clips`] and [`fit_clip_cached`]; `each`'s error; the
/// save's error.
pub fn fit_session(
    opened: &mut EditSession,
    settings: &FitSettings,
    only: Option<&str>,
    accept_map_warnings: bool,
    progress: ProgressFn<'_>,
    each: &mut dyn FnMut(FitStep) -> Result<()>,
) -> Result<SessionFitted> {
    let session = &mut opened.session;
    session.fit_settings = settings.clone();
    let (mut res, warnings) = load_resources(session, &opened.path)?;
    res.accept_map_warnings = accept_map_warnings;
    for w in warnings {
        each(FitStep::Warning(w))?;
    }
    // Said once, before the fits, rather than refused (the user accepted them).
    if let Ok(accepted) = check_before_fit(&res.model, &res.map, settings, accept_map_warnings) {
        for p in accepted {
            let w = Warning(format!("lipmap: warning: fitting with a model map problem: {p}"));
            each(FitStep::Warning(w))?;
        }
    }
    let mut out = SessionFitted::default();
    for c in select_clips(session, only)? {
        let name = session.clip(c)?.name.clone();
        progress(Progress::Stage { what: format!("fitting {name}"), total: 0 });
        let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
        let fits = fit_clip_cached(session, &res, c, settings, Some(&steps))?;
        if let Some(w) = fits.map_warning.clone() {
            each(FitStep::Warning(w))?;
        }
        let flag_lines = clip_flag_lines(session, c, &fits.fits)?;
        out.clips += 1;
        out.frames += fits.fits.len();
        out.failed += fits.failed();
        each(FitStep::Clip(ClipFitted { name, fits, flag_lines }))?;
    }
    progress(Progress::Finished);
    opened.save()?;
    Ok(out)
}

/// Fitted model-space shapes indexed by frame number (`None` for failed or missing fits),
/// `n_frames` long. Every shape is a whole mesh: for measures use
/// [`super::measure_fits::head_trajectory`], which keeps none.
pub fn shapes_by_frame(
    model: &MorphableModel,
    fits: &[FrameFit],
    n_frames: usize,
) -> Vec<Option<DVector>> {
    let mut shapes = vec![None; n_frames];
    for f in fits.iter().filter(|f| f.is_usable_within(n_frames)) {
        shapes[f.frame] = Some(fitted_shape(model, f));
    }
    shapes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::MapRole;
    use crate::workflow::create::{ClipInputs, NewSession, create_session};
    use crate::workflow::map::{check_session_map, label_role};
    use crate::workflow::{Error, FitRefusal, open_for_edit_at};

    /// The eos SFM map with the eyes' and the outer mouth's vertices exchanged.
    fn swapped(map: &crate::model::LandmarkMap) -> crate::model::LandmarkMap {
        let mut out = map.clone();
        for k in 0..12 {
            let (eye, mouth) = (36 + k, 48 + k);
            if let (Some(a), Some(b)) = (map.vertex(eye), map.vertex(mouth)) {
                out.to_vertex.insert(eye, b);
                out.to_vertex.insert(mouth, a);
            }
        }
        out
    }

    #[test]
    fn sfm_model_and_makehuman_head_get_two_maps_and_a_swapped_map_is_refused() {
        let (Some(eos), Some(data)) =
            (crate::testdata::shared("peer/eos/share"), crate::testdata::shared("data"))
        else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let map_file = eos.join("ibug_to_sfm.txt");
        let new = |path: &std::path::Path, mapping: &std::path::Path| NewSession {
            path: path.to_path_buf(),
            clip: ClipInputs {
                frames: data.join("carphone/frames"),
                landmarks: crate::workflow::create::LandmarkInput::File(
                    data.join("carphone/dlib68_pts"),
                ),
                fps: Some(30.0),
                ..Default::default()
            },
            head: Some(data.join("makehuman/base.obj")),
            model: eos.join("sfm_shape_3448.bin"),
            blendshapes: None,
            mapping: Some(mapping.to_path_buf()),
            set: crate::landmarks::LandmarkSet::F4,
            force: false,
            // The swapped map below is made to fail the checks: it is created anyway, to
            // see the fit refuse it.
            accept_map_warnings: true,
        };
        // Two meshes, two maps: the model's is the eos map, the head's is still to label.
        let path = dir.path().join("s.lipmap.json");
        let created = create_session(&new(&path, &map_file)).unwrap();
        assert!(created.head.as_ref().is_some_and(|h| h.needs_own_map()));
        let opened = open_for_edit_at(&path).unwrap();
        let s = &opened.session;
        assert_eq!(s.head_map, Some(crate::session::MapRef::default()));
        assert_eq!(label_role(s), MapRole::Head);
        let model_check = check_session_map(s, MapRole::Model).unwrap().unwrap();
        assert!(model_check.is_plausible(), "{}", model_check.summary());
        assert!(check_session_map(s, MapRole::Head).unwrap().is_none());
        drop(opened);

        // The swapped map: refused with its problems, fitted when accepted.
        let sfm = crate::io::landmark_map_toml::read_landmark_map(&map_file).unwrap();
        let bad = dir.path().join("swapped.toml");
        let names = &crate::reference::current().names;
        crate::io::landmark_map_toml::write_landmark_map(&bad, &swapped(&sfm), names).unwrap();
        let path = dir.path().join("w.lipmap.json");
        create_session(&new(&path, &bad)).unwrap();
        let mut opened = open_for_edit_at(&path).unwrap();
        let settings = opened.session.fit_settings.clone();
        let quiet = |_: Progress| {};
        let mut steps = Vec::new();
        let mut keep = |step: FitStep| {
            steps.push(step);
            Ok(())
        };
        let e = fit_session(&mut opened, &settings, None, false, &quiet, &mut keep).unwrap_err();
        let Error::FitRefused(FitRefusal::Implausible { problems }) = &e else {
            panic!("expected the map refused, got {e}")
        };
        assert!(problems.iter().any(|p| p.contains("swapped left/right")), "{problems:?}");
        assert!(e.to_string().contains("--accept-map-warnings"), "{e}");
        assert!(!opened.session.has_cached_fits(), "nothing fitted");
        let fitted = fit_session(&mut opened, &settings, None, true, &quiet, &mut keep).unwrap();
        assert_eq!((fitted.clips, fitted.frames), (1, 120));
        let clips: Vec<&ClipFitted> = steps
            .iter()
            .filter_map(|s| if let FitStep::Clip(c) = s { Some(c) } else { None })
            .collect();
        assert_eq!(clips.len(), 1);
        assert_eq!(clips[0].fits.fits.len(), 120);
        assert_eq!(fitted.failed, clips[0].fits.failed());
        let warned =
            |s: &FitStep| matches!(s, FitStep::Warning(w) if w.0.contains("swapped left/right"));
        let first_clip = steps.iter().position(|s| matches!(s, FitStep::Clip(_))).unwrap();
        assert!(steps[..first_clip].iter().any(warned), "the map warning comes before the fits");
        // Fitted once with the map accepted, a fit without accepting it uses those fits and
        // says so (it refused before they were made).
        steps.clear();
        let mut keep = |step: FitStep| {
            steps.push(step);
            Ok(())
        };
        fit_session(&mut opened, &settings, None, false, &quiet, &mut keep).unwrap();
        let said = |s: &FitStep| matches!(s, FitStep::Warning(w) if w.0.contains("fails the anatomy check, accepted then"));
        assert_eq!(steps.iter().filter(|s| said(s)).count(), 1);
        // The same cached fits driven onto a head say it too.
        let res = crate::workflow::resources::Resources::load(&opened.session).unwrap();
        let request = crate::workflow::transfer::TransferRequest {
            head: data.join("makehuman/base.obj"),
            mapping: Some(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("tests/fixtures/makehuman_ibug68.toml"),
            ),
            mode: crate::transfer::Interpolation::default(),
            clips: vec![0],
            out_dir: dir.path().join("transferred"),
            objs: false,
            accept_map_warnings: false,
        };
        let report = crate::workflow::transfer::transfer_session(
            &mut opened.session,
            &res,
            &request,
            &quiet,
        )
        .unwrap();
        assert!(report.warnings.iter().any(|w| w.0.contains("accepted then")), "{report:?}");
    }
}
