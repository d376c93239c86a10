//! Suggestions matched to the head's own face (`fit::own_face`: the head drawn from the
//! front, dlib's shape predictor run on the drawing with the hand labels held), as `lipmap
//! map suggest` makes them when the predictor is installed: on MakeHuman from six hand-map
//! labels, and the same head turned and moved. Skips when `../shared/data` or the predictor
//! (Debian `libdlib-data`) is absent. The figures on faces with human landmarks are in
//! `map_suggest_heldout` (docs/labelling.md).

mod common;

use lipmap::fit::map_suggest::suggest_map_on_own_face;
use lipmap::fit::own_face::own_face_landmarks;
use lipmap::fit::suggest::{SuggestHead, surface_triangles};
use lipmap::io::obj;
use lipmap::math::{Point3, Vector3};
use lipmap::model::{LandmarkMap, check_map};
use lipmap::track::{DEBIAN_PREDICTOR_PATH, read_shape_predictor};
use std::path::Path;

/// The hand labels, 0-based: chin, nose tip, outer eye corners, mouth corners.
const LABELS: [usize; 6] = [8, 30, 36, 45, 48, 54];

#[test]
fn six_labels_on_the_heads_own_face_give_a_unique_sane_map_invariant_to_placement() {
    let Some((dir, mesh, skin, fixture)) = common::makehuman() else { return };
    let Ok(predictor) = read_shape_predictor(Path::new(DEBIAN_PREDICTOR_PATH)) else {
        eprintln!("skipped: no shape predictor at {DEBIAN_PREDICTOR_PATH} (libdlib-data)");
        return;
    };
    let path = dir.join("base.obj");
    let solid = obj::occluding_vertices(&path).unwrap().unwrap();
    let triangles = surface_triangles(&mesh.triangles(), Some(&solid));
    let mut labels = LandmarkMap::default();
    for l in LABELS {
        labels.to_vertex.insert(l, fixture.vertex(l).unwrap());
    }
    let head =
        SuggestHead { vertices: &mesh.vertices, triangles: &triangles, eligible: Some(&skin) };

    // The labels are held: the predictor's points for them are their vertices' projections.
    let own = own_face_landmarks(&head, &labels, &predictor).unwrap();
    for l in LABELS {
        let p = own.pose.project(&mesh.vertices[labels.vertex(l).unwrap()], own.image_height);
        let q = &own.landmarks.points[l];
        assert!((p.x - q.x).abs() < 1e-9 && (p.y - q.y).abs() < 1e-9, "label {l} moved");
    }
    assert!(own.landmarks.points.iter().all(|p| p.visible && p.x.is_finite() && p.y.is_finite()));

    let proposal = suggest_map_on_own_face(&head, &labels, &predictor).unwrap();
    let map = proposal.applied_to(&labels);
    eprintln!("{}", proposal.summary());
    assert_eq!(common::vertices_used_twice(&map), 0, "no vertex is used twice");
    assert!(proposal.accepted.len() >= 55, "{}", proposal.summary());
    assert!(map.to_vertex.values().all(|&v| skin[v]), "only skin vertices");
    let check = check_map(&map, &mesh.vertices);
    assert!(check.is_plausible(), "{}", check.summary());
    // Against the hand map (mm; the mesh is in decimetres): the hand map is one labeller's
    // convention on a head without brows, so only a loose bound: most within 2 cm.
    let off_mm: Vec<f64> = proposal
        .accepted
        .iter()
        .filter_map(|s| {
            let r = mesh.vertices[fixture.vertex(s.landmark)?];
            Some((mesh.vertices[s.vertex] - r).norm() * 100.0)
        })
        .collect();
    let within = off_mm.iter().filter(|d| **d <= 20.0).count();
    assert!(within * 10 >= off_mm.len() * 8, "{within} of {} within 2 cm", off_mm.len());

    // The same head turned, tilted and moved: the drawing is made in the face's own axes,
    // so the same vertices come back.
    let r = *nalgebra::Rotation3::from_euler_angles(0.4, -0.7, 1.9).matrix();
    let t = Vector3::new(12.0, -30.0, 5.0);
    let moved: Vec<Point3> = mesh.vertices.iter().map(|p| Point3::from(r * p.coords + t)).collect();
    let head = SuggestHead { vertices: &moved, ..head };
    let again = suggest_map_on_own_face(&head, &labels, &predictor).unwrap();
    let same = again
        .accepted
        .iter()
        .filter(|s| {
            proposal.accepted.iter().any(|o| o.landmark == s.landmark && o.vertex == s.vertex)
        })
        .count();
    assert!(same + 2 >= proposal.accepted.len(), "{same} of {} the same", proposal.accepted.len());
}

