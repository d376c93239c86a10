//! Memory on hostile and long inputs, through the release binary as a user runs it: the
//! bound is under 1 GB of memory for an input under 1 MB, and memory that grows with
//! the data, never with a number read from a file.
//!
//! Inputs, all made here from the demo (4 sentences, no frames):
//! - `far`: the session with clip 0's last tracked frame moved to 900,000 (within the
//!   session's frame budget) and the fit cache dropped, as a hand edit would leave it;
//! - `over`: every clip's last tracked frame at 1,048,575 (each clip at the per-clip bound;
//!   the clips are worked one at a time, so memory is that of one such clip);
//! - a 62 s WAV (the demo voice repeated) animated by a speech model trained on the demo,
//!   carried onto the MakeHuman head when `../shared/data` is present;
//! - an hour of speech (130 demo sentences' voices, pauses included, repeated) at 16 kHz
//!   mono and at 48 kHz stereo, animated by a model trained with default settings on those
//!   130 sentences: bounded by 300 MB and 60 s, whatever the hour's size.
//!
//! - a corpus of 600 demo sentences (~36k frames, every fit cached): `validate` ≤ 150 MB
//!   and `eval` ≤ 300 MB; then the same clips repeated under other names (`LIPMAP_BENCH_COPIES`
//!   times, 4 unless set; 72 makes ~2.6 M frames, a whole GRID corpus, which must evaluate
//!   within 1 GB), so memory beyond the largest clip is seen flat in the number of clips and
//!   CPU time linear;
//! - `speech train` on 150 and 600 sentences: memory and CPU time linear in frames.
//!
//! Each command's peak resident memory is read from `wait4`'s rusage; prints MB and the
//! ratio to the bound. Run: `cargo bench --bench hostile` (`LIPMAP_BENCH_COPIES=72` for the
//! whole-corpus figure: ~1 GB of disk besides the demo's 0.45 GB, data files hard-linked).

#[path = "support/child.rs"]
mod child;

use std::path::{Path, PathBuf};

const BOUND_MB: f64 = 1024.0;

/// Runs `lipmap args`, returning (exit code, peak RSS in MB, seconds).
fn run(args: &[&str]) -> (i32, f64, f64) {
    let u = child::run_lipmap(args);
    (u.code, u.peak_mb, u.wall_s)
}

fn report(what: &str, input_bytes: u64, args: &[&str]) {
    let (code, mb, s) = run(args);
    println!(
        "hostile/{what} (input {:.0} KB, exit {code}): peak {mb:.0} MB in {s:.2} s (bound {BOUND_MB:.0} MB, ratio {:.3})",
        input_bytes as f64 / 1024.0,
        mb / BOUND_MB
    );
}

/// Bounds of `speech animate` on an hour of audio.
const HOUR_BOUND_MB: f64 = 300.0;
const HOUR_BOUND_S: f64 = 60.0;

/// Writes an hour of `voice` (mono samples at `rate`) repeated, as a WAV of `channels`
/// 16-bit channels, block by block (the bench holds no hour of samples either).
fn write_hour(path: &Path, voice: &[f32], rate: u32, channels: u16) {
    let spec = hound::WavSpec {
        channels,
        sample_rate: rate,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec).expect("hour WAV");
    let total = 3600 * rate as usize;
    for v in voice.iter().cycle().take(total) {
        let x = (v.clamp(-1.0, 1.0) * 32767.0).round() as i16;
        for _ in 0..channels {
            w.write_sample(x).expect("write sample");
        }
    }
    w.finalize().expect("finish hour WAV");
}

/// Writes an hour of the voices of `session`'s clips at `rate` with `channels`, as
/// [`write_hour`] does.
fn hour_wav(session: &Path, rate: u32, channels: u16, out: &Path) {
    let loaded = lipmap::session::Session::load(session).expect("demo session");
    let mut voice = Vec::new();
    for c in &loaded.clips {
        let a =
            lipmap::io::wav::read_wav(&c.audio.as_ref().expect("demo audio").file).expect("voice");
        voice.extend(a.samples);
    }
    if rate != 16_000 {
        voice =
            lipmap::speech::resample(&voice, 16_000.0, f64::from(rate)).expect("upsampled voice");
    }
    write_hour(out, &voice, rate, channels);
}

