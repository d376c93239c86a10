//! Frame sources: a clip's images, from a folder of PNG/JPEG/PPM files (natural name order)
//! or a video file decoded by the `ffmpeg` program, decoded lazily into a bounded LRU cache.
//!
//! Opening is cheap on purpose (a 10,000-frame clip must open in under a second): a folder is
//! listed once (no per-file `stat`, only the first image's header is read for the size) and a
//! video is probed with `ffprobe` without decoding. `FrameSource::get` decodes on demand.
//!
//! Video frames are decoded in aligned chunks of `FrameOptions::video_chunk` frames: a request
//! for frame `i` runs `ffmpeg -ss t -i FILE -frames:v N -f rawvideo -pix_fmt rgb24 -` once for
//! the chunk holding `i` and caches every frame of it, so stepping forward or backward costs
//! one ffmpeg process per chunk. `-ss` before `-i` seeks to the keyframe before `t` and then
//! decodes exactly to `t`, so frames are exact; `t` is taken half a frame early so rounding in
//! the container's time base cannot skip the first frame. A constant frame rate is assumed.
//!
//! Install ffmpeg (with ffprobe) on Debian/Ubuntu with `apt-get install ffmpeg`.

use image::RgbImage;
use std::cmp::Ordering;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};

/// Image extensions a folder source accepts (case-insensitive).
pub const IMAGE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "ppm", "pnm", "pgm"];

/// Frame rate assumed for an image folder when none is given (PAL video rate).
pub const DEFAULT_FOLDER_FPS: f64 = 25.0;

/// What went wrong reading frames; every variant names the file or program concerned.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: no image files (png, jpg, jpeg, ppm) in this folder")]
    NoFrames { path: PathBuf },
    #[error("{path}: frame {frame}: cannot decode image: {message}")]
    Decode { path: PathBuf, frame: usize, message: String },
    #[error(
        "{path}: frame {frame} is {got_w}x{got_h} but the clip is {want_w}x{want_h} (all frames of a clip must have one size)"
    )]
    SizeMismatch { path: PathBuf, frame: usize, got_w: u32, got_h: u32, want_w: u32, want_h: u32 },
    #[error(
        "the `{program}` program was not found on PATH; it is needed to read video files \
         (install it: Debian/Ubuntu `apt-get install ffmpeg`, macOS `brew install ffmpeg`), \
         or extract the frames to a folder of PNG images"
    )]
    ProgramMissing { program: &'static str },
    #[error("{path}: {program} failed: {message}")]
    Program { path: PathBuf, program: &'static str, message: String },
    #[error("{path}: frame {index} is out of range (the clip has {len} frames)")]
    OutOfRange { path: PathBuf, index: usize, len: usize },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

/// How to open a source.
#[derive(Clone, Debug)]
pub struct FrameOptions {
    /// Frames per second; overrides what the video says. Folders default to `DEFAULT_FOLDER_FPS`.
    pub fps: Option<f64>,
    /// Image size `[width, height]` when known (skips reading the first header or probing).
    pub size: Option<[u32; 2]>,
    /// Capacity of the decoded-frame cache in MiB (RGB, 3 bytes per pixel).
    pub cache_mb: usize,
    /// Frames decoded per ffmpeg run for video sources.
    pub video_chunk: usize,
}

impl Default for FrameOptions {
    fn default() -> Self {
        Self { fps: None, size: None, cache_mb: 256, video_chunk: 16 }
    }
}

enum Kind {
    Folder { dir: PathBuf, files: Vec<PathBuf> },
    Video { file: PathBuf, decode_lock: Mutex<()> },
}

/// A clip's frames, decoded lazily. `Send + Sync`: share it in an `Arc` with worker threads.
pub struct FrameSource {
    kind: Kind,
    len: usize,
    fps: f64,
    size: [u32; 2],
    chunk: usize,
    cache: Mutex<FrameCache>,
}

impl std::fmt::Debug for FrameSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameSource")
            .field("path", &self.path())
            .field("len", &self.len)
            .field("fps", &self.fps)
            .field("size", &self.size)
            .finish()
    }
}

impl FrameSource {
    /// Opens `path`: a directory is an image folder, a file a video.
    ///
    /// # Errors
    /// `FrameError` naming the path when it cannot be listed or probed.
    pub fn open(path: &Path, opts: &FrameOptions) -> Result<Self, FrameError> {
        if path.is_dir() { Self::open_folder(path, opts) } else { Self::open_video(path, opts) }
    }

