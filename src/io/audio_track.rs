//! A video's own audio track, extracted by the `ffmpeg` program into a 16-bit mono WAV at a
//! given rate: `ffmpeg -nostdin -v error -i file:VIDEO -map 0:a:0 -ac 1 -ar RATE -c:a pcm_s16le
//! -y file:OUT.wav`. The `file:` protocol prefix keeps a path beginning with `-` or holding a
//! `:` from being read as an option or a protocol.

use super::error::{FormatError, Result};
use std::path::Path;
use std::process::{Command, Stdio};

/// Writes the first audio stream of `video` to `out` (mono, `sample_rate` Hz, 16-bit PCM).
///
/// # Errors
/// One line naming the video: ffmpeg is not installed, the video has no audio track, or
/// ffmpeg failed (its last message).
pub fn extract_audio_track(video: &Path, out: &Path, sample_rate: u32) -> Result<()> {
    let output = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-i"])
        .arg(file_url(video))
        .args(["-map", "0:a:0", "-vn", "-ac", "1", "-ar", &sample_rate.to_string()])
        .args(["-c:a", "pcm_s16le", "-f", "wav", "-y"])
        .arg(file_url(out))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                FormatError::whole(
                    video,
                    "the `ffmpeg` program was not found on PATH; it is needed to extract the video's audio (install it: Debian/Ubuntu `apt-get install ffmpeg`), or give the audio as a WAV file with --audio",
                )
            } else {
                FormatError::io(video, e)
            }
        })?;
    if output.status.success() {
        return Ok(());
    }
    let message = String::from_utf8_lossy(&output.stderr);
    if message.contains("matches no streams") {
        return Err(FormatError::whole(
            video,
            "the video has no audio track; give the clip's audio as a WAV file with --audio",
        ));
    }
    let last = message.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
    Err(FormatError::whole(video, format!("ffmpeg could not extract the audio: {}", last.trim())))
}

fn file_url(p: &Path) -> std::ffi::OsString {
    let mut s = std::ffi::OsString::from("file:");
    s.push(p.as_os_str());
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_video_without_audio_is_named_in_one_line() {
        let Some(video) = crate::testdata::shared("data/carphone/carphone_pristine.mp4") else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let e = extract_audio_track(&video, &dir.path().join("a.wav"), 16_000).unwrap_err();
        let line = e.to_string();
        assert!(
            line.contains("carphone_pristine.mp4")
                && (line.contains("no audio track") || line.contains("ffmpeg")),
            "{line}"
        );
        assert!(!line.contains('\n'));
    }
}
