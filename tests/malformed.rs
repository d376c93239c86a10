//! The malformed-file corpus: every file in `tests/malformed/` with the exact one-line error
//! it must produce. Adding a case = one file plus one line in `CASES` (a reader for a new
//! kind of file is a small `fn(&Path) -> Result<(), String>` beside the others).

use lipmap::io::alignment_format::{TierChoice, read_alignment};
use lipmap::io::eos_bin::read_eos_blendshapes;
use lipmap::io::landmark_format::read_track;
use lipmap::io::landmark_map_toml::read_landmark_map;
use lipmap::io::makehuman_target::read_target;
use lipmap::io::model_source::load_model;
use lipmap::io::obj::read_obj;
use lipmap::session::Session;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

const DIR: &str = "tests/malformed";

type Reader = fn(&Path) -> Result<(), String>;

fn landmarks(p: &Path) -> Result<(), String> {
    read_track(p).map(drop).map_err(|e| e.to_string())
}

fn alignment(p: &Path) -> Result<(), String> {
    read_alignment(p, None).map(drop).map_err(|e| e.to_string())
}

/// The phone tier by number 1, for files whose only tier must be taken explicitly.
#[allow(dead_code)]
fn alignment_tier1(p: &Path) -> Result<(), String> {
    read_alignment(p, Some(&TierChoice::Index(1))).map(drop).map_err(|e| e.to_string())
}

fn mesh(p: &Path) -> Result<(), String> {
    read_obj(p).map(drop).map_err(|e| e.to_string())
}

/// A morphable model of any kind `lipmap new --model` takes (eos .bin, .npz, .lmm), by extension.
fn model(p: &Path) -> Result<(), String> {
    load_model(p, None).map(drop).map_err(|e| e.to_string())
}

fn blendshapes(p: &Path) -> Result<(), String> {
    read_eos_blendshapes(p).map(drop).map_err(|e| e.to_string())
}

fn landmark_map(p: &Path) -> Result<(), String> {
    read_landmark_map(p).map(drop).map_err(|e| e.to_string())
}

fn target(p: &Path) -> Result<(), String> {
    read_target(p).map(drop).map_err(|e| e.to_string())
}

/// Sessions name their file by its absolute path; shown relative here like the others.
fn session(p: &Path) -> Result<(), String> {
    let abs = lipmap::session::absolute(p);
    Session::load(p)
        .map(drop)
        .map_err(|e| e.to_string().replace(&abs.display().to_string(), &p.display().to_string()))
}

