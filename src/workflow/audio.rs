//! Giving a clip its audio: a WAV file as it is, or the audio track of the clip's video
//! extracted through ffmpeg into a WAV beside the session. Either is checked by reading it
//! whole, so a bad file is refused when it is added, not when a model is trained.

use super::error::{Error, Result};
use super::speech::SPEECH_SAMPLE_RATE;
use crate::io::audio_track::extract_audio_track;
use crate::io::wav::read_wav;
use crate::session::{Clip, ClipAudio, FramesRef};
use std::path::{Path, PathBuf};

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
/// use (one line naming the file); a video track asked of a clip whose frames are images; a
/// video without audio, or no ffmpeg; an offset that is not a number.
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
    let audio = read_wav(&file)?;
    if audio.sample_rate < SPEECH_SAMPLE_RATE {
        return Err(Error::Invalid(format!(
            "{}: recorded at {} Hz, below the {SPEECH_SAMPLE_RATE} Hz speech models are trained at; use audio at {SPEECH_SAMPLE_RATE} Hz or more",
            file.display(),
            audio.sample_rate
        )));
    }
    let channels = wav_channels(&file)?;
    Ok(ClipAudio { file, sample_rate: audio.sample_rate, channels, offset_s })
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

fn wav_channels(file: &Path) -> Result<u16> {
    let reader = hound::WavReader::open(file).map_err(|e| {
        Error::Format(crate::io::FormatError::whole(file, format!("not a readable WAV file: {e}")))
    })?;
    Ok(reader.spec().channels)
}
