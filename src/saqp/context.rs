//! Per-phone means and variances of the representative samples with the paper's context
//! back-off (§5.1): triphone (P_{i−1}, P_i, P_{i+1}), else diphone (P_i, P_{i+1}), else the
//! monophone P_i. Two further levels catch phones the corpus never saw: the phone's viseme
//! class (Neti et al.'s table), then all samples.
//!
//! A context seen a handful of times has a variance estimate of a few degrees of freedom, and
//! a triphone seen once has none: each level's variance is shrunk toward its parent's,
//! `v = ((n−1)·v_n + κ·v_parent) / ((n−1) + κ)` (a conjugate-prior posterior mean with κ
//! pseudo-observations), so one sample gives the parent's variance and many give their own.

use super::prepared::PhoneSet;
use crate::math::DVector;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::hash::Hash;

/// How the statistics are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContextOptions {
    /// Samples a triphone or diphone context needs before it is used.
    pub min_count: usize,
    /// κ, pseudo-observations of the parent variance.
    pub shrinkage: f64,
    /// Variances are kept above this fraction of the global variance (per dimension).
    pub variance_floor: f64,
}

impl Default for ContextOptions {
    fn default() -> Self {
        Self { min_count: 1, shrinkage: 3.0, variance_floor: 1e-3 }
    }
}

/// The back-off level a phone's statistics came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ContextLevel {
    Triphone,
    Diphone,
    Monophone,
    Viseme,
    Global,
}

/// Mean and (diagonal) variance of one phone in its context.
#[derive(Clone, Debug, PartialEq)]
pub struct PhoneStats {
    pub mean: DVector,
    pub variance: DVector,
    pub level: ContextLevel,
    pub count: usize,
}

/// Running sums of samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Acc {
    n: usize,
    sum: Vec<f64>,
    sumsq: Vec<f64>,
}

impl Acc {
    fn new(k: usize) -> Self {
        Self { n: 0, sum: vec![0.0; k], sumsq: vec![0.0; k] }
    }

    fn add(&mut self, x: &DVector) {
        self.n += 1;
        for (j, v) in x.iter().enumerate() {
            self.sum[j] += v;
            self.sumsq[j] += v * v;
        }
    }

    fn mean(&self) -> DVector {
        DVector::from_iterator(self.sum.len(), self.sum.iter().map(|s| s / self.n as f64))
    }

    /// Unbiased variance shrunk toward `parent` with κ pseudo-observations.
    fn variance(&self, parent: &DVector, kappa: f64, floor: &DVector) -> DVector {
        let n = self.n as f64;
        let dof = n - 1.0;
        DVector::from_iterator(
            self.sum.len(),
            (0..self.sum.len()).map(|j| {
                let own = if dof > 0.0 {
                    ((self.sumsq[j] - self.sum[j] * self.sum[j] / n) / dof).max(0.0)
                } else {
                    0.0
                };
                let v = if dof + kappa > 0.0 {
                    (dof * own + kappa * parent[j]) / (dof + kappa)
                } else {
                    parent[j]
                };
                v.max(floor[j])
            }),
        )
    }
}

mod pairs {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::collections::HashMap;
    use std::hash::Hash;

    pub fn serialize<K: Serialize + Ord, V: Serialize, S: Serializer>(
        m: &HashMap<K, V>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut v: Vec<(&K, &V)> = m.iter().collect();
        v.sort_by(|a, b| a.0.cmp(b.0));
        v.serialize(s)
    }

    pub fn deserialize<'de, K, V, D>(d: D) -> Result<HashMap<K, V>, D::Error>
    where
        K: Deserialize<'de> + Eq + Hash,
        V: Deserialize<'de>,
        D: Deserializer<'de>,
    {
        Ok(Vec::<(K, V)>::deserialize(d)?.into_iter().collect())
    }
}

/// Context statistics of a training corpus, over phone ids of a [`PhoneSet`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContextStats {
    dims: usize,
    options: ContextOptions,
    #[serde(with = "pairs")]
    tri: HashMap<[u16; 3], Acc>,
    #[serde(with = "pairs")]
    di: HashMap<[u16; 2], Acc>,
    #[serde(with = "pairs")]
    mono: HashMap<u16, Acc>,
    #[serde(with = "pairs")]
    vis: HashMap<u16, Acc>,
    global: Acc,
}

fn add<K: Eq + Hash>(map: &mut HashMap<K, Acc>, key: K, k: usize, x: &DVector) {
    map.entry(key).or_insert_with(|| Acc::new(k)).add(x);
}

/// The most coefficients per sample a statistics table may hold (the paper's K is 27).
pub const MAX_DIMS: usize = 4096;
/// The largest mean a statistics table may hold: coefficients are in model units.
pub const MAX_MEAN: f64 = 1e6;