    /// Opens a folder of images in natural name order (`f2.png` before `f10.png`).
    ///
    /// # Errors
    /// `Io` when the folder cannot be listed, `NoFrames` when it holds no images,
    /// `Decode` when the first image's header is unreadable.
    pub fn open_folder(dir: &Path, opts: &FrameOptions) -> Result<Self, FrameError> {
        let io_err = |source| FrameError::Io { path: dir.to_path_buf(), source };
        let mut names: Vec<String> = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(io_err)? {
            let entry = entry.map_err(io_err)?;
            // `file_type` comes from the directory entry itself on Linux (no stat per file).
            if entry.file_type().map(|t| t.is_dir()).unwrap_or(false) {
                continue;
            }
            let Ok(name) = entry.file_name().into_string() else { continue };
            if has_image_extension(&name) && !name.starts_with('.') {
                names.push(name);
            }
        }
        if names.is_empty() {
            return Err(FrameError::NoFrames { path: dir.to_path_buf() });
        }
        names.sort_by(|a, b| natural_cmp(a, b));
        let files: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
        check_frame_file(&files[0])?;
        let (w, h) = image::image_dimensions(&files[0]).map_err(|e| FrameError::Decode {
            path: files[0].clone(),
            frame: 0,
            message: e.to_string(),
        })?;
        let size = agreed_size(&files[0], opts.size, Some([w, h]))?;
        let fps = opts.fps.unwrap_or(DEFAULT_FOLDER_FPS);
        check_fps(dir, fps)?;
        Ok(Self {
            len: files.len(),
            kind: Kind::Folder { dir: dir.to_path_buf(), files },
            fps,
            size,
            chunk: 1,
            cache: Mutex::new(FrameCache::new(opts.cache_mb)),
        })
    }