/// (file in tests/malformed, reader, the error text after the file's path).
const CASES: &[(&str, Reader, &str)] = &[
    // iBUG .pts
    ("pts_67_points.pts", landmarks, ":70: expected 68 points, found 67"),
    ("pts_n_points_mismatch.pts", landmarks, ":2: n_points is 68 but 67 points are listed"),
    ("pts_69_points.pts", landmarks, ":72: more than 68 points"),
    ("pts_bad_x.pts", landmarks, ":11:1: bad x coordinate `abc`"),
    ("pts_bad_y_column.pts", landmarks, ":11:10: bad y coordinate `1O.2`"),
    ("pts_nan.pts", landmarks, ":6:1: bad x coordinate `nan`"),
    ("pts_one_number.pts", landmarks, ":8: expected `x y`, found `14.5`"),
    ("pts_three_numbers.pts", landmarks, ":8: expected `x y`, found `14.5 24.25 1`"),
    ("pts_no_brace.pts", landmarks, ":2: no `{` found"),
    ("pts_unclosed.pts", landmarks, ":71: file ends without `}` after 68 points"),
    ("pts_junk_header.pts", landmarks, ":2: unexpected `hello world` before `{`"),
    ("pts_text_after_brace.pts", landmarks, ":74: unexpected `1 2` after `}`"),
    ("pts_bad_n_points.pts", landmarks, ":2: bad n_points `sixty-eight`, expected a whole number"),
    ("pts_empty.pts", landmarks, ":1: no `{` found"),
    // OpenFace CSV
    ("openface_bad_x.csv", landmarks, ":3: column `x_3`: `abc` is not a finite number"),
    ("openface_frame_zero.csv", landmarks, ":2: column `frame`: 0, but OpenFace frames start at 1"),
    ("openface_duplicate_frame.csv", landmarks, ":4: column `frame`: frame 2 appears twice"),
    ("openface_x_without_y.csv", landmarks, ":1: column `x_5` has no `y_5`"),
    ("openface_short_row.csv", landmarks, ":3: 7 fields, but the header has 13"),
    ("openface_bad_success.csv", landmarks, ":2: column `success`: `yes` is not 0 or 1"),
    ("openface_duplicate_column.csv", landmarks, ":1: column `x_0` appears twice"),
    ("openface_fractional_frame.csv", landmarks, ":2: column `frame`: `1.5` is not a whole number"),
    // lipmap CSV
    ("lipmap_point_68.csv", landmarks, ":3: column `point`: 68 is out of range 0..67"),
    ("lipmap_bad_visible.csv", landmarks, ":2: column `visible`: `yes` is not 0 or 1"),
    (
        "lipmap_bad_source.csv",
        landmarks,
        ":2: column `source`: `guessed` is not tracked, corrected or interpolated",
    ),
    ("lipmap_duplicate_point.csv", landmarks, ":4: point 5 of frame 0 is given twice"),
    (
        "lipmap_missing_y.csv",
        landmarks,
        ":1: missing column `y` (expected frame,point,x,y,visible,confidence,source)",
    ),
    (
        "lipmap_unknown_column.csv",
        landmarks,
        ":1: unknown column `colour` (expected frame,point,x,y,visible,confidence,source)",
    ),
    ("lipmap_negative_frame.csv", landmarks, ":2: column `frame`: `-1` is not a whole number"),
    ("lipmap_non_numeric_y.csv", landmarks, ":3: column `y`: `two` is not a finite number"),
    (
        "lipmap_bad_confidence.csv",
        landmarks,
        ":2: column `confidence`: `high` is not a finite number",
    ),
    (
        "lipmap_frame_fields_disagree.csv",
        landmarks,
        ":3: frame 0: timestamp, frame_confidence, success or rerun_disagreement differ from its \
         earlier rows",
    ),
    (
        "landmarks_unknown.csv",
        landmarks,
        ":1: not a landmark file lipmap knows (.pts, OpenFace CSV, dlib XML, lipmap CSV, eos CSV)",
    ),
    // dlib imglab XML
    ("dlib_part_68.xml", landmarks, ":9: part name `68` is out of range 00..67"),
    ("dlib_part_name_text.xml", landmarks, ":6: part name `mouth` is out of range 00..67"),
    ("dlib_part_without_x.xml", landmarks, ":9: part `05` has no `x`"),
    ("dlib_bad_y.xml", landmarks, ":9: part `05`: `y` = `1O` is not a number"),
    ("dlib_duplicate_part.xml", landmarks, ":9: part `01` appears twice in this box"),
    ("dlib_part_without_name.xml", landmarks, ":6: <part> has no `name`"),
    (
        "dlib_mismatched_tag.xml",
        landmarks,
        ":9: bad XML: ill-formed document: expected `</box>`, but `</image>` was found",
    ),
    ("dlib_no_images.xml", landmarks, ": no <image> elements: not a dlib imglab landmark file"),
    ("dlib_truncated.xml", landmarks, ":9: file ends inside an <image>"),
    ("dlib_nested_image.xml", landmarks, ":3: <image> inside <image>"),
    // Praat TextGrid
    (
        "tg_overlap.TextGrid",
        alignment,
        ":24: interval 3 of tier `phones` starts at 0.45, before interval 2 ends at 0.5 (overlap)",
    ),
    (
        "tg_end_before_start.TextGrid",
        alignment,
        ":20: interval 2 of tier `phones` ends (0.3) before it starts (0.5)",
    ),
    ("tg_bad_number.TextGrid", alignment, ":21: `0.5x` is not a number"),
    (
        "tg_truncated.TextGrid",
        alignment,
        ":27: file ends where the xmin of interval 4 of tier `phones` was expected",
    ),
    (
        "tg_wrong_object_class.TextGrid",
        alignment,
        ":2: object class is \"Sound\", expected \"TextGrid\"",
    ),
    ("tg_binary.TextGrid", alignment, ":1: binary TextGrids are not supported; save as text file"),
    (
        "tg_binary_quoted.TextGrid",
        alignment,
        ":1: binary TextGrids are not supported; save as text file",
    ),
    ("tg_unclosed_string.TextGrid", alignment, ":26: string never closes"),
    (
        "tg_bad_tier_class.TextGrid",
        alignment,
        ":10: tier class is \"FormantTier\", expected \"IntervalTier\" or \"TextTier\"",
    ),
    (
        "tg_no_phone_tier.TextGrid",
        alignment,
        ": no phone tier (tiers: 1 `words`, 2 `syllables`); choose one by name or number",
    ),
    ("tg_invalid_utf8.TextGrid", alignment, ":22: text is neither UTF-8 nor UTF-16"),
    (
        "tg_utf16_odd_length.TextGrid",
        alignment,
        ": byte 1030: UTF-16 text with an odd number of bytes",
    ),
    (
        "tg_fractional_size.TextGrid",
        alignment,
        ":14: the size of tier `phones` must be a whole number, found 2.5",
    ),
    ("tg_missing_exists.TextGrid", alignment, ":7: expected <exists> or <absent>, found number 1"),
    (
        "tg_point_tier_chosen.TextGrid",
        alignment,
        ":7: tier `phones` is a point tier, not an interval tier",
    ),
    (
        "tg_empty.TextGrid",
        alignment,
        ":1: file ends where the file type \"ooTextFile\" was expected",
    ),
    // HTK / Festival .lab
    (
        "lab_overlap.lab",
        alignment,
        ":3: phone `AA1` starts at 0.35, before `B` ends at 0.4 (overlap)",
    ),
    ("lab_end_before_start.lab", alignment, ":2: phone `B` (0.2–0.1 s) ends before it starts"),
    ("lab_two_fields.lab", alignment, ":2: expected `start end label`, found `2000000 4000000`"),
    ("lab_bad_time.lab", alignment, ":2: end time `0.3O` is not a non-negative number"),
    ("lab_empty.lab", alignment, ": no labels found"),
    ("lab_negative_time.lab", alignment, ":1: start time `-0.5` is not a non-negative number"),
    ("xlabel_backwards.lab", alignment, ":5: end time 0.3 is before the previous end 0.31"),
    ("xlabel_bad_end.lab", alignment, ":3: end time `abc` is not a non-negative number"),
    ("xlabel_no_body.lab", alignment, ": no labels after the `#` line"),
    ("xlabel_missing_color.lab", alignment, ":2: expected `end color label`, found `0.22`"),
    // start,end,phone CSV
    ("phones_missing_end.csv", alignment, ":1: missing column `end` (expected start,end,phone)"),
    (
        "phones_overlap.csv",
        alignment,
        ":4: phone `AA1` starts at 0.3, before `B` ends at 0.4 (overlap)",
    ),
    ("phones_non_numeric.csv", alignment, ":3: column `end`: `later` is not a finite number"),
    ("phones_negative_start.csv", alignment, ":2: column `start`: -0.1 is negative"),
    ("phones_ragged.csv", alignment, ":3: 2 fields, but the header has 3"),
    // Wavefront OBJ
    (
        "obj_face_past_last_vertex.obj",
        mesh,
        ":5: face uses vertex 4 but the file has only 3 vertices",
    ),
    ("obj_face_index_zero.obj", mesh, ":4: vertex reference 0 (OBJ indices start at 1)"),
    ("obj_bad_vertex.obj", mesh, ":2: coordinate 2 `zero` is not a finite number"),
    (
        "obj_negative_before_first.obj",
        mesh,
        ":3: relative reference -3 points before the first vertex (2 read so far)",
    ),
    ("obj_two_corner_face.obj", mesh, ":4: a face needs at least 3 vertices, got 2"),
    // eos binary models (tiny synthetic files)
    (
        "eos_truncated.bin",
        model,
        ": byte 40: truncated: shape model basis cols needs 4 bytes, only 0 left",
    ),
    ("eos_basis_rows_mismatch.bin", model, ": byte 36: shape model basis has 3 rows, the mean 6"),
    ("eos_negative_triangle.bin", model, ": byte 92: shape model triangle 0 has vertex -1"),
    (
        "eos_blendshapes_ragged.bs.bin",
        blendshapes,
        ": byte 64: blendshape 1 `jaw` has 3 rows, the first has 6",
    ),
    // NumPy .npz models
    (
        "npz_basis_mean_mismatch.npz",
        model,
        ": field `basis_orthonormal`: shape [9, 1] does not match the mean's 6 values (need 6×K)",
    ),
    ("npz_no_mean.npz", model, ": field `mean`: required array is missing"),
    (
        "npz_truncated_array.npz",
        model,
        ": field `mean`: truncated: shape (6) of 8-byte values needs more than the 32 data bytes",
    ),
    (
        "npz_string_dtype.npz",
        model,
        ": field `mean`: unsupported dtype UnicodeStr of 6 bytes (need float or integer)",
    ),
    // (found by fuzzing: a header length of ~2 GB was allocated before reading)
    (
        "npz_header_length_huge.npz",
        model,
        ": field `mean`: truncated: header of 1985685464 bytes, only 58 bytes follow",
    ),
    // (found by fuzzing: bracket nesting made npyz's header parser run for seconds)
    (
        "npz_header_deep_nesting.npz",
        model,
        ": field `mean`: header nests brackets 102 deep; not a numeric array",
    ),
    (
        "npz_not_a_zip.npz",
        model,
        ": not an .npz archive: invalid Zip archive: Could not find central directory end",
    ),
    // lipmap model files
    (
        "lmm_truncated.lmm",
        model,
        ": byte 64: truncated: the header promises at least 100 bytes, the file has 64",
    ),
    (
        "lmm_bad_magic.lmm",
        model,
        ": unknown model format (expected eos .bin, .npz, a .npy folder, a lipmap model file, a folder of pose OBJs or an OBJ)",
    ),
    (
        "lmm_huge_expression_count.lmm",
        model,
        ": byte 48: truncated: the header promises at least 1125899906842668 bytes, the file has 48",
    ),
    // (found by fuzzing: both were arithmetic overflows, i.e. panics, before the fix)
    (
        "lmm_sizes_overflow.lmm",
        model,
        ": byte 16: sizes N=0 K=18446744073709551615 E=0 T=0 overflow",
    ),
    ("lmm_version_2.lmm", model, ": byte 8: unsupported version 2 (this lipmap reads 1)"),
    // eos TOML landmark maps
    (
        "map_non_numeric_vertex.toml",
        landmark_map,
        ":3: vertex for iBUG 49 must be a non-negative integer, got \"eight hundred\"",
    ),
    ("map_id_69.toml", landmark_map, ":3: `69` is not an iBUG id in 1..=68"),
    (
        "map_negative_vertex.toml",
        landmark_map,
        ":2: vertex for iBUG 31 must be a non-negative integer, got -3",
    ),
    (
        "map_no_section.toml",
        landmark_map,
        ": field `landmark_mappings`: no [landmark_mappings] table in the file",
    ),
    (
        "map_bad_toml.toml",
        landmark_map,
        ":3: string values must be quoted, expected literal string",
    ),
    // MakeHuman .target
    ("target_three_fields.target.txt", target, ":3: expected `vertex dx dy dz`, got `36 0.002 0`"),
    ("target_bad_vertex.target.txt", target, ":1: bad vertex index `x12`"),
    ("target_nan.target.txt", target, ":2: `nan` is not a finite number"),
    // sessions
    (
        "session_newer_schema.lipmap.json",
        session,
        ": this session was written by a newer lipmap (session schema 7; this build reads up to 3); update lipmap to open it",
    ),
    ("session_no_schema.lipmap.json", session, ": no `schema_version`: not a lipmap session file"),
    (
        "session_schema_text.lipmap.json",
        session,
        ": `schema_version` must be a whole number, found \"one\"",
    ),
    ("session_duplicate_clip.lipmap.json", session, ": two clips are named \"c1\""),
    (
        "session_short_xy.lipmap.json",
        session,
        ":156:4: frame 0: `xy` has 135 numbers, expected 136",
    ),
    ("session_bad_json.lipmap.json", session, ":3:17: key must be a string"),
    (
        "session_zero_fps.lipmap.json",
        session,
        ": clip \"c1\": front: fps: frame rate 0 is outside 1–1000 fps",
    ),
];

#[test]
fn every_malformed_file_gives_its_exact_one_line_error() {
    let mut failures = Vec::new();
    for (name, read, expected_tail) in CASES {
        let path = PathBuf::from(DIR).join(name);
        let expected = format!("{}{expected_tail}", path.display());
        match read(&path) {
            Ok(()) => failures.push(format!("{name}: parsed without error")),
            Err(got) if got != expected => {
                failures.push(format!("{name}:\n  got      {got}\n  expected {expected}"))
            }
            Err(got) => assert!(!got.contains('\n'), "{name}: message spans lines"),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases wrong:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}

#[test]
fn corpus_and_table_list_the_same_files() {
    let on_disk: BTreeSet<String> = std::fs::read_dir(DIR)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let listed: BTreeSet<String> = CASES.iter().map(|c| c.0.to_string()).collect();
    assert_eq!(listed.len(), CASES.len(), "a file is listed twice");
    assert_eq!(on_disk, listed, "files without a case, or cases without a file");
    assert!(CASES.len() >= 40);
}
