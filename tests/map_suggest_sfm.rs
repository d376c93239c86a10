//! Suggestions on eos's Surrey Face Model mean (`../shared/peer/eos/`), whose landmarks eos
//! ships (`landmarks_and_contours.json`: 50 fixed iBUG points and the model's frontal jaw
//! contour, the vertices its contour fitting chooses the jaw landmarks from). Six labels
//! from that map (chin, nose tip, outer eye corners, mouth corners) and carphone's frame 0
//! (`../shared/data/carphone/`) suggest the rest: no vertex twice, most landmarks, the fixed
//! ones near eos's, and the jaw on the model's frontal contour, symmetric. Skips when the
//! shared data is absent.

mod common;

use lipmap::fit::map_suggest::suggest_map;
use lipmap::fit::suggest::SuggestHead;
use lipmap::io::landmark_format::read_track;
use lipmap::io::model_source::load_model;
use lipmap::math::Point3;
use lipmap::model::LandmarkMap;

/// Carphone's frames are 176 × 144.
const IMAGE_HEIGHT: f64 = 144.0;

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

#[test]
fn six_labels_on_the_sfm_mean_put_the_jaw_on_its_frontal_contour() {
    let (Some(eos), Some(pts)) = (
        lipmap::testdata::shared("peer/eos"),
        lipmap::testdata::shared("data/carphone/dlib68_pts"),
    ) else {
        eprintln!("skipped: ../shared/peer/eos or ../shared/data/carphone is absent");
        return;
    };
    let model = load_model(&eos.join("share/sfm_shape_3448.bin"), None).unwrap();
    let mesh = model.mean_mesh();
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(eos.join("model/landmarks_and_contours.json")).unwrap(),
    )
    .unwrap();
    let eos_map = LandmarkMap {
        to_vertex: json["ibug_to_sfm_vertex"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.parse::<usize>().unwrap() - 1, v.as_u64().unwrap() as usize))
            .collect(),
    };
    let contour = |side: &str| -> Vec<Point3> {
        json["model_contour"][side]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| mesh.vertices[v.as_u64().unwrap() as usize])
            .collect()
    };
    let (right, left) = (contour("right_contour"), contour("left_contour"));
    let track = read_track(&pts).unwrap();
    let mut labels = LandmarkMap::default();
    for l in [8, 30, 36, 45, 48, 54] {
        labels.to_vertex.insert(l, eos_map.vertex(l).unwrap());
    }
    let head =
        SuggestHead { vertices: &mesh.vertices, triangles: &model.triangles, eligible: None };
    let proposal = suggest_map(&head, &labels, &track.frames[0], IMAGE_HEIGHT, None).unwrap();
    let map = proposal.applied_to(&labels);
    eprintln!("{}", proposal.summary());
    for (l, why) in &proposal.left {
        eprintln!("left {}: {why}", l + 1);
    }
    assert_eq!(common::vertices_used_twice(&map), 0, "no vertex is used twice");
    assert!(proposal.accepted.len() >= 50, "{}", proposal.summary());

    // The fixed landmarks eos maps, in mm (the model's units).
    let fixed: Vec<f64> = proposal
        .accepted
        .iter()
        .filter_map(|s| {
            Some((mesh.vertices[s.vertex] - mesh.vertices[eos_map.vertex(s.landmark)?]).norm())
        })
        .collect();
    // The jaw: distance to the model's frontal contour (its side), and left–right symmetry
    // (a point and its mirror partner at the same height and the same distance from the
    // chin's vertical).
    let jaw: Vec<(usize, Point3)> =
        map.pairs().filter(|(l, _)| *l < 17).map(|(l, v)| (l, mesh.vertices[v])).collect();
    let on_contour: Vec<f64> = jaw
        .iter()
        .filter(|(l, _)| *l != 8)
        .map(|(l, p)| common::to_polyline(p, if *l < 8 { &right } else { &left }))
        .collect();
    let chin = mesh.vertices[labels.vertex(8).unwrap()];
    let asymmetry: Vec<f64> = jaw
        .iter()
        .filter(|(l, _)| *l < 8)
        .filter_map(|&(l, p)| {
            let (_, q) = jaw.iter().find(|(m, _)| *m == 16 - l)?;
            Some(((p.y - q.y).abs()).max(((p.x - chin.x) + (q.x - chin.x)).abs()))
        })
        .collect();
    eprintln!(
        "SFM mean: {} suggested; eos's fixed landmarks: median {:.1} mm, worst {:.1} mm; jaw ({}): median {:.1} mm from the frontal contour, worst {:.1}; mirror pairs differ by {:.1} mm at most",
        proposal.accepted.len(),
        median(fixed.clone()),
        fixed.iter().cloned().fold(0.0, f64::max),
        on_contour.len(),
        median(on_contour.clone()),
        on_contour.iter().cloned().fold(0.0, f64::max),
        asymmetry.iter().cloned().fold(0.0, f64::max),
    );
    assert!(on_contour.len() >= 12, "{} jaw points", on_contour.len());
    assert!(median(on_contour.clone()) <= 5.0, "jaw off the frontal contour: {on_contour:?}");
    assert!(median(fixed) <= 6.0, "fixed landmarks");
}
