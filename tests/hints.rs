//! Every command lipmap suggests in a message (`lipmap import SESSION --mapping FILE`, …)
//! must exist: the hints are collected from the source and each is run through the binary's
//! own clap parser, which must not reject its subcommand or any of its flags.

use clap::Parser;
use clap::error::ErrorKind;
use lipmap::cli::Cli;
use std::path::{Path, PathBuf};

/// A hint found in the source: where, and its words after `lipmap`.
#[derive(Debug)]
struct Hint {
    at: String,
    words: Vec<String>,
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// A word of a hint: a flag, a placeholder (`SESSION`, `FILE`, `{}`), or a lowercase word
/// (subcommand or value).
fn hint_words(rest: &str) -> Vec<String> {
    let end = rest.find(['`', ')', '"', ',', ';', '\n', '(']).unwrap_or(rest.len());
    rest[..end]
        .split_whitespace()
        .map(|w| w.trim_end_matches(['.', ':']).to_string())
        .filter(|w| !w.is_empty() && w != "…" && w != "...")
        .collect()
}

/// `lipmap WORD …` in backticks, or followed by a flag or a placeholder (`SESSION`), is a
/// hint; prose such as "a lipmap model file", "this lipmap reads {VERSION}" or a format
/// string's "lipmap mesh: {} vertices" is not (a `{}` alone does not make a hint).
fn is_hint(before: Option<char>, words: &[String]) -> bool {
    let Some(first) = words.first() else { return false };
    if !first.chars().all(|c| c.is_ascii_lowercase() || c == '-') {
        return false;
    }
    let placeholder = |w: &String| {
        w.starts_with("--")
            || (w.len() > 1 && w.chars().all(|c| c.is_ascii_uppercase() || c == '_'))
    };
    before == Some('`') || words.iter().skip(1).take(2).any(placeholder)
}

fn collect_hints() -> Vec<Hint> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    let mut hints = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.trim_start();
            if code.starts_with("//") || code.starts_with("#[") {
                continue;
            }
            let mut from = 0;
            while let Some(k) = line[from..].find("lipmap ") {
                let at = from + k;
                let before = line[..at].chars().next_back();
                let words = hint_words(&line[at + "lipmap ".len()..]);
                if is_hint(before, &words) {
                    let rel = f.strip_prefix(root).unwrap_or(&f).display().to_string();
                    hints.push(Hint { at: format!("{rel}:{}", n + 1), words });
                }
                from = at + "lipmap ".len();
            }
        }
    }
    hints
}

/// The hint as command-line arguments: placeholders become a value.
fn argv(hint: &Hint) -> Vec<String> {
    let mut v = vec!["lipmap".to_string()];
    for w in &hint.words {
        v.push(if w.starts_with('{') { "x".into() } else { w.clone() });
    }
    v
}

#[test]
fn every_hint_names_a_command_and_flags_that_exist() {
    let hints = collect_hints();
    assert!(hints.len() >= 5, "the scan finds the hints: {hints:?}");
    let mut bad = Vec::new();
    for h in &hints {
        let args = argv(h);
        if let Err(e) = Cli::try_parse_from(&args) {
            // Missing values or required arguments are the placeholders' business; an
            // unknown subcommand or flag is a hint that cannot work.
            if matches!(e.kind(), ErrorKind::UnknownArgument | ErrorKind::InvalidSubcommand) {
                bad.push(format!("{}: `{}`: {}", h.at, args.join(" "), e.kind()));
            }
        }
    }
    assert!(bad.is_empty(), "hints naming commands that do not exist:\n{}", bad.join("\n"));
}

#[test]
fn the_check_catches_a_missing_flag() {
    let hint = Hint { at: "test".into(), words: vec!["import".into(), "--mesh".into()] };
    let e = Cli::try_parse_from(argv(&hint)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::UnknownArgument);
    // Prose and format strings are not hints; a session placeholder before a flag is.
    assert!(!is_hint(Some(' '), &hint_words("reads {VERSION})")));
    assert!(!is_hint(Some(' '), &hint_words("mesh: {} vertices, {} faces")));
    assert!(is_hint(Some(' '), &hint_words("import {} --mapping {}")));
    let hint = Hint { at: "test".into(), words: vec!["relabel".into(), "x".into()] };
    let e = Cli::try_parse_from(argv(&hint)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidSubcommand);
}