/// Runs this benchmark's own binary in a helper mode (`main`): what the helper reads or
/// makes stays out of this process, whose peak memory every child's figure would otherwise
/// include (`wait4` reports the larger of the child's peak and its parent's at the spawn);
/// returns its standard output.
fn in_helper(args: &[&str]) -> String {
    let out = std::process::Command::new(std::env::current_exe().expect("bench binary"))
        .args(args)
        .output()
        .expect("helper runs");
    assert!(out.status.success(), "helper {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("UTF-8 helper output")
}

/// `speech animate` on an hour of speech at 16 kHz mono and 48 kHz stereo.
fn hour_of_audio(tmp: &Path) {
    let corpus = tmp.join("corpus");
    let (code, _, _) =
        run(&["demo", "--no-tui", "--no-frames", "--sentences", "130", "--out", s(&corpus)]);
    assert_eq!(code, 0, "demo of 130 sentences");
    let session = corpus.join("demo.lipmap.json");
    let model = tmp.join("speech130.json");
    let train = child::run_lipmap(&["speech", "train", s(&session), "--out", s(&model)]);
    assert_eq!(train.code, 0, "speech train on 130 sentences");
    println!(
        "hostile/speech train, 130 sentences (for the hour): {:.1} s CPU, {:.1} s wall",
        train.cpu_s, train.wall_s
    );
    let anim = tmp.join("anim_hour");
    for (rate, channels) in [(16_000u32, 1u16), (48_000, 2)] {
        let wav = tmp.join(format!("hour_{rate}_{channels}.wav"));
        in_helper(&["hour-wav", s(&session), &rate.to_string(), &channels.to_string(), s(&wav)]);
        let bytes = size(&wav);
        let (code, mb, secs) =
            run(&["speech", "animate", s(&model), "--audio", s(&wav), "--out", s(&anim)]);
        println!(
            "hostile/speech animate, an hour at {} kHz {} ({:.0} MB WAV, exit {code}): peak {mb:.0} MB (bound {HOUR_BOUND_MB:.0}, ratio {:.2}) in {secs:.1} s (bound {HOUR_BOUND_S:.0}, ratio {:.2})",
            rate / 1000,
            if channels == 1 { "mono" } else { "stereo" },
            bytes as f64 / 1e6,
            mb / HOUR_BOUND_MB,
            secs / HOUR_BOUND_S
        );
        let _ = std::fs::remove_file(&wav);
    }
}

fn size(p: &Path) -> u64 {
    std::fs::metadata(p).map_or(0, |m| m.len())
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temporary path")
}

/// The session at `from` with each listed clip's last tracked frame set to `frame` and
/// no fit cache, written to `to`.
fn edited(from: &Path, to: &Path, clips: &[usize], frame: usize) -> PathBuf {
    let mut s = lipmap::session::Session::load(from).expect("session");
    for &c in clips {
        let mut track = s.clips[c].tracked().expect("tracked frames").as_ref().clone();
        track.frames.last_mut().expect("a tracked frame").frame = frame;
        s.set_tracked(c, track).expect("clip");
    }
    s.clear_fit_cache();
    s.save(to).expect("write");
    to.to_path_buf()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["hour-wav", session, rate, channels, out] => {
            let (rate, channels) =
                (rate.parse().expect("rate"), channels.parse().expect("channels"));
            return hour_wav(Path::new(session), rate, channels, Path::new(out));
        }
        ["repeat", from, to, copies] => {
            let (from, to) = (Path::new(from), Path::new(to));
            let (clips, frames) = clips_and_frames(from);
            let (big_clips, big_frames) = repeated(from, to, copies.parse().expect("copies"));
            return println!("{clips} {frames} {big_clips} {big_frames}");
        }
        _ => {}
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let demo = tmp.path().join("demo");
    let (code, _, _) =
        run(&["demo", "--no-tui", "--no-frames", "--sentences", "4", "--out", s(&demo)]);
    assert_eq!(code, 0, "demo");
    let session = demo.join("demo.lipmap.json");

    let far = edited(&session, &demo.join("far.lipmap.json"), &[0], 900_000);
    let out = tmp.path().join("out");
    let far_len = size(&far);
    report("far frame: eval", far_len, &["eval", s(&far)]);
    report("far frame: export --all", far_len, &["export", s(&far), "--out", s(&out), "--all"]);
    report("far frame: saqp markers", far_len, &["saqp", "markers", s(&far)]);
    let sp_far = tmp.path().join("sp_far.json");
    report(
        "far frame: speech train",
        far_len,
        &["speech", "train", s(&far), "--states", "2", "--mixtures", "1", "--out", s(&sp_far)],
    );
    let over = edited(&session, &demo.join("over.lipmap.json"), &[0, 1, 2, 3], 1_048_575);
    report(
        "every clip at frame 2^20-1: eval (one clip at a time)",
        size(&over),
        &["eval", s(&over)],
    );

    // Long audio: the demo voice repeated to 62 s.
    let model = tmp.path().join("speech.json");
    let (code, _, _) = run(&["speech", "train", s(&session), "--out", s(&model)]);
    assert_eq!(code, 0, "speech train");
    let loaded = lipmap::session::Session::load(&session).expect("demo session");
    let voice = &loaded.clips[0].audio.as_ref().expect("demo audio").file;
    let audio = lipmap::io::wav::read_wav(voice).expect("demo voice");
    let seconds = 62.0;
    let n = (seconds * f64::from(audio.sample_rate)) as usize;
    let long: Vec<f32> = audio.samples.iter().copied().cycle().take(n).collect();
    let wav = tmp.path().join("long.wav");
    lipmap::io::wav::write_wav(&wav, &long, audio.sample_rate).expect("write WAV");
    let anim = tmp.path().join("anim");
    report(
        "speech animate 62 s",
        size(&wav),
        &["speech", "animate", s(&model), "--audio", s(&wav), "--out", s(&anim)],
    );
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    match lipmap::testdata::shared("data/makehuman") {
        Some(dir) => report(
            "speech animate 62 s onto MakeHuman (19,158 vertices)",
            size(&wav),
            &[
                "speech",
                "animate",
                s(&model),
                "--audio",
                s(&wav),
                "--head",
                s(&dir.join("base.obj")),
                "--mapping",
                s(&map),
                "--out",
                s(&anim),
            ],
        ),
        None => println!("hostile: ../shared/data absent; the MakeHuman animation is skipped"),
    }
    corpus_scale(tmp.path());
    hour_of_audio(tmp.path());
}

/// Targets on a 600-sentence corpus, and for a whole GRID corpus.
const VALIDATE_600_MB: f64 = 150.0;
const EVAL_600_MB: f64 = 300.0;
const GRID_FRAMES: usize = 2_600_000;

/// One command on a corpus: peak and CPU time, against `bound_mb` when it has one.
fn corpus_run(what: &str, args: &[&str], bound_mb: Option<f64>) -> child::ChildUsage {
    let u = child::run_lipmap(args);
    let bound = bound_mb
        .map_or(String::new(), |b| format!(" (target {b:.0} MB, ratio {:.3})", u.peak_mb / b));
    println!(
        "hostile/{what} (exit {}): peak {:.0} MB{bound}, {:.1} s CPU",
        u.code, u.peak_mb, u.cpu_s
    );
    u
}

/// The clips and tracked frames of the session at `path`.
fn clips_and_frames(path: &Path) -> (usize, usize) {
    let s = lipmap::session::Session::load(path).expect("corpus session");
    (s.clips.len(), s.clips.iter().map(|c| c.tracked_summary().frames).sum())
}

/// The session at `from` with its clips repeated `copies` times in all, under other names,
/// every copy referring to the same data (hard-linked into the new session's folder);
/// returns (clips, frames).
fn repeated(from: &Path, to: &Path, copies: usize) -> (usize, usize) {
    let mut s = lipmap::session::Session::load(from).expect("corpus session");
    let clips = s.clips.clone();
    for k in 1..copies {
        for c in &clips {
            let mut copy = c.clone();
            copy.name = format!("copy{k}_{}", c.name);
            s.clips.push(copy);
        }
    }
    s.save(to).expect("repeated corpus");
    clips_and_frames(to)
}

/// A demo corpus of `sentences` (no frames) made with another seed than the documented
/// demo's, in `dir`; its session file.
fn held_out_demo(dir: &Path, sentences: usize) -> PathBuf {
    let n = sentences.to_string();
    let made = child::run_lipmap(&[
        "demo",
        "--no-tui",
        "--no-frames",
        "--sentences",
        &n,
        "--seed",
        "7",
        "--out",
        s(dir),
    ]);
    assert_eq!(made.code, 0, "demo of {sentences} sentences");
    dir.join("demo.lipmap.json")
}

/// `validate`, `eval` and `fit` (all cached) on a 600-sentence corpus and on its clips
/// repeated; `speech train` on 150 and 600 sentences.
fn corpus_scale(tmp: &Path) {
    let copies: usize =
        std::env::var("LIPMAP_BENCH_COPIES").ok().and_then(|v| v.parse().ok()).unwrap_or(4);
    let dir = tmp.join("corpus600");
    let session = held_out_demo(&dir, 600);
    let big = dir.join(format!("copies{copies}.lipmap.json"));
    let counts: Vec<usize> = in_helper(&["repeat", s(&session), s(&big), &copies.to_string()])
        .split_whitespace()
        .map(|n| n.parse().expect("a count"))
        .collect();
    let [clips, frames, big_clips, big_frames] = counts[..] else { panic!("four counts") };
    println!("hostile/corpus: 600 sentences, {clips} clips, {frames} frames, fits cached");
    let validate =
        corpus_run("corpus 600: validate", &["validate", s(&session)], Some(VALIDATE_600_MB));
    let eval = corpus_run("corpus 600: eval", &["eval", s(&session)], Some(EVAL_600_MB));
    corpus_run("corpus 600: fit (all cached)", &["fit", s(&session)], None);

    let grid = big_frames >= GRID_FRAMES;
    println!("hostile/corpus ×{copies}: {big_clips} clips, {big_frames} frames");
    let bound = grid.then_some(BOUND_MB);
    let big_validate =
        corpus_run(&format!("corpus ×{copies}: validate"), &["validate", s(&big)], bound);
    let big_eval = corpus_run(&format!("corpus ×{copies}: eval"), &["eval", s(&big)], bound);
    let big_fit =
        corpus_run(&format!("corpus ×{copies}: fit (all cached)"), &["fit", s(&big)], bound);
    let added = (big_clips - clips).max(1) as f64;
    for (what, small, large) in [("validate", &validate, &big_validate), ("eval", &eval, &big_eval)]
    {
        println!(
            "hostile/corpus ×{copies} against ×1, {what}: peak +{:.2} KB per added clip; CPU ×{:.2} for frames ×{:.2}",
            (large.peak_mb - small.peak_mb) * 1024.0 / added,
            large.cpu_s / small.cpu_s.max(1e-9),
            big_frames as f64 / frames as f64
        );
    }
    println!("hostile/corpus ×{copies}, fit: peak {:.0} MB", big_fit.peak_mb);
    if !grid {
        println!(
            "hostile/corpus: {big_frames} frames is short of a whole GRID corpus ({GRID_FRAMES}); LIPMAP_BENCH_COPIES=72 measures that"
        );
    }
    let _ = std::fs::remove_file(&big);
    let _ = std::fs::remove_dir_all(dir.join(format!("copies{copies}.lipmap.d")));
    speech_train_scale(tmp, &session, frames);
}

/// `speech train` on 150 and 600 sentences: peak and CPU time per frame.
fn speech_train_scale(tmp: &Path, session600: &Path, frames600: usize) {
    let session150 = held_out_demo(&tmp.join("corpus150"), 150);
    let (_, frames150) = clips_and_frames(&session150);
    let mut runs = Vec::new();
    for (session, frames) in [(&session150, frames150), (&session600.to_path_buf(), frames600)] {
        let model = tmp.join(format!("speech{frames}.json"));
        let u = child::run_lipmap(&["speech", "train", s(session), "--out", s(&model)]);
        assert_eq!(u.code, 0, "speech train on {frames} frames");
        println!(
            "hostile/speech train, {frames} frames: peak {:.0} MB, {:.1} s CPU ({:.2} ms per frame)",
            u.peak_mb,
            u.cpu_s,
            1e3 * u.cpu_s / frames as f64
        );
        runs.push((frames, u));
    }
    let ((f0, a), (f1, b)) = (&runs[0], &runs[1]);
    println!(
        "hostile/speech train, linear in frames: frames ×{:.2}, CPU ×{:.2}, peak ×{:.2}",
        *f1 as f64 / *f0 as f64,
        b.cpu_s / a.cpu_s.max(1e-9),
        b.peak_mb / a.peak_mb
    );
}
