//! Demo sessions: one session per generated demo speaker (frames, tracked landmarks, phones,
//! the voice, side view, the demo head, its PCA model and landmark map), as `lipmap demo` and the tests
//! make them.

use super::error::{Error, Result};
use crate::alignment::Alignment;
use crate::demo::voice::{VOICE_SAMPLE_RATE, speak};
use crate::demo::{DemoOutput, SpeakerOutput};
use crate::io::alignment_format::read_alignment;
use crate::io::landmark_format::read_track;
use crate::io::wav::write_wav;
use crate::session::{Clip, ClipAudio, FramesRef, ModelRef, Session, View};
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
        // A fresh session replaces the last demo's: not under an editor that has it open,
        // and without the journal of that one's edits (its clips have the same names).
        let _lock = crate::session::SessionLock::acquire(&path)?;
        session.save(&path)?;
        crate::session::journal::Journal::new(&path).clear()?;
        paths.push(path);
    }
    Ok(paths)
}

fn demo_session(out: &DemoOutput, sp: &SpeakerOutput, path: &Path) -> Result<Session> {
    let mut session = Session::new(path);
    // A corpus of sentences: each clip's landmarks go to the data folder as they are read.
    session.write_data_early(path);
    session.head_mesh = Some(abs(&out.head_obj));
    let model = out
        .model
        .clone()
        .ok_or_else(|| Error::Invalid("the demo was generated without its model".into()))?;
    session.model = Some(ModelRef { path: abs(&model), blendshapes: None });
    session.landmark_map.file = Some(abs(&out.landmark_map));
    for (k, c) in sp.clips.iter().enumerate() {
        let front_dir = c.front_dir.clone().unwrap_or_else(|| c.dir.join("front"));
        let mut front = View::new(FramesRef::Images { dir: abs(&front_dir) }, c.fps);
        front.size = Some([c.width, c.height]);
        let mut clip = Clip::new(c.name.clone(), front);
        if let Some(side) = &c.side_dir {
            let mut v = View::new(FramesRef::Images { dir: abs(side) }, c.fps);
            v.size = Some([c.width, c.height]);
            clip.side = Some(v);
        }
        clip.set_tracked(read_track(&c.tracked_csv)?);
        clip.landmarks_file = Some(abs(&c.tracked_csv));
        let alignment = read_alignment(&c.phones_csv, None)?;
        clip.audio = Some(write_demo_voice(&alignment, &c.dir, voice_seed(sp.index, k))?);
        clip.alignment = Some(alignment);
        clip.alignment_file = Some(abs(&c.phones_csv));
        session.add_clip(clip)?;
    }
    Ok(session)
}

/// The demo speaker's voice for one clip (from the same phone timings as its lips), written
/// as `voice.wav` in the clip's folder.
fn write_demo_voice(alignment: &Alignment, clip_dir: &Path, seed: u64) -> Result<ClipAudio> {
    let file = abs(&clip_dir.join("voice.wav"));
    let samples = speak(alignment, VOICE_SAMPLE_RATE, seed);
    write_wav(&file, &samples, VOICE_SAMPLE_RATE)?;
    Ok(ClipAudio { file, sample_rate: VOICE_SAMPLE_RATE, channels: 1, offset_s: 0.0 })
}

/// One voice seed per speaker and clip, so no two clips share their noise.
fn voice_seed(speaker: usize, clip: usize) -> u64 {
    (speaker as u64) << 20 | clip as u64
}

fn abs(p: &Path) -> PathBuf {
    crate::session::absolute(p)
}
