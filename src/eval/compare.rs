//! Comparison of two or more fit configurations (landmark sets F1–F5, models, λ, heads) in
//! the shape of the thesis's tables: rows sentences or speakers, W/H(/P) RMSE columns per
//! configuration, a mean row, and p-values of paired t-tests against a baseline.

use super::report::{Cell, Table};
use super::rmse::sentence_rmse;
use super::stats::{TTest, paired_t_test};
use super::{PerMeasure, Utterance, mean_of};
use crate::measure::Measure;
use serde::{Deserialize, Serialize};

/// One configuration's evaluated sentences (its head trajectories; the video side is the
/// same speaker's measures in every configuration).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Configuration {
    /// Column group name, e.g. `F4` or `head B`.
    pub name: String,
    pub utterances: Vec<Utterance>,
}

/// What a table row is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum RowKey {
    /// One row per sentence (matched across configurations by name).
    #[default]
    Sentence,
    /// One row per speaker: the mean of that speaker's per-sentence RMSEs.
    Speaker,
}

/// A configuration comparison: `values[row][config]` are per-row RMSEs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    pub row_key: RowKey,
    pub configs: Vec<String>,
    /// Index of the baseline configuration in `configs`.
    pub baseline: usize,
    /// Measures present in any configuration (W, H, and P when some head has it).
    pub measures: Vec<Measure>,
    pub row_labels: Vec<String>,
    pub values: Vec<Vec<PerMeasure>>,
    /// Per configuration: mean over rows.
    pub means: Vec<PerMeasure>,
    /// Per configuration and measure: paired t-test (config − baseline over rows where
    /// both have a value); `None` for the baseline itself and when the test cannot run.
    pub tests: Vec<[Option<TTest>; 3]>,
}

/// Why a comparison could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompareError {
    #[error("no configuration to compare")]
    Empty,
    #[error("baseline {baseline} is out of range for {n} configurations")]
    BadBaseline { baseline: usize, n: usize },
}

fn row_label(u: &Utterance, key: RowKey) -> String {
    match key {
        RowKey::Sentence => u.name.clone(),
        RowKey::Speaker => u.speaker.clone().unwrap_or_else(|| "?".into()),
    }
}

/// Per-row RMSEs of one configuration: for sentences the sentence RMSE (a repeated name
/// keeps the first), for speakers the mean of their sentences' RMSEs.
fn rows_of(config: &Configuration, key: RowKey) -> Vec<(String, PerMeasure)> {
    let mut groups: Vec<(String, Vec<PerMeasure>)> = Vec::new();
    for u in &config.utterances {
        let label = row_label(u, key);
        let v = sentence_rmse(u);
        match groups.iter_mut().find(|(l, _)| *l == label) {
            Some((_, vs)) if key == RowKey::Speaker => vs.push(v),
            Some(_) => {}
            None => groups.push((label, vec![v])),
        }
    }
    groups
        .into_iter()
        .map(|(l, vs)| (l, PerMeasure::from_fn(|m| mean_of(vs.iter().map(|v| v.get(m))))))
        .collect()
}

/// Compares configurations row by row against `configs[baseline]`.
///
/// Rows are the union of all configurations' rows in order of first appearance (baseline
/// first); a configuration lacking a row has `None` there. Each non-baseline configuration
/// gets, per measure, a paired two-sided t-test of its row RMSEs against the baseline's over
/// the rows where both have a value (see [`paired_t_test`]).
///
/// # Errors
/// `Empty` without configurations, `BadBaseline` for an out-of-range baseline.
pub fn compare_configurations(
    configs: &[Configuration],
    baseline: usize,
    row_key: RowKey,
) -> Result<Comparison, CompareError> {
    if configs.is_empty() {
        return Err(CompareError::Empty);
    }
    if baseline >= configs.len() {
        return Err(CompareError::BadBaseline { baseline, n: configs.len() });
    }
    let per_config: Vec<Vec<(String, PerMeasure)>> =
        configs.iter().map(|c| rows_of(c, row_key)).collect();
    let mut row_labels: Vec<String> = Vec::new();
    let order = std::iter::once(baseline).chain((0..configs.len()).filter(|&c| c != baseline));
    for c in order {
        for (l, _) in &per_config[c] {
            if !row_labels.contains(l) {
                row_labels.push(l.clone());
            }
        }
    }
    let values: Vec<Vec<PerMeasure>> = row_labels
        .iter()
        .map(|l| {
            per_config
                .iter()
                .map(|rows| rows.iter().find(|(r, _)| r == l).map(|(_, v)| *v).unwrap_or_default())
                .collect()
        })
        .collect();
    let n_configs = configs.len();
    let means: Vec<PerMeasure> = (0..n_configs)
        .map(|c| PerMeasure::from_fn(|m| mean_of(values.iter().map(|r| r[c].get(m)))))
        .collect();
    let tests = (0..n_configs)
        .map(|c| {
            Measure::ALL.map(|m| {
                if c == baseline {
                    return None;
                }
                let (a, b): (Vec<f64>, Vec<f64>) =
                    values.iter().filter_map(|r| Some((r[c].get(m)?, r[baseline].get(m)?))).unzip();
                paired_t_test(&a, &b)
            })
        })
        .collect();
    let has_p = values.iter().flatten().any(|v| v.p.is_some());
    let measures = Measure::ALL.into_iter().filter(|m| *m != Measure::P || has_p).collect();
    Ok(Comparison {
        row_key,
        configs: configs.iter().map(|c| c.name.clone()).collect(),
        baseline,
        measures,
        row_labels,
        values,
        means,
        tests,
    })
}

