//! A clip's audio: given as a WAV file as it is, or as the audio track of the clip's video
//! extracted through ffmpeg into a WAV beside the session, checked by reading it through
//! (block by block, never held whole), so a bad file is refused when it is added, not when a
//! model is trained; and analysed for a speech model ([`clip_log_mel`]), streamed from the
//! file into the per-frame log mel energies the model needs, aligned to the clip's frames.
//!
//! Audio that covers too little of its clip is refused where it enters (import) and where
//! it is used (training, scoring): more than [`MAX_UNCOVERED_FRACTION`] of the clip without
//! audio is another recording or a cut file, not the clip's speech.

use super::error::{Error, Result, Warning};
use super::speech::SPEECH_SAMPLE_RATE;
use crate::io::audio_track::extract_audio_track;
use crate::io::wav::{WavStream, check_wav};
use crate::math::DMatrix;
use crate::session::{Clip, ClipAudio, FramesRef};
use crate::speech::{LogMelAnalyser, MfccOptions};
use std::path::{Path, PathBuf};

/// The largest fraction of a clip that may be without audio (before its offset or after its
/// end): beyond it the audio is refused.
pub const MAX_UNCOVERED_FRACTION: f64 = 0.25;
/// Audio ending (or starting) this much short of its clip is warned about: a frame or two
/// is the usual rounding between a video and its sound track, more is worth a look.
pub const WARN_UNCOVERED_S: f64 = 0.1;

/// Seconds of a clip of `clip_s` covered by audio of `audio_s` starting at `offset_s`.
pub fn covered_seconds(offset_s: f64, audio_s: f64, clip_s: f64) -> f64 {
    ((offset_s + audio_s).min(clip_s) - offset_s.max(0.0)).max(0.0)
}

/// `Err` when audio covering `covered_s` of a `clip_s` clip leaves more than
/// [`MAX_UNCOVERED_FRACTION`] of it without sound; a warning past [`WARN_UNCOVERED_S`].
///
/// # Errors
/// One line naming the clip, the file and both lengths.
pub fn check_coverage(
    clip: &str,
    file: &Path,
    covered_s: f64,
    clip_s: f64,
) -> Result<Option<Warning>> {
    let missing = (clip_s - covered_s).max(0.0);
    let said = || {
        format!(
            "clip `{clip}`: its audio {} covers {covered_s:.2} s of the clip's {clip_s:.2} s",
            file.display()
        )
    };
    if clip_s > 0.0 && missing > MAX_UNCOVERED_FRACTION * clip_s {
        return Err(Error::Invalid(format!(
            "{}; more than {:.0} % of a clip without audio is refused (is it the clip's audio, and its offset right?)",
            said(),
            100.0 * MAX_UNCOVERED_FRACTION
        )));
    }
    Ok((missing > WARN_UNCOVERED_S)
        .then(|| Warning(format!("lipmap: warning: {}; the rest is taken as silence", said()))))
}

/// A clip's audio analysed for a speech model.
#[derive(Clone, Debug)]
pub struct ClipSound {
    /// Log mel energies, one row per frame of the clip.
    pub log_mel: DMatrix,
    /// Content hash of the file's samples ([`WavStream::content_hash`]).
    pub hash: u64,
    /// Set when the audio leaves part of the clip silent.
    pub warning: Option<Warning>,
}

/// The log mel energies of clip `name`'s `n_frames` frames (at `mfcc.frame_rate`) from its
/// audio, streamed from the file: sample 0 of the analysis is the front view's frame 0
/// (silence where the recording starts later, its head dropped where it starts earlier).
///
/// # Errors
/// The WAV's one-line error (unreadable, too low a rate, a bad sample); an offset that
/// starts the audio after the clip's end; audio covering too little of the clip
/// ([`check_coverage`]).
pub fn clip_log_mel(
    name: &str,
    audio: &ClipAudio,
    mfcc: &MfccOptions,
    n_frames: usize,
) -> Result<ClipSound> {
    let clip_s = n_frames as f64 / mfcc.frame_rate;
    // An offset is only meaningful while audio and frames overlap; checked before any
    // padding is made, so a wild offset in a session file cannot size it.
    if !(audio.offset_s.is_finite() && audio.offset_s < clip_s) {
        return Err(Error::Invalid(format!(
            "clip `{name}`: audio offset {} s starts the audio after the clip's end ({clip_s:.2} s)",
            crate::math::short_number(audio.offset_s)
        )));
    }
    let rate = mfcc.sample_rate.round() as u32;
    let mut stream = WavStream::open_at_rate(&audio.file, rate)?;
    let mut analyser = LogMelAnalyser::new(mfcc, Some(n_frames))
        .map_err(|e| Error::Invalid(format!("clip `{name}`: {e}")))?;
    let shift = (audio.offset_s * f64::from(rate)).round();
    let fail =
        |e: crate::speech::SpeechError| Error::Invalid(format!("{}: {e}", audio.file.display()));
    // Silence before a late start, in blocks: never more than the clip's length.
    let mut lead = if shift > 0.0 { shift as usize } else { 0 };
    let zeros = vec![0.0f32; 8192];
    while lead > 0 {
        let n = lead.min(zeros.len());
        analyser.push(&zeros[..n]).map_err(fail)?;
        lead -= n;
    }
    let mut skip = if shift < 0.0 { (-shift) as usize } else { 0 };
    let mut block = Vec::new();
    let mut more = true;
    let mut delivered = 0usize;
    while more {
        block.clear();
        more = stream.next_block(&mut block)?;
        let from = skip.min(block.len());
        skip -= from;
        delivered += block.len();
        // Samples past the clip's last window are read (for the hash) but not analysed.
        if (analyser.samples_received() as f64) < (clip_s + mfcc.window_s) * f64::from(rate) {
            analyser.push(&block[from..]).map_err(fail)?;
        }
    }
    let audio_s = delivered as f64 / f64::from(rate);
    let warning = check_coverage(
        name,
        &audio.file,
        covered_seconds(audio.offset_s, audio_s, clip_s),
        clip_s,
    )?;
    Ok(ClipSound { log_mel: analyser.finish(), hash: stream.content_hash(), warning })
}