impl ContextStats {
    /// Checks statistics read from a file: every accumulator as long as `dims`, every value
    /// finite. The message names the table at fault.
    ///
    /// # Errors
    /// The first inconsistency found.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_DIMS).contains(&self.dims) {
            return Err(format!("stats.dims {} is not between 1 and {MAX_DIMS}", self.dims));
        }
        let o = &self.options;
        if !((0.0..=1e6).contains(&o.shrinkage)
            && o.variance_floor > 0.0
            && o.variance_floor <= 1.0)
        {
            return Err(
                "stats.options: shrinkage must be within 0–1e6 and variance_floor within 0–1 (above 0)"
                    .into(),
            );
        }
        let check = |table: &str, acc: &Acc| {
            if acc.sum.len() != self.dims || acc.sumsq.len() != self.dims {
                return Err(format!(
                    "stats.{table}: {} and {} values where dims is {}",
                    acc.sum.len(),
                    acc.sumsq.len(),
                    self.dims
                ));
            }
            if acc.sum.iter().chain(&acc.sumsq).any(|v| !v.is_finite()) {
                return Err(format!("stats.{table}: a value is not finite"));
            }
            // Sums of region coefficients in model units: a mean past ±MAX_MEAN, a negative
            // sum of squares or one below the square of the sum are not statistics of motion.
            let n = acc.n as f64;
            let bad = acc.n == 0
                || acc.sum.iter().zip(&acc.sumsq).any(|(s, q)| {
                    (s / n).abs() > MAX_MEAN || *q < 0.0 || s * s / n > q * (1.0 + 1e-9) + 1e-12
                });
            if bad {
                return Err(format!(
                    "stats.{table}: a count of 0, a mean beyond ±{MAX_MEAN:e} or a negative variance"
                ));
            }
            Ok(())
        };
        check("global", &self.global)?;
        // Every variance is floored at a fraction of the global one, which E divides by.
        let g = &self.global;
        let n = g.n as f64;
        if g.sum.iter().zip(&g.sumsq).any(|(s, q)| q / n - (s / n).powi(2) <= 0.0) {
            return Err("stats.global: a dimension without variance".into());
        }
        self.tri.values().try_for_each(|a| check("tri", a))?;
        self.di.values().try_for_each(|a| check("di", a))?;
        self.mono.values().try_for_each(|a| check("mono", a))?;
        self.vis.values().try_for_each(|a| check("vis", a))
    }

    /// Checks that every phone id the tables name is below `phones` (the phone set's size).
    ///
    /// # Errors
    /// The table naming an unknown phone.
    pub fn validate_ids(&self, phones: usize) -> Result<(), String> {
        let known = |id: &u16| usize::from(*id) < phones;
        if !self.tri.keys().flatten().all(known) {
            return Err("stats.tri: a context names a phone the model's phone set lacks".into());
        }
        if !self.di.keys().flatten().all(known) {
            return Err("stats.di: a context names a phone the model's phone set lacks".into());
        }
        if !self.mono.keys().all(known) {
            return Err("stats.mono: a phone the model's phone set lacks".into());
        }
        Ok(())
    }

    /// Accumulates the samples of sentences given as (phone ids, one sample per phone).
    pub fn build<'a>(
        dims: usize,
        phones: &PhoneSet,
        sentences: impl IntoIterator<Item = (&'a [u16], &'a [DVector])>,
        options: ContextOptions,
    ) -> Self {
        let mut s = Self {
            dims,
            options,
            tri: HashMap::new(),
            di: HashMap::new(),
            mono: HashMap::new(),
            vis: HashMap::new(),
            global: Acc::new(dims),
        };
        for (ids, samples) in sentences {
            for (i, x) in samples.iter().enumerate() {
                let p = ids[i];
                if i > 0 && i + 1 < ids.len() {
                    add(&mut s.tri, [ids[i - 1], p, ids[i + 1]], dims, x);
                }
                if i + 1 < ids.len() {
                    add(&mut s.di, [p, ids[i + 1]], dims, x);
                }
                add(&mut s.mono, p, dims, x);
                if let Some(v) = phones.viseme(p) {
                    add(&mut s.vis, v, dims, x);
                }
                s.global.add(x);
            }
        }
        s
    }

    /// Number of samples accumulated.
    pub fn len(&self) -> usize {
        self.global.n
    }

    pub fn is_empty(&self) -> bool {
        self.global.n == 0
    }

    fn floor(&self) -> DVector {
        let zero = DVector::zeros(self.dims);
        let v = self.global.variance(&zero, 0.0, &zero);
        let mean_v = v.mean().max(f64::MIN_POSITIVE);
        v.map(|x| self.options.variance_floor * x.max(mean_v * 1e-3))
    }

    fn stats(&self, acc: &Acc, parent: &DVector, level: ContextLevel) -> PhoneStats {
        let floor = self.floor();
        let variance = acc.variance(parent, self.options.shrinkage, &floor);
        PhoneStats { mean: acc.mean(), variance, level, count: acc.n }
    }

    /// The statistics of phone `id` without context: monophone, else viseme class, else
    /// global. `None` when the corpus is empty.
    pub fn monophone(&self, phones: &PhoneSet, id: u16) -> Option<PhoneStats> {
        if self.global.n == 0 {
            return None;
        }
        let zero = DVector::zeros(self.dims);
        let global = self.stats(&self.global, &zero, ContextLevel::Global);
        let global =
            PhoneStats { variance: self.global.variance(&zero, 0.0, &self.floor()), ..global };
        let vis = phones.viseme(id).and_then(|v| self.vis.get(&v));
        let parent = match vis {
            Some(a) => self.stats(a, &global.variance, ContextLevel::Viseme),
            None => global,
        };
        Some(match self.mono.get(&id) {
            Some(a) => self.stats(a, &parent.variance, ContextLevel::Monophone),
            None => parent,
        })
    }

    /// The statistics of phone `i` of the sequence `ids` with the back-off triphone →
    /// diphone → monophone → viseme class → global. `None` when the corpus is empty.
    pub fn lookup(&self, phones: &PhoneSet, ids: &[u16], i: usize) -> Option<PhoneStats> {
        let mono = self.monophone(phones, ids[i])?;
        if mono.level != ContextLevel::Monophone {
            return Some(mono);
        }
        let min = self.options.min_count.max(1);
        let tri = (i > 0 && i + 1 < ids.len())
            .then(|| self.tri.get(&[ids[i - 1], ids[i], ids[i + 1]]))
            .flatten()
            .filter(|a| a.n >= min);
        if let Some(a) = tri {
            return Some(self.stats(a, &mono.variance, ContextLevel::Triphone));
        }
        let di = (i + 1 < ids.len()).then(|| self.di.get(&[ids[i], ids[i + 1]])).flatten();
        if let Some(a) = di.filter(|a| a.n >= min) {
            return Some(self.stats(a, &mono.variance, ContextLevel::Diphone));
        }
        Some(mono)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64) -> DVector {
        DVector::from_vec(vec![x])
    }

    #[test]
    fn back_off_reaches_each_level() {
        let (mut phones, table) = (PhoneSet::default(), crate::eval::VisemeTable::default());
        let [a, b, c, p, m] =
            ["AA", "B", "IY", "P", "M"].map(|l| phones.intern(l, &Default::default(), &table));
        let ids = vec![a, b, c];
        let samples = [v(1.0), v(2.0), v(3.0)];
        let ids2 = [c, b, a];
        let samples2 = [v(3.5), v(4.0), v(1.5)];
        let stats = ContextStats::build(
            1,
            &phones,
            [(&ids[..], &samples[..]), (&ids2[..], &samples2[..])],
            ContextOptions::default(),
        );
        let s = stats.lookup(&phones, &ids, 1).unwrap();
        assert_eq!((s.level, s.mean[0]), (ContextLevel::Triphone, 2.0));
        let s = stats.lookup(&phones, &[a, b, a], 0).unwrap();
        assert_eq!((s.level, s.mean[0]), (ContextLevel::Diphone, 1.0));
        let s = stats.lookup(&phones, &[m, b, m], 1).unwrap();
        assert_eq!((s.level, s.mean[0]), (ContextLevel::Monophone, 3.0));
        // P was never seen, but B shares its viseme class.
        let s = stats.lookup(&phones, &[a, p, a], 1).unwrap();
        assert_eq!((s.level, s.mean[0]), (ContextLevel::Viseme, 3.0));
        let x = phones.intern("ZZZ", &Default::default(), &table);
        let s = stats.lookup(&phones, &[x], 0).unwrap();
        assert_eq!(s.level, ContextLevel::Global);
        assert!((s.mean[0] - 15.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn one_sample_takes_the_parent_variance() {
        let mut phones = PhoneSet::default();
        let a = phones.intern("AA", &Default::default(), &Default::default());
        let ids = vec![a, a, a, a];
        let samples = [v(0.0), v(2.0), v(4.0), v(6.0)];
        let stats =
            ContextStats::build(1, &phones, [(&ids[..], &samples[..])], ContextOptions::default());
        let mono = stats.monophone(&phones, a).unwrap();
        assert!((mono.mean[0] - 3.0).abs() < 1e-12);
        // Triphone AA-AA-AA seen twice (2, 4): variance 2, shrunk toward the monophone's.
        let tri = stats.lookup(&phones, &ids, 1).unwrap();
        assert_eq!(tri.level, ContextLevel::Triphone);
        let want = (1.0 * 2.0 + 3.0 * mono.variance[0]) / 4.0;
        assert!((tri.variance[0] - want).abs() < 1e-12);
    }
}
