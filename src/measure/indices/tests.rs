//! Known-answer tests of the facial indices, bounds, box plots, matching and neutral frame.

use super::*;
use crate::alignment::{Alignment, Phone, PhoneInventory};
use crate::math::{DVector, Point2};
use crate::measure::{MeasureError, Series};
use crate::model::LandmarkMap;

fn sample_points() -> Vec<Option<Point2>> {
    let mut pts: Vec<Option<Point2>> = vec![None; 68];
    let set =
        |pts: &mut Vec<Option<Point2>>, i: usize, x: f64, y: f64| pts[i] = Some(Point2::new(x, y));
    set(&mut pts, 0, -70.0, 0.0);
    set(&mut pts, 16, 70.0, 0.0);
    set(&mut pts, 8, 0.0, 120.0);
    set(&mut pts, 36, -45.0, 0.0);
    set(&mut pts, 45, 45.0, 0.0);
    set(&mut pts, 39, -15.0, 0.0);
    set(&mut pts, 42, 15.0, 0.0);
    set(&mut pts, 31, -20.0, 45.0);
    set(&mut pts, 35, 20.0, 45.0);
    set(&mut pts, 33, 0.0, 50.0);
    set(&mut pts, 51, 0.0, 65.0);
    set(&mut pts, 62, 0.0, 70.0);
    set(&mut pts, 66, 0.0, 72.0);
    set(&mut pts, 57, 0.0, 82.0);
    set(&mut pts, 48, -25.0, 72.0);
    set(&mut pts, 54, 25.0, 72.0);
    pts
}

#[test]
fn distances_and_indices_by_hand() {
    let d = facial_distances(&sample_points()).unwrap();
    let want = [120.0, 140.0, 90.0, 30.0, 50.0, 40.0, 17.0, 50.0, 5.0, 10.0, 38.0, 15.0, 70.0];
    for (k, w) in want.iter().enumerate() {
        assert!((d.d[k] - w).abs() < 1e-12, "D{} = {} != {w}", k + 1, d.d[k]);
    }
    let ix = indices_from_distances(&d).unwrap();
    assert!((ix.get(FacialIndex::Facial) - 100.0 * 120.0 / 140.0).abs() < 1e-9);
    assert!((ix.get(FacialIndex::Intercanthal) - 100.0 * 30.0 / 90.0).abs() < 1e-9);
    assert!((ix.get(FacialIndex::VerticalMouthHeight) - 100.0 * 17.0 / 120.0).abs() < 1e-9);
    assert!((ix.get(FacialIndex::NoseUpperLip) - 100.0 * 15.0 / 70.0).abs() < 1e-9);
    assert!((ix.get(FacialIndex::MouthWidth) - 100.0 * 50.0 / 90.0).abs() < 1e-9);
}

#[test]
fn head_shape_uses_frontal_projection() {
    // The sample face as a mesh: z must not matter, vertex k = landmark k.
    let pts = sample_points();
    let mut flat = Vec::new();
    for (k, p) in pts.iter().enumerate() {
        let p = p.unwrap_or(Point2::new(k as f64, -(k as f64)));
        flat.extend([p.x, p.y, (k % 5) as f64 * 7.0]);
    }
    let map = LandmarkMap { to_vertex: (0..68).map(|i| (i, i)).collect() };
    let a = shape_indices(&DVector::from_vec(flat), &map).unwrap();
    assert_eq!(a, facial_indices(&pts).unwrap());
    let mut partial = map.clone();
    partial.to_vertex.remove(&8);
    let zeros = DVector::zeros(68 * 3);
    assert_eq!(shape_indices(&zeros, &partial), Err(MeasureError::MissingLandmark(8)));
}

#[test]
fn partial_indices_agree_and_leave_missing_ones_nan() {
    let pts = sample_points();
    assert_eq!(facial_indices_partial(&pts), facial_indices(&pts).unwrap());
    let mut no_zygion = pts.clone();
    no_zygion[0] = None;
    let v = facial_indices_partial(&no_zygion);
    assert!(v.get(FacialIndex::Facial).is_nan() && v.get(FacialIndex::NoseFaceWidth).is_nan());
    assert_eq!(
        v.get(FacialIndex::MouthWidth),
        facial_indices(&pts).unwrap().get(FacialIndex::MouthWidth)
    );
}

