//! The head view on a real head (MakeHuman's `base.obj`, a whole figure with helper
//! geometry, and eos's SFM mean, a face mask): framed on the face in any orientation, `0`
//! and leaving the view keep that framing, picking lands on the visible surface (an eye
//! corner on the eyelid, not in the socket behind the eyeball), and the map selector.
//! Skips when `../shared` is absent.

mod common;

use lipmap::io::landmark_map_toml::read_landmark_map;
use lipmap::io::model_source;
use lipmap::math::{Matrix3, Point3, Vector3};
use lipmap::model::face_locate::locate_face;
use lipmap::model::{LandmarkMap, Mesh};
use lipmap::session::MapRole;
use lipmap::tui::app::App;
use lipmap::tui::fixtures::synthetic_app;
use lipmap::tui::screens::View;
use lipmap::tui::screens::head::view::{pick_vertex, project, view_rotation};
use lipmap::tui::{Action, update};
use std::sync::Arc;

fn run(app: &mut App, actions: impl IntoIterator<Item = Action>) {
    for a in actions {
        let mut next = Some(a);
        while let Some(a) = next {
            next = update(app, a);
        }
    }
}

fn makehuman() -> Option<(Mesh, Vec<bool>, Vec<bool>, LandmarkMap)> {
    let (dir, mesh, skin, map) = common::makehuman()?;
    Some((mesh, skin, common::makehuman_occluders(&dir), map))
}

fn turned(mesh: &Mesh, r: &Matrix3, t: Vector3) -> Mesh {
    Mesh {
        vertices: mesh.vertices.iter().map(|p| Point3::from(r * p.coords + t)).collect(),
        faces: mesh.faces.clone(),
    }
}

fn placements() -> Vec<(&'static str, Matrix3, Vector3)> {
    let rot = common::rotation_deg;
    vec![
        ("y-up", Matrix3::identity(), Vector3::zeros()),
        ("z-up", rot(Vector3::x(), 90.0), Vector3::new(0.0, 0.0, 3.0)),
        ("facing -z", rot(Vector3::y(), 180.0), Vector3::new(5.0, -2.0, 1.0)),
        ("lying, turned", rot(Vector3::new(1.0, 0.3, -0.2), 75.0), Vector3::new(-4.0, 1.0, 9.0)),
    ]
}

#[test]
fn the_face_is_found_on_makehuman_in_any_orientation() {
    let Some((mesh, skin, _, fixture)) = makehuman() else { return };
    let tris = mesh.triangles();
    let tip = mesh.vertices[fixture.vertex(30).unwrap()];
    for (name, r, t) in placements() {
        let m = turned(&mesh, &r, t);
        // With its helper geometry left out, and as a scan would come: no groups at all.
        for (groups, eligible) in [("groups", Some(skin.as_slice())), ("no groups", None)] {
            let face = locate_face(&m.vertices, &tris, eligible)
                .unwrap_or_else(|| panic!("{name}, {groups}: no face found"));
            eprintln!("MakeHuman {name}, {groups}: {face:?}");
            let want = r * tip.coords + t;
            // Decimetres: 0.15 is 15 mm.
            let off = (face.nose_tip.coords - want).norm();
            assert!(off < 0.15, "{name}, {groups}: nose tip {off:.3} dm off ({face:?})");
            assert!(face.axes.row(2).transpose().dot(&(r * Vector3::z())) > 0.9, "{name}: forward");
            assert!(face.axes.row(1).transpose().dot(&(r * Vector3::y())) > 0.9, "{name}: up");
            // An adult face is about 1/100 dm per mm.
            assert!((0.007..0.014).contains(&face.scale), "{name}: scale {}", face.scale);
        }
    }
}

#[test]
fn the_face_is_found_on_the_sfm_mean() {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let model = model_source::load_model(&eos.join("share/sfm_shape_3448.bin"), None).unwrap();
    let map = read_landmark_map(&eos.join("share/ibug_to_sfm.txt")).unwrap();
    let mesh = model.mean_mesh();
    let tip = mesh.vertices[map.vertex(30).unwrap()];
    for (name, r, t) in placements() {
        let m = turned(&mesh, &r, t * 100.0);
        let face = locate_face(&m.vertices, &model.triangles, None).expect(name);
        eprintln!("SFM mean {name}: {face:?}");
        let off = (face.nose_tip.coords - (r * tip.coords + t * 100.0)).norm();
        assert!(off < 15.0, "{name}: nose tip {off:.1} mm off ({face:?})");
        assert!(face.axes.row(1).transpose().dot(&(r * Vector3::y())) > 0.9, "{name}: up");
    }
}

/// The synthetic app with MakeHuman as the mesh the head view labels, helper geometry as
/// the session bridge sets it.
fn makehuman_app(mesh: Mesh, skin: Vec<bool>, solid: Vec<bool>) -> App {
    let mut app = synthetic_app(4, 176, 144, false);
    app.map = None;
    app.set_label_mesh(Arc::new(mesh), Some(Arc::new(skin)), Some(Arc::new(solid)));
    app.view = View::Head;
    app
}

