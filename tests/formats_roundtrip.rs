//! Round trips of every landmark and alignment format on real files from `../shared/data`
//! (skipped with a notice when absent), plus synthetic cases for what real files lack.

use lipmap::alignment::{Alignment, Phone, PhoneInventory};
use lipmap::io::alignment_format::{
    AlignmentFormat, TierChoice, format_alignment, parse_alignment, parse_alignment_as,
    read_alignment,
};
use lipmap::io::landmark_format::{LandmarkFormat, detect, read_track, write_track};
use lipmap::io::pts::{format_pts, list_pts_folder, read_pts, read_pts_folder};
use lipmap::io::textgrid::parse_textgrid;
use lipmap::landmarks::track::{FrameLandmarks, LandmarkPoint, PointSource, Track};
use lipmap::testdata::shared;
use std::path::{Path, PathBuf};

/// Formats a whole multi-frame track can take (a single `.pts` holds one frame only).
const TRACK_FORMATS: [LandmarkFormat; 5] = [
    LandmarkFormat::PtsFolder,
    LandmarkFormat::OpenFace,
    LandmarkFormat::DlibXml,
    LandmarkFormat::LipmapCsv,
    LandmarkFormat::EosCsv,
];

fn file_name(format: LandmarkFormat, step: usize) -> String {
    match format {
        LandmarkFormat::Pts => format!("s{step}.pts"),
        LandmarkFormat::PtsFolder => format!("s{step}_pts"),
        LandmarkFormat::OpenFace => format!("s{step}_openface.csv"),
        LandmarkFormat::DlibXml => format!("s{step}.xml"),
        LandmarkFormat::LipmapCsv => format!("s{step}_lipmap.csv"),
        LandmarkFormat::EosCsv => format!("s{step}_eos.csv"),
    }
}

/// Writes `track` in `format`, checks detection finds that format, and reads it back.
fn through(track: &Track, format: LandmarkFormat, dir: &Path, step: usize) -> Track {
    let path = dir.join(file_name(format, step));
    write_track(track, &path, format).unwrap();
    assert_eq!(detect(&path).unwrap(), format, "{}", path.display());
    read_track(&path).unwrap()
}

/// Positions as the format stores them: dlib keeps whole pixels.
fn expected_xy(p: &LandmarkPoint, rounded: bool) -> (f64, f64) {
    if rounded { (p.x.round(), p.y.round()) } else { (p.x, p.y) }
}

fn assert_same_points(orig: &Track, back: &Track, rounded: bool, what: &str) {
    assert_eq!(orig.len(), back.len(), "{what}: frame count");
    for (a, b) in orig.frames.iter().zip(&back.frames) {
        assert_eq!(a.frame, b.frame, "{what}: frame numbers");
        for (i, (p, q)) in a.points.iter().zip(&b.points).enumerate() {
            assert_eq!(p.visible, q.visible, "{what}: frame {} point {i} visibility", a.frame);
            if p.visible {
                assert_eq!(
                    expected_xy(p, rounded),
                    (q.x, q.y),
                    "{what}: frame {} point {i}",
                    a.frame
                );
            }
        }
    }
}

/// Every format to every other and back (A -> B -> A) keeps the points to the precision of
/// the coarsest format in the chain.
fn check_all_conversions(track: &Track) {
    let dir = tempfile::tempdir().unwrap();
    for (ia, &a) in TRACK_FORMATS.iter().enumerate() {
        for (ib, &b) in TRACK_FORMATS.iter().enumerate() {
            let step = 10 * ia + ib;
            let t1 = through(track, a, dir.path(), 3 * step);
            let t2 = through(&t1, b, dir.path(), 3 * step + 1);
            let t3 = through(&t2, a, dir.path(), 3 * step + 2);
            let rounded = a == LandmarkFormat::DlibXml || b == LandmarkFormat::DlibXml;
            assert_same_points(track, &t3, rounded, &format!("{a} -> {b} -> {a}"));
        }
    }
}

fn pts_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pts"))
        .collect();
    v.sort();
    v
}