impl Comparison {
    /// The thesis-shaped table: a label column, then `config W`, `config H` (, `config P`)
    /// per configuration; one row per sentence or speaker, a `mean` row and a
    /// `p vs <baseline>` row (empty under the baseline's columns and where no test ran).
    pub fn to_table(&self) -> Table {
        let first = match self.row_key {
            RowKey::Sentence => "sentence",
            RowKey::Speaker => "speaker",
        };
        let mut headers = vec![first.to_string()];
        for c in &self.configs {
            headers.extend(self.measures.iter().map(|m| format!("{c} {m}")));
        }
        let mut t = Table::new("RMSE by configuration", headers).keyed("configurations");
        let cells = |vals: &mut dyn Iterator<Item = Option<f64>>| -> Vec<Cell> {
            vals.map(Cell::num).collect()
        };
        for (label, row) in self.row_labels.iter().zip(&self.values) {
            let mut r = vec![Cell::text(label)];
            r.extend(cells(&mut row.iter().flat_map(|v| self.measures.iter().map(|m| v.get(*m)))));
            t.push_row(r);
        }
        let mut mean = vec![Cell::text("mean")];
        mean.extend(cells(
            &mut self.means.iter().flat_map(|v| self.measures.iter().map(|m| v.get(*m))),
        ));
        t.push_row(mean);
        let mut p = vec![Cell::text(format!("p vs {}", self.configs[self.baseline]))];
        for tests in &self.tests {
            for m in &self.measures {
                p.push(Cell::num(tests[*m as usize].map(|t| t.p)));
            }
        }
        t.push_row(p);
        t.notes.push(format!(
            "p: two-sided paired t-test over {}s against {}",
            first, self.configs[self.baseline]
        ));
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::Trajectory;

    fn utt(name: &str, speaker: &str, offset: f64) -> Utterance {
        let video = Trajectory { w: vec![Some(1.0); 4], h: vec![Some(0.5); 4], p: vec![] };
        let head = Trajectory {
            w: vec![Some(1.0 + offset); 4],
            h: vec![Some(0.5 + 2.0 * offset); 4],
            p: vec![],
        };
        Utterance {
            name: name.into(),
            speaker: Some(speaker.into()),
            fps: 25.0,
            video,
            head,
            ..Default::default()
        }
    }

    fn configs() -> Vec<Configuration> {
        let base = [0.10, 0.20, 0.15, 0.30];
        let other = [0.12, 0.25, 0.16, 0.36];
        let mk = |name: &str, offs: &[f64]| Configuration {
            name: name.into(),
            utterances: offs
                .iter()
                .enumerate()
                .map(|(k, o)| utt(&format!("s{k}"), if k < 2 { "A" } else { "B" }, *o))
                .collect(),
        };
        vec![mk("F4", &base), mk("F1", &other)]
    }

    #[test]
    fn rows_means_and_paired_p_against_scipy() {
        let c = compare_configurations(&configs(), 0, RowKey::Sentence).unwrap();
        assert_eq!(c.row_labels, ["s0", "s1", "s2", "s3"]);
        assert_eq!(c.measures, [Measure::W, Measure::H]);
        assert!((c.values[1][1].w.unwrap() - 0.25).abs() < 1e-12);
        assert!((c.means[0].w.unwrap() - 0.1875).abs() < 1e-12);
        assert!(c.tests[0][0].is_none());
        // scipy.stats.ttest_rel([.12,.25,.16,.36], [.10,.20,.15,.30]).pvalue
        let p = c.tests[1][0].unwrap().p;
        assert!((p - 0.060_481_502_572_069_704).abs() < 1e-9, "p = {p}");
        let t = c.to_table();
        assert_eq!(t.headers, ["sentence", "F4 W", "F4 H", "F1 W", "F1 H"]);
        assert_eq!(t.rows.len(), 6);
        assert_eq!(t.rows[5][0], Cell::text("p vs F4"));
        assert_eq!(t.rows[5][1], Cell::Empty);
    }

    #[test]
    fn speaker_rows_average_their_sentences() {
        let c = compare_configurations(&configs(), 1, RowKey::Speaker).unwrap();
        assert_eq!(c.row_labels, ["A", "B"]);
        assert!((c.values[0][0].w.unwrap() - 0.15).abs() < 1e-12);
        assert!((c.values[1][1].h.unwrap() - 0.52).abs() < 1e-12);
    }

    #[test]
    fn missing_rows_and_bad_input() {
        let mut cs = configs();
        cs[1].utterances.pop();
        cs[1].utterances.push(utt("extra", "C", 0.5));
        let c = compare_configurations(&cs, 0, RowKey::Sentence).unwrap();
        assert_eq!(c.row_labels.len(), 5);
        assert_eq!(c.values[3][1].w, None);
        assert_eq!(c.values[4][0].w, None);
        // The t-test pairs only the 3 shared rows.
        assert_eq!(c.tests[1][0].unwrap().n, 3);
        assert_eq!(compare_configurations(&[], 0, RowKey::Sentence), Err(CompareError::Empty));
        assert!(matches!(
            compare_configurations(&cs, 2, RowKey::Sentence),
            Err(CompareError::BadBaseline { .. })
        ));
    }
}