    /// Opens a video through `ffprobe` (falling back to `ffmpeg -i` when ffprobe is absent);
    /// nothing is decoded until `get`.
    ///
    /// # Errors
    /// `ProgramMissing` when ffmpeg is not installed, `Program` when it cannot read the file.
    pub fn open_video(file: &Path, opts: &FrameOptions) -> Result<Self, FrameError> {
        check_frame_file(file)?;
        let info = match probe_with_ffprobe(file) {
            Err(FrameError::ProgramMissing { .. }) => probe_with_ffmpeg(file)?,
            other => other?,
        };
        let fps = opts.fps.or(info.fps).ok_or_else(|| FrameError::Invalid {
            path: file.to_path_buf(),
            message: "the video does not state its frame rate; give one".into(),
        })?;
        check_fps(file, fps)?;
        let size = agreed_size(file, opts.size, info.size)?;
        let len = match (info.frames, info.duration) {
            (Some(n), _) => n,
            (None, Some(d)) => (d * fps).round().max(0.0) as usize,
            (None, None) => {
                return Err(FrameError::Invalid {
                    path: file.to_path_buf(),
                    message: "cannot tell how many frames the video has".into(),
                });
            }
        };
        let frame_bytes = size[0] as usize * size[1] as usize * 3;
        let cache = FrameCache::new(opts.cache_mb);
        // A chunk must fit comfortably in the cache or it would evict itself while decoding.
        let fit = (cache.capacity / frame_bytes.max(1) / 2).max(1);
        Ok(Self {
            kind: Kind::Video { file: file.to_path_buf(), decode_lock: Mutex::new(()) },
            len,
            fps,
            size,
            chunk: opts.video_chunk.clamp(1, fit.max(1)),
            cache: Mutex::new(cache),
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// `[width, height]` in pixels (of the first frame for a folder).
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// The folder or video file.
    pub fn path(&self) -> &Path {
        match &self.kind {
            Kind::Folder { dir, .. } => dir,
            Kind::Video { file, .. } => file,
        }
    }

    /// The image file of frame `i` for a folder source.
    pub fn frame_path(&self, i: usize) -> Option<&Path> {
        match &self.kind {
            Kind::Folder { files, .. } => files.get(i).map(PathBuf::as_path),
            Kind::Video { .. } => None,
        }
    }

    /// Whether frame `i` is decoded and cached (a prefetcher can skip it).
    pub fn is_cached(&self, i: usize) -> bool {
        self.lock_cache().peek(i)
    }

    /// Bytes of decoded frames held in the cache.
    pub fn cached_bytes(&self) -> usize {
        self.lock_cache().used
    }

    /// Frame `i` (0-based) as RGB, decoding it unless cached.
    ///
    /// # Errors
    /// `OutOfRange`, or a decode error naming the file and frame.
    pub fn get(&self, i: usize) -> Result<Arc<RgbImage>, FrameError> {
        if i >= self.len {
            return Err(FrameError::OutOfRange {
                path: self.path().to_path_buf(),
                index: i,
                len: self.len,
            });
        }
        if let Some(img) = self.lock_cache().get(i) {
            return Ok(img);
        }
        match &self.kind {
            Kind::Folder { files, .. } => {
                // Decoded outside the lock so several threads can decode different frames.
                let img = Arc::new(self.decode_image(&files[i], i)?);
                self.lock_cache().insert(i, img.clone());
                Ok(img)
            }
            Kind::Video { file, decode_lock } => {
                // One ffmpeg at a time: a second thread asking for the same chunk waits and
                // then finds it cached instead of decoding it again.
                let _guard = decode_lock.lock().unwrap_or_else(|p| p.into_inner());
                if let Some(img) = self.lock_cache().get(i) {
                    return Ok(img);
                }
                let first = i / self.chunk * self.chunk;
                let count = self.chunk.min(self.len - first);
                let frames = self.decode_video_chunk(file, first, count)?;
                if frames.len() <= i - first {
                    return Err(FrameError::Program {
                        path: file.clone(),
                        program: "ffmpeg",
                        message: format!(
                            "gave no frame {i} (the video ends after {} frames)",
                            first + frames.len()
                        ),
                    });
                }
                let wanted = frames[i - first].clone();
                let mut cache = self.lock_cache();
                for (k, img) in frames.into_iter().enumerate() {
                    cache.insert(first + k, img);
                }
                // Re-insert the requested frame last so it is the most recently used.
                cache.insert(i, wanted.clone());
                Ok(wanted)
            }
        }
    }

    fn lock_cache(&self) -> std::sync::MutexGuard<'_, FrameCache> {
        self.cache.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn decode_image(&self, path: &Path, frame: usize) -> Result<RgbImage, FrameError> {
        check_frame_file(path)?;
        let img = image::open(path)
            .map_err(|e| FrameError::Decode {
                path: path.to_path_buf(),
                frame,
                message: e.to_string(),
            })?
            .into_rgb8();
        let [want_w, want_h] = self.size;
        if img.dimensions() != (want_w, want_h) {
            return Err(FrameError::SizeMismatch {
                path: path.to_path_buf(),
                frame,
                got_w: img.width(),
                got_h: img.height(),
                want_w,
                want_h,
            });
        }
        Ok(img)
    }

    fn decode_video_chunk(
        &self,
        file: &Path,
        first: usize,
        count: usize,
    ) -> Result<Vec<Arc<RgbImage>>, FrameError> {
        // Half a frame early: the frame at exactly `first / fps` is then the first one kept.
        let t = ((first as f64 - 0.5) / self.fps).max(0.0);
        // `-ss` is relative to the file's start time (ffmpeg adds it unless -seek_timestamp).
        let [w, h] = self.size;
        let output = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-ss"])
            .arg(format!("{t:.6}"))
            .arg("-i")
            .arg(child_path_arg(file))
            .args(["-frames:v", &count.to_string(), "-an", "-sn"])
            .args(["-vf", &format!("scale={w}:{h}")])
            .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| program_error(file, "ffmpeg", e))?;
        if !output.status.success() {
            return Err(FrameError::Program {
                path: file.to_path_buf(),
                program: "ffmpeg",
                message: stderr_tail(&output.stderr),
            });
        }
        let frame_bytes = w as usize * h as usize * 3;
        Ok(output
            .stdout
            .chunks_exact(frame_bytes)
            .filter_map(|bytes| RgbImage::from_raw(w, h, bytes.to_vec()))
            .map(Arc::new)
            .collect())
    }
}

/// Refuses a frame or video path that is not a regular file (a FIFO would hang the decoder).
fn check_frame_file(path: &Path) -> Result<(), FrameError> {
    super::input::check_regular_file(path)
        .map(drop)
        .map_err(|e| FrameError::Invalid { path: path.to_path_buf(), message: e.message })
}

/// `path` as a child program's argument: a relative path gets a `./` prefix, so a name such as
/// `-y.mp4` is not read as an option and `concat:x.mp4` not as an ffmpeg protocol.
fn child_path_arg(path: &Path) -> PathBuf {
    if path.is_relative() { Path::new(".").join(path) } else { path.to_path_buf() }
}

/// Frame rates lipmap accepts (frames per second): a camera's range, no more. Frame counts
/// are derived from durations × fps, so a rate outside it (1e20, 1e-300) is an error, not
/// an allocation or a loop of that size.
pub const FPS_RANGE: std::ops::RangeInclusive<f64> = 1.0..=1000.0;

/// The one frame-rate rule: `fps` within [`FPS_RANGE`].
///
/// # Errors
/// A message giving the value and the range.
pub fn check_fps_value(fps: f64) -> Result<(), String> {
    if FPS_RANGE.contains(&fps) {
        Ok(())
    } else {
        Err(format!(
            "frame rate {} is outside {}–{} fps",
            crate::math::short_number(fps),
            FPS_RANGE.start(),
            FPS_RANGE.end()
        ))
    }
}

/// Longest image side lipmap accepts (px). Buffers are sized width × height, so a size from
/// a file is bounded before anything is allocated for it.
pub const MAX_IMAGE_SIDE: u32 = 1 << 15;

/// The frame size to use: the one given (a session's record) when the frames agree with it,
/// else the frames' own; each side within 1..=[`MAX_IMAGE_SIDE`].
fn agreed_size(
    path: &Path,
    given: Option<[u32; 2]>,
    found: Option<[u32; 2]>,
) -> Result<[u32; 2], FrameError> {
    let invalid = |message: String| FrameError::Invalid { path: path.to_path_buf(), message };
    if let (Some([gw, gh]), Some([fw, fh])) = (given, found)
        && [gw, gh] != [fw, fh]
    {
        return Err(invalid(format!(
            "the recorded frame size {gw}×{gh} disagrees with the frames' {fw}×{fh}"
        )));
    }
    let [w, h] = given.or(found).ok_or_else(|| invalid("cannot tell the frame size".into()))?;
    if !(1..=MAX_IMAGE_SIDE).contains(&w) || !(1..=MAX_IMAGE_SIDE).contains(&h) {
        return Err(invalid(format!("frame size {w}×{h} is outside 1–{MAX_IMAGE_SIDE} px")));
    }
    Ok([w, h])
}

fn check_fps(path: &Path, fps: f64) -> Result<(), FrameError> {
    check_fps_value(fps)
        .map_err(|message| FrameError::Invalid { path: path.to_path_buf(), message })
}

fn has_image_extension(name: &str) -> bool {
    name.rsplit_once('.')
        .is_some_and(|(_, ext)| IMAGE_EXTENSIONS.iter().any(|e| e.eq_ignore_ascii_case(ext)))
}

/// Compares names so that runs of digits compare by value: `frame2` < `frame10`.
/// Equal values with different zero padding fall back to plain byte order.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let nx = x.iter().take_while(|c| c.is_ascii_digit()).count();
                let ny = y.iter().take_while(|c| c.is_ascii_digit()).count();
                let dx = trim_zeros(&x[..nx]);
                let dy = trim_zeros(&y[..ny]);
                let ord = dx.len().cmp(&dy.len()).then_with(|| dx.cmp(dy));
                if ord != Ordering::Equal {
                    return ord;
                }
                x = &x[nx..];
                y = &y[ny..];
            }
            (Some(c), Some(d)) => {
                let ord = c.cmp(d);
                if ord != Ordering::Equal {
                    return ord;
                }
                x = &x[1..];
                y = &y[1..];
            }
        }
    }
}