#[test]
fn missing_point_and_zero_denominator() {
    let mut pts = sample_points();
    pts[57] = None;
    assert_eq!(facial_distances(&pts), Err(MeasureError::MissingLandmark(57)));
    let mut pts = sample_points();
    pts[16] = pts[0];
    assert!(matches!(facial_indices(&pts), Err(MeasureError::DegenerateReference(_))));
}

#[test]
fn the_embedded_bounds_are_the_published_table() {
    // The published bounds as they stood in code before they moved to `data/`.
    let published = [
        (FacialIndex::Facial, 83.68, 89.52),
        (FacialIndex::Intercanthal, 33.59, 35.50),
        (FacialIndex::Nasal, 73.55, 95.97),
        (FacialIndex::Nasofacial, 42.23, 47.49),
        (FacialIndex::NoseFaceWidth, 28.91, 32.66),
        (FacialIndex::LipArea, 29.79, 35.53),
        (FacialIndex::VerticalMouthHeight, 13.58, 16.22),
        (FacialIndex::UpperLipThickness, 3.93, 5.61),
        (FacialIndex::LowerLipThickness, 9.23, 11.44),
        (FacialIndex::MouthWidth, 49.18, 54.80),
        (FacialIndex::ChinSize, 22.79, 27.18),
        (FacialIndex::NoseUpperLip, 25.88, 29.08),
    ];
    let expected = BoundsTable {
        bounds: published.map(|(index, low, high)| IndexBounds { index, low, high }).to_vec(),
    };
    assert_eq!(BoundsTable::from_csv_str(DEFAULT_BOUNDS_CSV).unwrap(), expected);
    assert_eq!(BoundsTable::default(), expected);
    for (index, low, high) in published {
        assert_eq!(index.published_bounds(), (low, high));
    }
}

#[test]
fn classification_is_inclusive_in_the_middle() {
    let t = BoundsTable::default();
    let b = t.get(FacialIndex::VerticalMouthHeight).unwrap();
    assert_eq!((b.low, b.high), (13.58, 16.22));
    assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 13.57), Some(IndexClass::Low));
    assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 13.58), Some(IndexClass::Middle));
    assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 16.23), Some(IndexClass::High));
    assert_eq!(t.classify(FacialIndex::Facial, f64::NAN), None);
    assert_eq!(t.bounds.len(), 12);
}

#[test]
fn csv_and_toml_round_trip_and_errors() {
    let t = BoundsTable::default();
    assert_eq!(BoundsTable::from_csv_str(&t.to_csv_string()).unwrap(), t);
    assert_eq!(BoundsTable::from_toml_str(&t.to_toml_string()).unwrap(), t);
    let user = "# my corpus\nlow,index,high\n1,Vertical mouth height,2\n3,nose-face width,4\n";
    let u = BoundsTable::from_csv_str(user).unwrap();
    assert_eq!(u.bounds.len(), 2);
    assert_eq!(u.classify(FacialIndex::NoseFaceWidth, 5.0), Some(IndexClass::High));
    assert_eq!(u.classify(FacialIndex::Facial, 5.0), None);
    let e = BoundsTable::from_csv_str("index,low,high\nfacial,1,2\nnosy,1,2\n").unwrap_err();
    assert_eq!((e.line, e.field.as_deref()), (Some(3), Some("index")));
    let e = BoundsTable::from_csv_str("index,low,high\nfacial,x,2\n").unwrap_err();
    assert_eq!((e.line, e.field.as_deref()), (Some(2), Some("low")));
    let e = BoundsTable::from_csv_str("index,low,high\nfacial,3,2\n").unwrap_err();
    assert_eq!(e.line, Some(2));
    let e = BoundsTable::from_csv_str("index,low,high\nfacial,1,2\nfacial,1,2\n").unwrap_err();
    assert!(e.message.contains("twice"));
    assert!(BoundsTable::from_csv_str("index,low\nfacial,1\n").is_err());
    let e = BoundsTable::from_toml_str("[[bounds]]\nindex = \"facial\"\nlow = \"a\"\nhigh = 2\n")
        .unwrap_err();
    assert_eq!(e.line, Some(3));
}

