//! The names lipmap prints for the quantities of its methods, and what each means: one name
//! per quantity, so `fit`, `eval`, `transfer`, `saqp`, the TUI and the docs say the same
//! thing. The explanations are `docs/glossary.md`, embedded at build time, which `lipmap help
//! TERM` prints from; [`names`] are the names as code prints them, each tested to have its
//! entry there.
//!
//! Start with [`lookup`].

/// The glossary as shipped (`docs/glossary.md`).
pub const GLOSSARY_MD: &str = include_str!("../docs/glossary.md");

/// Quantity names as every output prints them (each has a glossary entry, tested).
pub mod names {
    /// One point's distance from the fit, in image pixels.
    pub const REPROJECTION_ERROR: &str = "reprojection error";
    /// One frame's RMS of its points' reprojection errors, in image pixels.
    pub const REPROJECTION_RMS: &str = "reprojection RMS";
    /// Frames replaced by interpolation between usable neighbours.
    pub const FILLED_FRAMES: &str = "frames filled from neighbours";
    /// The RMS landmark distance left once a model is placed on a head.
    pub const PLACEMENT_RESIDUAL: &str = "placement residual";
    /// Barycentric control triangles left out.
    pub const TRIANGLES_DROPPED: &str = "control triangles dropped";
    /// The weight of the mouth markers in SAQP's quality error.
    pub const MOUTH_WEIGHT: &str = "mouth weight ω_m";
    /// The largest quality error among the training sentences.
    pub const LARGEST_TRAINING_ERROR: &str = "largest training error ξ";
    /// SAQP's fitting error of a phone sequence.
    pub const SATF_ERROR: &str = "SATF error E";
    /// The SATF smoothing weight.
    pub const SMOOTHING_WEIGHT: &str = "smoothing weight λ";
    /// The fitting landmark set.
    pub const LANDMARK_SET: &str = "landmark set";
    /// The default trajectory normalisation.
    pub const MIN_MAX: &str = "min–max scaled";
}

/// One glossary entry, borrowed from the glossary text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry<'a> {
    /// The name as printed (the entry's heading).
    pub term: &'a str,
    /// Other names it answers to (symbols, column names, older wordings).
    pub aliases: Vec<&'a str>,
    /// Its unit, as written.
    pub unit: &'a str,
    /// The explanation (Markdown paragraphs).
    pub text: &'a str,
}

impl Entry<'_> {
    /// The entry as `lipmap help TERM` prints it: name, unit, other names, explanation.
    pub fn to_text(&self) -> String {
        let mut s = format!("{}  ({})\n", self.term, self.unit);
        if !self.aliases.is_empty() {
            s.push_str(&format!("also: {}\n", self.aliases.join(", ")));
        }
        s.push('\n');
        s.push_str(self.text.trim());
        s.push('\n');
        s
    }
}

/// Every entry of `text` (a glossary in `docs/glossary.md`'s layout: `## term`, then an
/// `Also:` line and a `Unit:` line, then paragraphs), in order.
pub fn entries_of(text: &str) -> Vec<Entry<'_>> {
    let mut out = Vec::new();
    for section in text.split("\n## ").skip(1) {
        let (term, rest) = section.split_once('\n').unwrap_or((section, ""));
        let mut aliases = Vec::new();
        let mut unit = "";
        let mut body = rest;
        loop {
            let (line, after) = body.split_once('\n').unwrap_or((body, ""));
            if let Some(a) = line.strip_prefix("Also:") {
                aliases = a.split(',').map(str::trim).filter(|a| !a.is_empty()).collect();
            } else if let Some(u) = line.strip_prefix("Unit:") {
                unit = u.trim();
            } else {
                break;
            }
            body = after;
        }
        out.push(Entry { term: term.trim(), aliases, unit, text: body.trim() });
    }
    out
}

/// Every entry of the shipped glossary.
pub fn entries() -> Vec<Entry<'static>> {
    entries_of(GLOSSARY_MD)
}

/// A term as compared: case, `-`, `_` and repeated spaces do not matter.
fn folded(s: &str) -> String {
    s.to_lowercase().replace(['-', '_', '–'], " ").split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The entry named `query` (its name or one of its other names; case, `-` and `_` ignored).
pub fn lookup(query: &str) -> Option<Entry<'static>> {
    let q = folded(query);
    entries().into_iter().find(|e| folded(e.term) == q || e.aliases.iter().any(|a| folded(a) == q))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_printed_name_has_an_entry_with_a_unit() {
        use names::*;
        for name in [
            REPROJECTION_ERROR,
            REPROJECTION_RMS,
            FILLED_FRAMES,
            PLACEMENT_RESIDUAL,
            TRIANGLES_DROPPED,
            MOUTH_WEIGHT,
            LARGEST_TRAINING_ERROR,
            SATF_ERROR,
            SMOOTHING_WEIGHT,
            LANDMARK_SET,
            MIN_MAX,
        ] {
            let e = lookup(name).unwrap_or_else(|| panic!("no entry for `{name}`"));
            assert_eq!(e.term, name);
            assert!(!e.unit.is_empty() && e.text.len() > 40, "{name}: {e:?}");
        }
    }

    #[test]
    fn terms_are_found_by_their_other_names_whatever_the_case() {
        assert_eq!(lookup("omega_m").unwrap().term, names::MOUTH_WEIGHT);
        assert_eq!(lookup("XI").unwrap().term, names::LARGEST_TRAINING_ERROR);
        assert_eq!(lookup("bridged").unwrap().term, names::FILLED_FRAMES);
        assert_eq!(lookup("fit-residual").unwrap().term, names::REPROJECTION_RMS);
        assert_eq!(lookup("reprojection  rms").unwrap().term, names::REPROJECTION_RMS);
        assert_eq!(lookup("min-max scaled").unwrap().term, names::MIN_MAX);
        assert!(lookup("no such thing").is_none());
    }

    #[test]
    fn no_name_answers_for_two_entries() {
        let all = entries();
        let mut seen = std::collections::BTreeMap::new();
        for e in &all {
            let names: std::collections::BTreeSet<String> =
                std::iter::once(&e.term).chain(&e.aliases).map(|n| folded(n)).collect();
            for n in names {
                if let Some(other) = seen.insert(n.clone(), e.term) {
                    panic!("`{n}` names both `{other}` and `{}`", e.term);
                }
            }
        }
        assert!(all.len() >= 25, "{}", all.len());
    }

    #[test]
    fn an_entry_prints_its_name_unit_and_text() {
        let e = lookup("placement residual").unwrap().to_text();
        assert!(e.starts_with("placement residual  (head units (its OBJ's own"), "{e}");
        assert!(e.contains("also: residual_rigid, rigid residual, placement"), "{e}");
        assert!(e.contains("after a similarity transform alone"), "{e}");
    }
}
