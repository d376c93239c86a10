//! Demo sessions: one session per generated demo speaker (frames, tracked landmarks, phones,
//! side view, the demo head, its PCA model and landmark map), as `lipmap demo` and the tests
//! make them.

use super::error::{Error, Result};
use crate::demo::{DemoOutput, SpeakerOutput};
use crate::io::alignment_format::read_alignment;
use crate::io::landmark_format::read_track;
use crate::session::{Clip, FramesRef, ModelRef, Session, View};
use std::path::{Path, PathBuf};

/// Session file of speaker `k` in the demo folder.
pub fn demo_session_path(out_dir: &Path, speaker: usize) -> PathBuf {
    if speaker == 0 {
        out_dir.join("demo.lipmap.json")
    } else {
        out_dir.join(format!("speaker_{speaker:02}.lipmap.json"))
    }
}

/// Builds and saves one session per demo speaker (frames, tracked landmarks, phones, side
/// view, the demo head, its PCA model and landmark map); returns the session files.
///
/// # Errors
/// Any generated file that cannot be read back (a bug, reported with its path).
pub fn write_demo_sessions(out: &DemoOutput) -> Result<Vec<PathBuf>> {
    let mut paths = Vec::new();
    for sp in &out.speakers {
        let path = demo_session_path(&out.out_dir, sp.index);
        let session = demo_session(out, sp, &path)?;
        session.save(&path)?;
        paths.push(path);
    }
    Ok(paths)
}

fn demo_session(out: &DemoOutput, sp: &SpeakerOutput, path: &Path) -> Result<Session> {
    let mut session = Session::new(path);
    session.head_mesh = Some(abs(&out.head_obj));
    let model = out
        .model
        .clone()
        .ok_or_else(|| Error::Invalid("the demo was generated without its model".into()))?;
    session.model = Some(ModelRef { path: abs(&model), blendshapes: None });
    session.landmark_map.file = Some(abs(&out.landmark_map));
    for c in &sp.clips {
        let front_dir = c.front_dir.clone().unwrap_or_else(|| c.dir.join("front"));
        let mut front = View::new(FramesRef::Images { dir: abs(&front_dir) }, c.fps);
        front.size = Some([c.width, c.height]);
        let mut clip = Clip::new(c.name.clone(), front);
        if let Some(side) = &c.side_dir {
            let mut v = View::new(FramesRef::Images { dir: abs(side) }, c.fps);
            v.size = Some([c.width, c.height]);
            clip.side = Some(v);
        }
        clip.tracked = read_track(&c.tracked_csv)?;
        clip.landmarks_file = Some(abs(&c.tracked_csv));
        clip.alignment = Some(read_alignment(&c.phones_csv, None)?);
        clip.alignment_file = Some(abs(&c.phones_csv));
        session.add_clip(clip)?;
    }
    Ok(session)
}

fn abs(p: &Path) -> PathBuf {
    crate::session::absolute(p)
}
