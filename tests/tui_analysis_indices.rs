//! The analysis view's facial indices are those `lipmap indices` prints for the same session:
//! a head that is another mesh than the model is read through its own map whichever map the
//! head view labels, and the speaker on the clip's landmarks as corrected (not the fit's
//! input with sealed lips closed). Real data from ../shared (skipped when absent).

mod common;
use common::{lipmap, s, text};

use lipmap::session::MapRole;
use lipmap::tui::jobs::{AnalysisJob, analyse_for_tui};
use lipmap::tui::session_bridge::SessionBridge;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// Index name → value of the JSON table `key` of `lipmap indices --json`.
fn cli_values(json: &Value, key: &str) -> BTreeMap<String, f64> {
    json[key]["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|r| Some((r["index"].as_str()?.to_string(), r["value"].as_f64()?)))
        .collect()
}

/// Index name → value of the analysis view's table titled `title`.
fn tui_values(
    tables: &[lipmap::tui::screens::analysis::AnalysisTable],
    title: &str,
) -> BTreeMap<String, f64> {
    let t =
        tables.iter().find(|t| t.title.starts_with(title)).unwrap_or_else(|| panic!("no {title}"));
    let value = t.columns.iter().position(|c| c == "value").unwrap();
    t.rows.iter().filter_map(|r| Some((r.cells[0].clone(), r.keys[value]?))).collect()
}

fn assert_same(tui: &BTreeMap<String, f64>, cli: &BTreeMap<String, f64>, what: &str) {
    assert_eq!(tui.keys().collect::<Vec<_>>(), cli.keys().collect::<Vec<_>>(), "{what}");
    for (k, v) in cli {
        assert!((tui[k] - v).abs() < 1e-9, "{what} {k}: TUI {} vs CLI {v}", tui[k]);
    }
}

#[test]
fn the_analysis_views_indices_are_those_of_lipmap_indices_in_both_labelling_roles() {
    let (Some(c), Some(mh)) = (common::carphone(30), lipmap::testdata::shared("data/makehuman"))
    else {
        return;
    };
    let session = c.root.join("two.lipmap.json");
    let head_map =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let out = lipmap(&[
        "new",
        s(&session),
        "--frames",
        s(&c.frames),
        "--fps",
        "29.97",
        "--landmarks",
        s(&c.landmarks),
        "--model",
        s(&c.eos.join("sfm_shape_3448.bin")),
        "--mapping",
        s(&c.eos.join("ibug_to_sfm.txt")),
        "--head",
        s(&mh.join("base.obj")),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = lipmap(&["import", s(&session), "--head-mapping", s(&head_map)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = lipmap(&["indices", s(&session), "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: Value = serde_json::from_slice(&out.stdout).unwrap();
    let (cli_speaker, cli_head) = (cli_values(&json, "speaker"), cli_values(&json, "head"));
    assert!(cli_head.len() >= 10, "{cli_head:?}");

    for role in [MapRole::Model, MapRole::Head] {
        let (app, bridge, _frames) =
            SessionBridge::open_labelling(&session, 0, Some(role)).unwrap();
        assert_eq!(app.head.label_role, role);
        let job = AnalysisJob::of(&app, 1, "carphone".into()).expect("model and map");
        let data = analyse_for_tui(&job);
        assert_same(&tui_values(&data.tables, "speaker indices"), &cli_speaker, "speaker");
        assert_same(&tui_values(&data.tables, "head indices"), &cli_head, "head");
        drop(bridge);
    }
}