/// The numbers of a `.pts` body as written in the file, parsed independently of lipmap.
fn raw_pts_numbers(path: &Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let body = text.split('{').nth(1).unwrap().split('}').next().unwrap();
    body.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split_whitespace().map(|s| s.parse::<f64>().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        })
        .collect()
}

#[test]
fn human_pts_files_round_trip_exactly_through_every_format() {
    let Some(dir) = shared("data/images") else { return };
    let files = pts_files(&dir);
    assert_eq!(files.len(), 2, "einstein.pts and takeo.pts");
    for path in files {
        let frame = read_pts(&path, 0).unwrap();
        let raw = raw_pts_numbers(&path);
        assert_eq!(raw.len(), 68);
        // 1-based in the file, 0-based in lipmap.
        for (p, (x, y)) in frame.points.iter().zip(&raw) {
            assert_eq!((p.x + 1.0, p.y + 1.0), (*x, *y));
        }
        // Writing gives back exactly the file's numbers (shortest round-trip decimals).
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.pts");
        std::fs::write(&out, format_pts(&frame)).unwrap();
        assert_eq!(raw_pts_numbers(&out), raw);
        let single = Track::new(vec![frame]);
        let back = through(&single, LandmarkFormat::Pts, dir.path(), 0);
        assert_eq!(back, single);
        check_all_conversions(&single);
    }
    // Hand-checked: takeo's first point is `32.310345 99.612347` in the file.
    let takeo = read_pts(&dir.join("takeo.pts"), 0).unwrap();
    assert_eq!((takeo.points[0].x, takeo.points[0].y), (32.310345 - 1.0, 99.612347 - 1.0));
}

#[test]
fn tracker_pts_folder_round_trips_through_every_format() {
    let Some(dir) = shared("data/carphone/dlib68_pts") else { return };
    let files = list_pts_folder(&dir).unwrap();
    assert_eq!(files.len(), 120);
    assert!(files[2].ends_with("frame_0002.pts") && files[119].ends_with("frame_0119.pts"));
    assert_eq!(detect(&dir).unwrap(), LandmarkFormat::PtsFolder);
    let track = read_pts_folder(&dir).unwrap();
    assert_eq!(track.len(), 120);
    assert_eq!(track.frames[119].frame, 119);
    // Hand-checked: frame_0000.pts begins `64.000 69.333`.
    assert_eq!((track.frames[0].points[0].x, track.frames[0].points[0].y), (63.0, 68.333));
    let raw = raw_pts_numbers(&files[57]);
    for (p, (x, y)) in track.frames[57].points.iter().zip(&raw) {
        assert_eq!((p.x + 1.0, p.y + 1.0), (*x, *y));
    }
    check_all_conversions(&track);
}

fn synthetic_track() -> Track {
    let frames = (0..3)
        .map(|f| {
            let mut pts: Vec<LandmarkPoint> = (0..68)
                .map(|i| {
                    LandmarkPoint::tracked(
                        10.0 + i as f64 * 1.37 + f as f64 / 3.0,
                        50.0 + 0.1 * i as f64,
                    )
                })
                .collect();
            pts[5].visible = false;
            pts[6].confidence = Some(0.25);
            pts[7].source = PointSource::Corrected;
            pts[8].source = PointSource::Interpolated;
            let mut fl = FrameLandmarks::new(2 * f, pts);
            fl.timestamp = Some(f as f64 * 0.0667);
            fl.confidence = Some(0.9);
            fl
        })
        .collect();
    Track::new(frames)
}

