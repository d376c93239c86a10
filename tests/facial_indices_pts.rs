//! Facial indices on real human iBUG-68 annotations (`../shared/data/images/*.pts`), checked
//! against distances worked out in the test by explicit point arithmetic.

use lipmap::math::Point2;
use lipmap::measure::indices::{FacialIndex, facial_distances, facial_indices};

/// The 68 points of a `.pts` file, parsed here (independently of `io::pts`). Coordinates
/// stay 1-based: a constant offset changes no distance.
fn read_pts(path: &std::path::Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let body = text.split('{').nth(1).unwrap().split('}').next().unwrap();
    let nums: Vec<f64> = body.split_whitespace().map(|s| s.parse().unwrap()).collect();
    assert_eq!(nums.len(), 136, "{}", path.display());
    nums.chunks(2).map(|c| (c[0], c[1])).collect()
}

fn hypot(a: (f64, f64), b: (f64, f64)) -> f64 {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
}

/// D1..D13 by hand from the raw coordinates, following the definitions in `measure::indices::distances` literally.
fn hand_distances(p: &[(f64, f64)]) -> [f64; 13] {
    let nasion = ((p[39].0 + p[42].0) / 2.0, (p[39].1 + p[42].1) / 2.0);
    [
        hypot(p[8], nasion),  // D1 gnathion–nasion
        hypot(p[0], p[16]),   // D2 zygion–zygion
        hypot(p[36], p[45]),  // D3 exocanthion–exocanthion
        hypot(p[39], p[42]),  // D4 endocanthion–endocanthion
        hypot(nasion, p[33]), // D5 nasion–subnasale
        hypot(p[31], p[35]),  // D6 alare–alare
        hypot(p[51], p[57]),  // D7 labiale sup.–labiale inf.
        hypot(p[48], p[54]),  // D8 cheilion–cheilion
        hypot(p[51], p[62]),  // D9 labiale sup.–stomion 1
        hypot(p[66], p[57]),  // D10 stomion 2–labiale inf.
        hypot(p[57], p[8]),   // D11 labiale inf.–gnathion
        hypot(p[33], p[51]),  // D12 subnasale–labiale sup.
        hypot(p[33], p[8]),   // D13 subnasale–gnathion
    ]
}

fn check(name: &str, pinned_vertical_mouth_height: f64, pinned_facial: f64) {
    let Some(dir) = lipmap::testdata::shared("data/images") else { return };
    let raw = read_pts(&dir.join(name));
    let pts: Vec<Option<Point2>> = raw.iter().map(|&(x, y)| Some(Point2::new(x, y))).collect();

    let d = hand_distances(&raw);
    let got = facial_distances(&pts).unwrap();
    for (k, (g, h)) in got.d.iter().zip(&d).enumerate() {
        assert!((g - h).abs() < 1e-9, "{name} D{}: {g} vs {h}", k + 1);
    }
    let by_hand = [
        (FacialIndex::Facial, d[0] / d[1]),
        (FacialIndex::Intercanthal, d[3] / d[2]),
        (FacialIndex::Nasal, d[5] / d[4]),
        (FacialIndex::Nasofacial, d[4] / d[0]),
        (FacialIndex::NoseFaceWidth, d[5] / d[1]),
        (FacialIndex::LipArea, d[6] / d[7]),
        (FacialIndex::VerticalMouthHeight, d[6] / d[0]),
        (FacialIndex::UpperLipThickness, d[8] / d[0]),
        (FacialIndex::LowerLipThickness, d[9] / d[0]),
        (FacialIndex::MouthWidth, d[7] / d[2]),
        (FacialIndex::ChinSize, d[10] / d[0]),
        (FacialIndex::NoseUpperLip, d[11] / d[12]),
    ];
    let ix = facial_indices(&pts).unwrap();
    for (index, ratio) in by_hand {
        assert!((ix.get(index) - 100.0 * ratio).abs() < 1e-9, "{name} {index}");
    }
    // Pinned from an independent computation on the same file, so a parsing slip in both
    // the test and the library cannot pass unnoticed.
    let vmh = ix.get(FacialIndex::VerticalMouthHeight);
    assert!((vmh - pinned_vertical_mouth_height).abs() < 1e-3, "{name}: {vmh}");
    let facial = ix.get(FacialIndex::Facial);
    assert!((facial - pinned_facial).abs() < 1e-3, "{name}: {facial}");
}

#[test]
fn takeo_indices_match_hand_arithmetic() {
    check("takeo.pts", 11.7657, 77.9175);
}

#[test]
fn einstein_indices_match_hand_arithmetic() {
    check("einstein.pts", 23.3786, 89.3764);
}