#[test]
fn box_plot_rule_matches_hand_quartiles() {
    // 1..=8 and 40: type-7 quartiles of 9 values are the 3rd and 7th: 3 and 7.
    let mut v: Vec<f64> = (1..=8).map(f64::from).collect();
    v.push(40.0);
    let b = box_plot(&v).unwrap();
    assert_eq!((b.q1, b.median, b.q3, b.iqr), (3.0, 5.0, 7.0, 4.0));
    // Fences −3 and 13: 40 is an outlier, the upper whisker stops at 8.
    assert_eq!((b.lower_whisker, b.upper_whisker, b.n_outliers), (1.0, 8.0, 1));
    // Even count, interpolated: [1,2,3,4] → Q1 = 1.75, Q3 = 3.25.
    let b = box_plot(&[4.0, 1.0, 3.0, 2.0]).unwrap();
    assert_eq!((b.q1, b.q3), (1.75, 3.25));
    assert!(box_plot(&[f64::NAN]).is_none());
}

#[test]
fn corpus_bounds_are_box_edges() {
    let samples: Vec<FacialIndices> =
        (1..=9).map(|k| FacialIndices { values: [k as f64; 12] }).collect();
    let (t, plots) = BoundsTable::from_corpus(&samples).unwrap();
    let b = t.get(FacialIndex::ChinSize).unwrap();
    assert_eq!((b.low, b.high), (3.0, 7.0));
    assert_eq!(plots.len(), 12);
    assert!(BoundsTable::from_corpus(&samples[..3]).is_err());
}

#[test]
fn verdict_warns_on_opposite_mouth_height_and_narrow_on_wide() {
    let t = BoundsTable::default();
    let mut speaker = FacialIndices { values: [0.0; 12] };
    let mut head = speaker;
    for i in FacialIndex::ALL {
        let (lo, hi) = i.published_bounds();
        speaker.values[i.position()] = 0.5 * (lo + hi);
        head.values[i.position()] = 0.5 * (lo + hi);
    }
    assert!(match_speaker_head(&speaker, &head, &t).is_good_match());
    speaker.values[FacialIndex::VerticalMouthHeight.position()] = 12.0;
    head.values[FacialIndex::VerticalMouthHeight.position()] = 18.0;
    let v = match_speaker_head(&speaker, &head, &t);
    assert_eq!(v.warnings.len(), 1);
    // Either way round.
    let v = match_speaker_head(&head, &speaker, &t);
    assert!(matches!(v.warnings[0], MatchWarning::VerticalMouthHeightOpposite { .. }));
    // Low vs middle is not flagged.
    head.values[FacialIndex::VerticalMouthHeight.position()] = 15.0;
    assert!(match_speaker_head(&speaker, &head, &t).is_good_match());
    speaker.values[FacialIndex::MouthWidth.position()] = 45.0;
    head.values[FacialIndex::MouthWidth.position()] = 60.0;
    let v = match_speaker_head(&speaker, &head, &t);
    assert!(matches!(v.warnings[..], [MatchWarning::NarrowMouthOnWide { .. }]));
    // Wide onto narrow is not what the published finding warns about.
    assert!(match_speaker_head(&head, &speaker, &t).is_good_match());
}

#[test]
fn neutral_frame_is_smallest_opening_in_silence() {
    let al = Alignment {
        phones: vec![
            Phone { start: 0.0, end: 0.3, label: "sil".into() },
            Phone { start: 0.3, end: 0.6, label: "M".into() },
            Phone { start: 0.6, end: 1.0, label: "sp".into() },
        ],
    };
    // 10 fps: silence frames 0..3 and 6..10; frame 4 (in /m/) is the global minimum.
    let h: Series =
        [0.3, 0.2, 0.25, 0.5, 0.0, 0.4, 0.3, 0.1, 0.1, 0.2].into_iter().map(Some).collect();
    assert_eq!(
        choose_neutral_frame(&h, &al, &PhoneInventory::default(), 10.0),
        Some(NeutralFrame { frame: 7, in_silence: true })
    );
    let none = Alignment { phones: vec![Phone { start: 0.0, end: 1.0, label: "AA1".into() }] };
    assert_eq!(
        choose_neutral_frame(&h, &none, &PhoneInventory::default(), 10.0),
        Some(NeutralFrame { frame: 4, in_silence: false })
    );
    assert_eq!(choose_neutral_frame(&vec![None; 3], &al, &PhoneInventory::default(), 10.0), None);
}