#[test]
fn lipmap_csv_is_lossless_and_openface_keeps_frame_fields() {
    let dir = tempfile::tempdir().unwrap();
    let track = synthetic_track();
    assert_eq!(through(&track, LandmarkFormat::LipmapCsv, dir.path(), 0), track);
    let of = through(&track, LandmarkFormat::OpenFace, dir.path(), 1);
    for (a, b) in track.frames.iter().zip(&of.frames) {
        assert_eq!(
            (a.frame, a.timestamp, a.confidence, a.success),
            (b.frame, b.timestamp, b.confidence, b.success)
        );
        assert_eq!(a.points[9].x, b.points[9].x);
    }
    // The folder numbers frames by position, so the gaps (0, 2, 4) close up.
    let folder = through(&track, LandmarkFormat::PtsFolder, dir.path(), 2);
    assert_eq!(folder.frames.iter().map(|f| f.frame).collect::<Vec<_>>(), [0, 1, 2]);
    // dlib: a missing part means not visible.
    let xml = through(&track, LandmarkFormat::DlibXml, dir.path(), 3);
    assert!(!xml.frames[0].points[5].visible && xml.frames[0].points[4].visible);
    // A multi-frame track cannot go to one .pts file.
    let e = write_track(&track, &dir.path().join("x.pts"), LandmarkFormat::Pts).unwrap_err();
    assert!(e.to_string().contains("holds one frame but the track has 3"), "{e}");
}

fn phones(a: &Alignment) -> Vec<(f64, f64, &str)> {
    a.phones.iter().map(|p| (p.start, p.end, p.label.as_str())).collect()
}

/// Reads `a` back from every written format and compares to the precision of each.
fn check_alignment_formats(a: &Alignment, what: &str) {
    let contiguous = a.phones.windows(2).all(|w| w[0].end == w[1].start)
        && a.phones.first().is_some_and(|p| p.start == 0.0);
    for f in AlignmentFormat::ALL {
        let text = format_alignment(a, f);
        let back = parse_alignment_as(&text, Path::new("x"), f, None).unwrap();
        assert_eq!(back.phones.len(), a.phones.len(), "{what} via {f}");
        match f {
            AlignmentFormat::TextGrid => assert_eq!(&back, a, "{what} via {f}"),
            // Formats without empty labels name a silence `sil`: the same phone key.
            AlignmentFormat::PhonesCsv | AlignmentFormat::HtkLab | AlignmentFormat::Xlabel => {
                for (p, q) in a.phones.iter().zip(&back.phones) {
                    assert_eq!(
                        PhoneInventory::default().key_of(&p.label),
                        PhoneInventory::default().key_of(&q.label),
                        "{what} via {f}"
                    );
                    let tol = if f == AlignmentFormat::HtkLab { 5.1e-8 } else { 0.0 };
                    assert!((p.end - q.end).abs() <= tol, "{what} via {f}: {p:?} vs {q:?}");
                    if f != AlignmentFormat::Xlabel || contiguous {
                        assert!((p.start - q.start).abs() <= tol, "{what} via {f}: {p:?} vs {q:?}");
                    }
                }
            }
        }
    }
}

/// The same bytes in UTF-16 LE and BE with a BOM, and UTF-8 with a BOM, parse identically.
fn check_encodings(path: &Path, tier: Option<&TierChoice>, expected: &Alignment) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut variants = vec![[&[0xEF, 0xBB, 0xBF][..], text.as_bytes()].concat()];
    for little in [true, false] {
        let mut b = if little { vec![0xFF, 0xFE] } else { vec![0xFE, 0xFF] };
        for u in text.encode_utf16() {
            b.extend(if little { u.to_le_bytes() } else { u.to_be_bytes() });
        }
        variants.push(b);
    }
    for bytes in variants {
        assert_eq!(&parse_alignment(&bytes, path, tier).unwrap(), expected, "{}", path.display());
    }
}