fn trim_zeros(digits: &[u8]) -> &[u8] {
    let n = digits.iter().take_while(|&&c| c == b'0').count();
    &digits[n..]
}

fn program_error(path: &Path, program: &'static str, e: std::io::Error) -> FrameError {
    if e.kind() == std::io::ErrorKind::NotFound {
        FrameError::ProgramMissing { program }
    } else {
        FrameError::Program { path: path.to_path_buf(), program, message: e.to_string() }
    }
}

fn stderr_tail(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let tail = lines[lines.len().saturating_sub(3)..].join(" | ");
    if tail.is_empty() { "exited with an error and no message".into() } else { tail }
}

/// What a probe learnt about a video.
#[derive(Clone, Debug, Default, PartialEq)]
struct VideoInfo {
    fps: Option<f64>,
    size: Option<[u32; 2]>,
    frames: Option<usize>,
    duration: Option<f64>,
}

fn probe_with_ffprobe(file: &Path) -> Result<VideoInfo, FrameError> {
    let output = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
        .arg("stream=width,height,avg_frame_rate,r_frame_rate,nb_frames,duration:format=duration")
        .args(["-of", "default=noprint_wrappers=1"])
        .arg(child_path_arg(file))
        .stdin(Stdio::null())
        .output()
        .map_err(|e| program_error(file, "ffprobe", e))?;
    if !output.status.success() {
        return Err(FrameError::Program {
            path: file.to_path_buf(),
            program: "ffprobe",
            message: stderr_tail(&output.stderr),
        });
    }
    let info = parse_ffprobe(&String::from_utf8_lossy(&output.stdout));
    if info.size.is_none() {
        return Err(FrameError::Invalid {
            path: file.to_path_buf(),
            message: "no video stream".into(),
        });
    }
    Ok(info)
}