#[test]
fn the_head_view_frames_the_face_and_zero_returns_to_it() {
    let Some((mesh, skin, solid, fixture)) = makehuman() else { return };
    let tip = mesh.vertices[fixture.vertex(30).unwrap()];
    let chin = mesh.vertices[fixture.vertex(8).unwrap()];
    let mut app = makehuman_app(mesh, skin, solid);
    let framing = app.head.framing;
    // The face, not the 17 dm figure: the sphere holds nose tip and chin and is head-sized.
    assert!(framing.radius < 1.6, "{framing:?}");
    assert!((framing.centre - tip).norm() < framing.radius);
    assert!((framing.centre - chin).norm() < framing.radius);
    run(&mut app, [Action::Rotate { yaw: 45, pitch: 30 }, Action::ZoomIn, Action::ZoomIn]);
    run(&mut app, [Action::MoveCursor { dx: 40, dy: -30 }]);
    run(&mut app, [Action::ShowFrames, Action::ShowHead]);
    assert_eq!(app.head.framing, framing, "leaving and coming back keeps the framing");
    run(&mut app, [Action::ResetView]);
    assert_eq!(app.head.framing, framing);
    assert_eq!((app.head.view.yaw, app.head.view.pitch, app.head.view.zoom), (0.0, 0.0, 1.0));
    // With five labels the box of the labels frames the view, still upright and frontal
    // when only one eye is labelled so far (as a user labels one side first).
    let mut labels = LandmarkMap::default();
    for l in [8, 30, 36, 48, 54] {
        labels.to_vertex.insert(l, fixture.vertex(l).unwrap());
    }
    app.map = Some(labels);
    run(&mut app, [Action::ResetView]);
    assert!((app.head.framing.centre - tip).norm() < app.head.framing.radius);
    assert!(app.head.framing.radius < framing.radius * 1.2, "{:?}", app.head.framing);
    let upright = app.head.framing.rotation * framing.rotation.transpose();
    assert!((upright - Matrix3::identity()).norm() < 1e-9, "turned by the labels: {upright}");
}

#[test]
fn picking_an_eye_corner_lands_on_the_eyelid_not_in_the_socket() {
    let Some((mesh, skin, solid, fixture)) = makehuman() else { return };
    let mut app = makehuman_app(mesh.clone(), skin.clone(), solid);
    for l in [36, 39, 42, 45] {
        let want = fixture.vertex(l).unwrap();
        // The cursor put on the eye corner as the view shows it, zoomed in as a user would.
        app.head.view.zoom = 6.0;
        let rot = view_rotation(&app.head.view, &app.head.framing);
        let p = project(&mesh, &rot, &app.head.framing)[want];
        app.head.view.cursor = (p.0, -p.1);
        let picked =
            pick_vertex(&mesh, &app.head.triangles, &app.head.framing, &app.head.view, Some(&skin))
                .unwrap();
        // Decimetres: within 3 mm of the hand map's corner, and not behind the eyeball.
        let off = (mesh.vertices[picked] - mesh.vertices[want]).norm();
        assert!(off < 0.03, "landmark {l}: picked {picked}, {:.1} mm from {want}", off * 100.0);
        let depth = app.head.framing.rotation.row(2).transpose();
        let behind = depth.dot(&(mesh.vertices[want] - mesh.vertices[picked]));
        assert!(behind < 0.03, "landmark {l}: {:.1} mm behind the corner", behind * 100.0);
    }
}

#[test]
fn the_selector_switches_between_the_model_and_the_head_map() {
    let mut app = synthetic_app(4, 176, 144, false);
    app.view = View::Head;
    // One map: there is nothing to switch to.
    run(&mut app, [Action::SwitchLabelledMesh]);
    assert_eq!(app.switch_map, None);
    assert!(app.status.contains("one map"), "{}", app.status);
    // Two maps: the run loop is asked to save and reopen on the other one.
    app.head.head_has_own_map = true;
    app.head.label_role = MapRole::Head;
    app.head.label_mesh_name = "base.obj".into();
    app.head.other_mesh_name = "sfm_shape_3448.bin".into();
    run(&mut app, [Action::SwitchLabelledMesh]);
    assert_eq!(app.switch_map, Some(MapRole::Model));
    assert!(app.save.should_quit(), "nothing unsaved: it leaves at once for the reopening");
    // Drawn: both meshes listed, the labelled one marked, the key in the status line.
    let mut app2 = synthetic_app(4, 176, 144, false);
    app2.view = View::Head;
    app2.head.head_has_own_map = true;
    app2.head.label_role = MapRole::Head;
    app2.head.label_mesh_name = "base.obj".into();
    app2.head.other_mesh_name = "sfm_shape_3448.bin".into();
    app2.status.clear();
    let keymap = lipmap::tui::Keymap::builtin().unwrap();
    let mut t = ratatui::Terminal::new(ratatui::backend::TestBackend::new(120, 30)).unwrap();
    t.draw(|f| lipmap::tui::draw::draw(&app2, &keymap, f)).unwrap();
    let text: String = t
        .backend()
        .buffer()
        .content()
        .chunks(120)
        .map(|row| row.iter().map(|c| c.symbol()).collect::<String>() + "\n")
        .collect();
    assert!(text.contains("▸ head  base.obj"), "{text}");
    // The other mesh's name is cut to the panel's width, with an ellipsis.
    assert!(text.contains("  model sfm_shape_3448"), "{text}");
    assert!(text.contains("m label the model map"), "{text}");
}