/// Both fronts take one path: the TUI's `O` (its effect handed to the suggestions' job, the
/// job's reply applied by `update`) labels the same map as `lipmap map suggest` writes, on
/// the same session (carphone with MakeHuman as model and head, six hand labels).
#[test]
fn the_tui_and_the_command_line_suggest_the_same_map() {
    use lipmap::tui::app::Effect;
    use lipmap::tui::jobs::{TrackerSource, suggest_for_tui};
    use lipmap::tui::session_bridge::SessionBridge;
    use lipmap::tui::{Action, update};
    let Some((dir, _, _, fixture)) = common::makehuman() else { return };
    let Some(cp) = common::carphone(12) else { return };
    if read_shape_predictor(Path::new(DEBIAN_PREDICTOR_PATH)).is_err() {
        eprintln!("skipped: no shape predictor at {DEBIAN_PREDICTOR_PATH} (libdlib-data)");
        return;
    }
    let mut labels = LandmarkMap::default();
    for l in LABELS {
        labels.to_vertex.insert(l, fixture.vertex(l).unwrap());
    }
    let six = cp.root.join("six.toml");
    lipmap::io::landmark_map_toml::write_landmark_map(
        &six,
        &labels,
        &lipmap::reference::current().names,
    )
    .unwrap();
    let head = dir.join("base.obj");
    let session = cp.root.join("s.lipmap.json");
    let new = common::lipmap(&[
        "new",
        common::s(&session),
        "--frames",
        common::s(&cp.frames),
        "--landmarks",
        common::s(&cp.landmarks),
        "--model",
        common::s(&head),
        "--head",
        common::s(&head),
        "--mapping",
        common::s(&six),
    ]);
    assert!(new.status.success(), "{}", common::text(&new.stderr));
    let out = cp.root.join("cli.toml");
    let cli = common::lipmap(&["map", "suggest", common::s(&session), "--out", common::s(&out)]);
    assert!(cli.status.success(), "{}", common::text(&cli.stderr));
    assert!(
        common::text(&cli.stdout).contains("the head's own face"),
        "{}",
        common::text(&cli.stdout)
    );
    let written = lipmap::io::landmark_map_toml::read_landmark_map(&out).unwrap();

    let (mut app, bridge, _) = SessionBridge::open(&session, 0).unwrap();
    let mut next = Some(Action::ShowHead);
    while let Some(a) = next.take() {
        next = update(&mut app, a);
    }
    next = update(&mut app, Action::SuggestAllLabels);
    assert!(next.is_none());
    let effects = app.take_effects();
    let Some(Effect::SuggestMap { labels: asked, landmark: None }) = effects.last().cloned() else {
        panic!("no suggestion asked: {effects:?}");
    };
    assert_eq!(asked, labels);
    let reply =
        suggest_for_tui(&TrackerSource::default(), bridge.suggest_job(asked, None), &|_| {});
    let Action::MapSuggested { suggested: Ok(s), .. } = reply.clone() else { panic!("{reply:?}") };
    assert!(s.proposal.accepted.len() >= 55, "{}", s.proposal.summary());
    let mut next = Some(reply);
    while let Some(a) = next.take() {
        next = update(&mut app, a);
    }
    assert!(app.status.contains("matched to the head's own face"), "{}", app.status);
    assert_eq!(app.map.as_ref(), Some(&written), "the TUI's map is the command line's");
    // `o` on one of them puts the cursor on a vertex no other landmark holds (with 61
    // labels held rather than 6, the drawing's match may move it).
    let l = s.proposal.accepted[0].landmark;
    app.head.view.label = l;
    next = update(&mut app, Action::SuggestLabel);
    assert!(next.is_none());
    let Some(Effect::SuggestMap { labels: asked, landmark: Some(one) }) =
        app.take_effects().last().cloned()
    else {
        panic!("no suggestion asked for {l}");
    };
    assert_eq!((one, asked.vertex(l)), (l, None));
    let reply =
        suggest_for_tui(&TrackerSource::default(), bridge.suggest_job(asked, Some(l)), &|_| {});
    next = Some(reply);
    while let Some(a) = next.take() {
        next = update(&mut app, a);
    }
    let Some((at, v)) = app.head.view.suggested else { panic!("{}", app.status) };
    assert_eq!(at, l, "{}", app.status);
    assert!(written.pairs().all(|(k, w)| k == l || w != v), "{}", app.status);
}