/// Parses ffprobe's `key=value` lines; the stream's values come before the format's.
fn parse_ffprobe(text: &str) -> VideoInfo {
    let mut map: HashMap<&str, &str> = HashMap::new();
    for line in text.lines() {
        if let Some((k, v)) = line.split_once('=') {
            // Keep the first occurrence: the stream's duration wins over the container's.
            map.entry(k.trim()).or_insert(v.trim());
        }
    }
    let num = |k: &str| map.get(k).and_then(|v| v.parse::<f64>().ok()).filter(|v| v.is_finite());
    let rate = |k: &str| map.get(k).and_then(|v| parse_rate(v));
    let size = match (map.get("width"), map.get("height")) {
        (Some(w), Some(h)) => w.parse().ok().zip(h.parse().ok()).map(|(w, h)| [w, h]),
        _ => None,
    };
    VideoInfo {
        fps: rate("avg_frame_rate").or_else(|| rate("r_frame_rate")),
        size,
        frames: map.get("nb_frames").and_then(|v| v.parse().ok()).filter(|&n: &usize| n > 0),
        duration: num("duration"),
    }
}

fn parse_rate(v: &str) -> Option<f64> {
    let r = match v.split_once('/') {
        Some((n, d)) => n.parse::<f64>().ok()? / d.parse::<f64>().ok()?,
        None => v.parse().ok()?,
    };
    (r.is_finite() && r > 0.0).then_some(r)
}

/// Fallback when only `ffmpeg` is installed: read the banner `ffmpeg -i FILE` prints.
fn probe_with_ffmpeg(file: &Path) -> Result<VideoInfo, FrameError> {
    let mut child = Command::new("ffmpeg")
        .args(["-nostdin", "-hide_banner", "-i"])
        .arg(child_path_arg(file))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| program_error(file, "ffmpeg", e))?;
    let mut text = String::new();
    if let Some(mut err) = child.stderr.take() {
        let _ = err.read_to_string(&mut text);
    }
    let _ = child.wait();
    let info = parse_ffmpeg_banner(&text);
    if info.size.is_none() {
        return Err(FrameError::Program {
            path: file.to_path_buf(),
            program: "ffmpeg",
            message: stderr_tail(text.as_bytes()),
        });
    }
    Ok(info)
}

/// Reads `Duration: 00:00:04.00, start: 0.000000` and the first
/// `Stream #0:0...: Video: ..., 176x144 ..., 29.97 fps, ...` line.
fn parse_ffmpeg_banner(text: &str) -> VideoInfo {
    let mut info = VideoInfo::default();
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("Duration:") {
            if let Some(d) = rest.split(',').next() {
                let hms: Vec<f64> = d.trim().split(':').filter_map(|x| x.parse().ok()).collect();
                if hms.len() == 3 {
                    info.duration = Some(hms[0] * 3600.0 + hms[1] * 60.0 + hms[2]);
                }
            }
        } else if line.starts_with("Stream #") && line.contains("Video:") && info.size.is_none() {
            for field in line.split(',') {
                let field = field.trim();
                if info.size.is_none() {
                    let token = field.split_whitespace().next().unwrap_or("");
                    if let Some((w, h)) = token.split_once('x')
                        && let (Ok(w), Ok(h)) = (w.parse::<u32>(), h.parse::<u32>())
                    {
                        info.size = Some([w, h]);
                    }
                }
                if let Some(v) = field.strip_suffix(" fps") {
                    info.fps = v.trim().parse().ok().filter(|f: &f64| *f > 0.0);
                }
            }
        }
    }
    info
}

/// Decoded frames, least recently used evicted first once `capacity` bytes are exceeded.
struct FrameCache {
    capacity: usize,
    used: usize,
    tick: u64,
    entries: HashMap<usize, (Arc<RgbImage>, u64)>,
    order: BTreeMap<u64, usize>,
}