/// Where a clip's audio comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum AudioSource {
    /// A WAV file.
    Wav(PathBuf),
    /// The audio track of the clip's front video.
    VideoTrack,
}

/// A clip's audio as the user gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct AudioInput {
    pub source: AudioSource,
    /// Seconds from the front view's frame 0 to the audio's first sample.
    pub offset_s: f64,
}

/// Reads and checks `clip`'s audio from `input`. A video track is written as
/// `SESSION_NAME.CLIP.wav` beside `session_file`.
///
/// # Errors
/// An unreadable, empty or truncated WAV, or one recorded below the 16 kHz speech models
/// use (one line naming the file); audio covering too little of a clip that has frames
/// ([`check_coverage`]); a video track asked of a clip whose frames are images; a video
/// without audio, or no ffmpeg; an offset that is not a number.
pub fn read_clip_audio(clip: &Clip, session_file: &Path, input: &AudioInput) -> Result<ClipAudio> {
    let offset_s = input.offset_s;
    if !offset_s.is_finite() {
        return Err(Error::Invalid(format!("audio offset {offset_s} is not a number of seconds")));
    }
    let file = match &input.source {
        AudioSource::Wav(p) => crate::session::absolute(p),
        AudioSource::VideoTrack => {
            let FramesRef::Video { file: video } = &clip.front.source else {
                return Err(Error::Invalid(format!(
                    "clip `{}` is a folder of images, which has no audio track; give its audio as a WAV file with --audio",
                    clip.name
                )));
            };
            let out = video_track_path(session_file, &clip.name);
            extract_audio_track(video, &out, SPEECH_SAMPLE_RATE)?;
            out
        }
    };
    let audio = check_wav(&file)?;
    if audio.sample_rate < SPEECH_SAMPLE_RATE {
        return Err(Error::Invalid(format!(
            "{}: recorded at {} Hz, below the {SPEECH_SAMPLE_RATE} Hz speech models are trained at; use audio at {SPEECH_SAMPLE_RATE} Hz or more",
            file.display(),
            audio.sample_rate
        )));
    }
    if let Some(last) = clip.tracked_summary().last_frame {
        let clip_s = (last + 1) as f64 / clip.front.fps;
        check_coverage(
            &clip.name,
            &file,
            covered_seconds(offset_s, audio.seconds(), clip_s),
            clip_s,
        )?;
    }
    Ok(ClipAudio { file, sample_rate: audio.sample_rate, channels: audio.channels, offset_s })
}

/// `SESSION_NAME.CLIP.wav` beside the session file.
fn video_track_path(session_file: &Path, clip: &str) -> PathBuf {
    let abs = crate::session::absolute(session_file);
    let name = crate::session::model::session_name_of(&abs);
    let safe: String = clip
        .chars()
        .map(|c| if c.is_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .collect();
    abs.with_file_name(format!("{name}.{safe}.wav"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_counts_only_the_clip_and_refuses_past_the_margin() {
        assert_eq!(covered_seconds(0.0, 3.0, 2.0), 2.0);
        assert_eq!(covered_seconds(0.5, 3.0, 2.0), 1.5);
        assert_eq!(covered_seconds(-1.0, 1.5, 2.0), 0.5);
        let f = Path::new("a.wav");
        assert_eq!(check_coverage("s1", f, 2.0, 2.0).unwrap(), None);
        let w = check_coverage("s1", f, 1.8, 2.0).unwrap().unwrap();
        assert!(w.0.starts_with("lipmap: warning: clip `s1`"), "{w}");
        // One sample of audio for 61 frames at 24 fps.
        let e = check_coverage("s1", f, 1.0 / 16_000.0, 61.0 / 24.0).unwrap_err().to_string();
        assert!(e.contains("clip `s1`") && e.contains("a.wav") && e.contains("25 %"), "{e}");
        assert!(!e.contains('\n'));
    }
}