#[test]
fn praatio_bobby_long_format_arpabet() {
    let Some(dir) = shared("data/speech/praatio_examples") else { return };
    let path = dir.join("bobby_phones.TextGrid");
    let a = read_alignment(&path, None).unwrap();
    assert_eq!(a.phones.len(), 15);
    assert_eq!(
        a.phones[0],
        Phone { start: 0.0124716553288, end: 0.06469123242311078, label: String::new() }
    );
    assert_eq!(phones(&a)[2], (0.08438971390281873, 0.23285789838876556, "AA1"));
    assert_eq!(PhoneInventory::default().key_of(&a.phones[2].label), "AA");
    assert_eq!(a.phones[14].end, 1.194625);
    check_encodings(&path, None, &a);
    check_alignment_formats(&a, "bobby");

    // The words file has no phone tier: the default fails naming the tiers; an index works.
    let words = dir.join("bobby_words.TextGrid");
    let e = read_alignment(&words, None).unwrap_err().to_string();
    assert!(
        e.ends_with("no phone tier (tiers: 1 `word`, 2 `phrase`); choose one by name or number"),
        "{e}"
    );
    let w = read_alignment(&words, Some(&TierChoice::Index(1))).unwrap();
    assert_eq!(w.phones[1].label, "BOBBY");
    let by_name = read_alignment(&words, Some(&"PHRASE".parse().unwrap())).unwrap();
    assert_eq!(
        by_name.phones.len(),
        parse_textgrid(&std::fs::read(&words).unwrap(), &words).unwrap().tiers[1].kind_len()
    );
}

trait KindLen {
    fn kind_len(&self) -> usize;
}

impl KindLen for lipmap::io::textgrid::Tier {
    fn kind_len(&self) -> usize {
        match &self.kind {
            lipmap::io::textgrid::TierKind::Intervals(v) => v.len(),
            lipmap::io::textgrid::TierKind::Points(v) => v.len(),
        }
    }
}

#[test]
fn praatio_mary_short_format_ipa_crlf_with_point_tier() {
    let Some(dir) = shared("data/speech/praatio_examples") else { return };
    let path = dir.join("mary.TextGrid");
    let grid = parse_textgrid(&std::fs::read(&path).unwrap(), &path).unwrap();
    assert_eq!(
        grid.tiers.iter().map(|t| t.name.as_str()).collect::<Vec<_>>(),
        ["phone", "word", "pitch"]
    );
    assert_eq!(grid.xmax, 1.869687);
    let a = read_alignment(&path, None).unwrap();
    assert_eq!(a.phones.len(), 16);
    assert_eq!(phones(&a)[1], (0.3154201182247563, 0.38526757369599995, "m"));
    assert_eq!(a.phones[2].label, "ə");
    assert_eq!(PhoneInventory::default().key_of("ə"), "AH");
    check_encodings(&path, None, &a);
    check_alignment_formats(&a, "mary");
    let e = read_alignment(&path, Some(&TierChoice::Index(3))).unwrap_err().to_string();
    assert!(e.ends_with("tier `pitch` is a point tier, not an interval tier"), "{e}");
}

#[test]
fn praat_generated_textgrid_phoneme_tier() {
    let Some(dir) = shared("data/speech/generated") else { return };
    let path = dir.join("praat_bin_blue.TextGrid");
    let a = read_alignment(&path, None).unwrap();
    assert_eq!(a.phones.len(), 21);
    assert_eq!(
        phones(&a)[..4],
        [(0.0, 0.012, ""), (0.012, 0.05, "b"), (0.05, 0.14, "ɪ"), (0.14, 0.224, "n")]
    );
    let words = read_alignment(&path, Some(&TierChoice::Name("word".into()))).unwrap();
    assert_eq!(words.phones[1].label, "bin");
    check_encodings(&path, None, &a);
    check_alignment_formats(&a, "praat bin blue");
}

#[test]
fn festival_xlabel_segments() {
    let Some(dir) = shared("data/speech/generated") else { return };
    let path = dir.join("festival_segs.txt");
    let a = read_alignment(&path, None).unwrap();
    assert_eq!(a.phones.len(), 16);
    assert_eq!(phones(&a)[..2], [(0.0, 0.22, "pau"), (0.22, 0.3127, "b")]);
    assert_eq!(phones(&a)[15], (1.6662, 1.8862, "pau"));
    assert_eq!(
        a.phones
            .iter()
            .map(|p| PhoneInventory::default().key_of(&p.label))
            .collect::<Vec<_>>()
            .join(" "),
        "sil B IH N B L UW AE T EH F T UW N AW sil"
    );
    check_alignment_formats(&a, "festival");
}
