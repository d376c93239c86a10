//! `lipmap tables --out DIR` and `lipmap --data DIR`: the built-in reference tables written
//! out, edited, and used in place of the built-ins by a command, through the binary.

mod common;

use std::path::Path;
use std::process::Command;

fn lipmap(args: &[&str], env_data: Option<&Path>) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_lipmap"));
    cmd.args(args).env_remove("LIPMAP_DATA");
    if let Some(d) = env_data {
        cmd.env("LIPMAP_DATA", d);
    }
    let out = cmd.output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.success(), text(&out.stdout), text(&out.stderr))
}

#[test]
fn an_edited_viseme_table_regroups_the_evaluation() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let session = session.to_str().unwrap();
    let tables = dir.path().join("tables");
    let t = tables.to_str().unwrap();
    let (ok, out, err) = lipmap(&["tables", "--out", t], None);
    assert!(ok, "{err}");
    assert_eq!(out.matches("wrote ").count(), 5, "{out}");
    let (ok, _, err) = lipmap(&["tables", "--out", t], None);
    assert!(!ok && err.contains("phones.csv: already exists"), "{err}");

    // One class renamed in the user's copy; the other tables left as written.
    let visemes = tables.join("visemes.toml");
    let text = std::fs::read_to_string(&visemes).unwrap();
    std::fs::write(&visemes, text.replace("\"bilabials\"", "\"lips together\"")).unwrap();
    let (ok, builtin, err) = lipmap(&["eval", session], None);
    assert!(ok, "{err}");
    assert!(builtin.contains("bilabials") && !builtin.contains("lips together"), "{builtin}");
    for (args, env) in
        [(vec!["--data", t, "eval", session], None), (vec!["eval", session], Some(&*tables))]
    {
        let (ok, edited, err) = lipmap(&args, env);
        assert!(ok, "{err}");
        assert!(edited.contains("lips together") && !edited.contains("bilabials"), "{edited}");
    }

    // The user's phone inventory merges EH into AE: the per-phoneme table loses its EH row.
    let phones = tables.join("phones.csv");
    let text = std::fs::read_to_string(&phones).unwrap();
    std::fs::write(&phones, text.replace("EH,ɛ,\n", "").replace("AE,æ a,", "AE,æ a ɛ,eh")).unwrap();
    let has_row =
        |table: &str, phone: &str| table.lines().any(|l| l.starts_with(&format!("{phone} ")));
    assert!(has_row(&builtin, "EH") && has_row(&builtin, "AE"), "{builtin}");
    let (ok, merged, err) = lipmap(&["--data", t, "eval", session], None);
    assert!(ok, "{err}");
    assert!(!has_row(&merged, "EH") && has_row(&merged, "AE"), "{merged}");
    std::fs::write(&phones, text).unwrap();

    // A table that does not parse stops the command with its file and line.
    std::fs::write(&visemes, "[[classes]]\nid = \"S\"\nphones = [\"sil\"\n").unwrap();
    let (ok, _, err) = lipmap(&["eval", session, "--data", t], None);
    assert!(!ok && err.lines().count() == 1, "{err}");
    assert!(err.contains("visemes.toml:3"), "{err}");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (ok, _, err) = lipmap(&["--data", empty.to_str().unwrap(), "eval", session], None);
    assert!(!ok && err.contains("holds none of") && err.contains("lipmap tables --out"), "{err}");
}