impl FrameCache {
    fn new(capacity_mb: usize) -> Self {
        Self {
            capacity: capacity_mb.saturating_mul(1 << 20),
            used: 0,
            tick: 0,
            entries: HashMap::new(),
            order: BTreeMap::new(),
        }
    }

    fn peek(&self, i: usize) -> bool {
        self.entries.contains_key(&i)
    }

    fn get(&mut self, i: usize) -> Option<Arc<RgbImage>> {
        self.tick += 1;
        let tick = self.tick;
        let (img, stamp) = self.entries.get_mut(&i)?;
        self.order.remove(stamp);
        *stamp = tick;
        self.order.insert(tick, i);
        Some(img.clone())
    }

    fn insert(&mut self, i: usize, img: Arc<RgbImage>) {
        let cost = img.as_raw().len();
        if cost > self.capacity {
            return; // would evict everything and still not fit
        }
        if let Some((old, stamp)) = self.entries.remove(&i) {
            self.order.remove(&stamp);
            self.used -= old.as_raw().len();
        }
        while self.used + cost > self.capacity {
            let Some((_, victim)) = self.order.pop_first() else { break };
            if let Some((old, _)) = self.entries.remove(&victim) {
                self.used -= old.as_raw().len();
            }
        }
        self.tick += 1;
        self.entries.insert(i, (img, self.tick));
        self.order.insert(self.tick, i);
        self.used += cost;
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn child_programs_never_see_a_path_as_an_option() {
        assert_eq!(child_path_arg(Path::new("-y.mp4")), PathBuf::from("./-y.mp4"));
        assert_eq!(child_path_arg(Path::new("a/b.mp4")), PathBuf::from("./a/b.mp4"));
        assert_eq!(child_path_arg(Path::new("/v/-y.mp4")), PathBuf::from("/v/-y.mp4"));
    }

    #[test]
    fn a_device_or_folder_is_not_a_video() {
        let opts = FrameOptions::default();
        if Path::new("/dev/zero").exists() {
            let e = FrameSource::open_video(Path::new("/dev/zero"), &opts).err().unwrap();
            assert_eq!(e.to_string(), "/dev/zero: not a regular file (a device)");
        }
        let dir = tempfile::tempdir().unwrap();
        let e = FrameSource::open_video(dir.path(), &opts).err().unwrap().to_string();
        assert!(e.ends_with("not a regular file (a folder)"), "{e}");
    }
    use super::*;

    #[test]
    fn natural_order_puts_frame2_before_frame10() {
        let mut v = vec!["frame10.png", "frame2.png", "frame1.png", "frame02.png", "a.png"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["a.png", "frame1.png", "frame02.png", "frame2.png", "frame10.png"]);
    }

    #[test]
    fn lru_evicts_least_recent_within_capacity() {
        let mut c = FrameCache::new(1);
        let img = || Arc::new(RgbImage::new(256, 512)); // 384 KiB each; 2 fit in 1 MiB
        c.insert(0, img());
        c.insert(1, img());
        assert!(c.get(0).is_some()); // 0 is now newer than 1
        c.insert(2, img());
        assert!(c.peek(0) && c.peek(2) && !c.peek(1));
        assert!(c.used <= c.capacity);
    }

    #[test]
    fn parses_ffprobe_and_ffmpeg_banner() {
        let p = parse_ffprobe(
            "width=176\nheight=144\nr_frame_rate=30000/1001\navg_frame_rate=30000/1001\nstart_time=0.000000\nduration=4.004000\nnb_frames=120\nduration=4.1\n",
        );
        assert_eq!(p.size, Some([176, 144]));
        assert_eq!(p.frames, Some(120));
        assert!((p.fps.unwrap() - 29.97003).abs() < 1e-4);
        assert_eq!(p.duration, Some(4.004));
        let b = parse_ffmpeg_banner(
            "  Duration: 00:00:04.00, start: 0.000000, bitrate: 297 kb/s\n  Stream #0:0[0x1](und): Video: h264 (High) (avc1 / 0x31637661), yuv420p(progressive), 176x144 [SAR 1:1 DAR 11:9], 294 kb/s, 29.97 fps, 29.97 tbr, 30k tbn (default)\n",
        );
        assert_eq!(b.size, Some([176, 144]));
        assert_eq!(b.fps, Some(29.97));
        assert_eq!(b.duration, Some(4.0));
    }
}
