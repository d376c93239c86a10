//! SAQP end to end on the demo corpus: generate 200 sentences, fit every clip, run the
//! paper's cross-validation for the three built-in synthesizers over five seeds; plus the GP
//! against scikit-learn (when Python has it) and the bad-input errors.

use lipmap::alignment::Phone;
use lipmap::demo::corpus::{CorpusOptions, DemoCorpus, generate_corpus};
use lipmap::fit::FitSettings;
use lipmap::math::Point3;
use lipmap::saqp::{self, Corpus, CvOptions, External, SaqpError, SynthKind};
use std::collections::HashMap;
use std::sync::OnceLock;

fn demo() -> &'static (DemoCorpus, Corpus) {
    static DEMO: OnceLock<(DemoCorpus, Corpus)> = OnceLock::new();
    DEMO.get_or_init(|| {
        let demo =
            generate_corpus(&CorpusOptions { sentences: 200, ..CorpusOptions::default() }).unwrap();
        let settings = FitSettings::default();
        let fits = demo.fit_sentences(&settings);
        let corpus = demo.to_saqp(&fits);
        (demo, corpus)
    })
}

/// Fitting 200 clips and five cross-validations (about 30 s in a test build): run with
/// `cargo test --test saqp -- --ignored --nocapture`. The core path, without the command's
/// bridging of discredited frames: keyframe r 0.87 / ratio 0.49, trajectory 0.89 / 0.47,
/// concatenative 0.49 / 0.60 over split seeds 1–5 of the default demo seed.
#[test]
#[ignore]
fn demo_corpus_cross_validation_meets_the_targets() {
    let (_, corpus) = demo();
    let mut sums: HashMap<SynthKind, [f64; 3]> = HashMap::new();
    let seeds = [1u64, 2, 3, 4, 5];
    for seed in seeds {
        let report = saqp::cross_validate(
            corpus,
            &HashMap::new(),
            &CvOptions { seed, ..CvOptions::default() },
        )
        .unwrap();
        if seed == 1 {
            for r in &report.regions {
                println!(
                    "region {:>9}: {:5} vertices, {} dims, {:.1} % kept",
                    r.region.name(),
                    r.vertices,
                    r.dims,
                    100.0 * r.variance_kept
                );
            }
            println!(
                "markers {}, pairs {}, unseen {}, λ {} order {}",
                report.markers, report.pairs, report.unseen, report.satf.lambda, report.satf.order
            );
        }
        for s in &report.synths {
            println!(
                "seed {seed} {:>10}: r {:.3} rmse {:.3} const {:.3} ω_m {} θ₁ {:?} θ₂ {:.3} σ² {:.4}",
                s.synth.name(),
                s.pearson_r,
                s.rmse,
                s.rmse_constant,
                s.omega_m,
                s.gp.hyper.length_scales,
                s.gp.hyper.signal_variance,
                s.gp.hyper.noise_variance
            );
            let e = sums.entry(s.synth).or_default();
            e[0] += s.pearson_r / seeds.len() as f64;
            e[1] += s.rmse / seeds.len() as f64;
            e[2] += s.rmse_constant / seeds.len() as f64;
        }
    }
    for (kind, [r, rmse, constant]) in &sums {
        println!(
            "mean {:>10}: r {r:.3}, rmse {rmse:.3} = {:.3} × constant {constant:.3}",
            kind.name(),
            rmse / constant
        );
    }
    let t = sums[&SynthKind::Trajectory];
    assert!(t[0] >= 0.6 && t[1] <= 0.85 * t[2], "trajectory {t:?}");
    let k = sums[&SynthKind::Keyframe];
    assert!(k[0] >= 0.6 && k[1] <= 0.85 * k[2], "keyframe {k:?}");
    let c = sums[&SynthKind::Concatenative];
    assert!(c[0] >= 0.4 && c[1] <= 0.95 * c[2], "concat {c:?}");
}

#[test]
#[ignore]
fn gp_is_at_least_as_good_as_scikit_learn() {
    let ok = std::process::Command::new("python3").args(["-c", "import sklearn"]).output();
    if !ok.map(|o| o.status.success()).unwrap_or(false) {
        eprintln!("skipping: python3 with scikit-learn is not available");
        return;
    }
    let (_, corpus) = demo();
    let report = saqp::cross_validate(corpus, &HashMap::new(), &CvOptions::default()).unwrap();
    for s in &report.synths {
        let gp = &s.gp;
        let y: Vec<f64> = gp.targets.iter().map(|t| t - gp.target_mean).collect();
        let script = format!(
            "import numpy as np\nfrom sklearn.gaussian_process import GaussianProcessRegressor as G\n\
             from sklearn.gaussian_process.kernels import ConstantKernel as C, RBF, WhiteKernel as W\n\
             x=np.array({:?}).reshape(-1,{}); y=np.array({:?})\n\
             k=C(1.0,(1e-8,1e8))*RBF([1.0]*x.shape[1],(1e-8,1e8))+W(0.1,(1e-10,1e4))\n\
             g=G(kernel=k,n_restarts_optimizer=5,random_state=0,normalize_y=False).fit(x,y)\n\
             print(g.log_marginal_likelihood_value_)",
            gp.inputs.concat(),
            gp.hyper.length_scales.len(),
            y
        );
        let out = std::process::Command::new("python3").args(["-c", &script]).output().unwrap();
        let sk: f64 = String::from_utf8_lossy(&out.stdout).trim().parse().unwrap();
        println!("{}: lipmap log ML {:.4}, scikit-learn {:.4}", s.synth.name(), -gp.nlml, sk);
        assert!(
            -gp.nlml >= sk - 1e-6 * sk.abs().max(1.0),
            "{} {} < {}",
            s.synth.name(),
            -gp.nlml,
            sk
        );
    }
}

fn small_corpus() -> Corpus {
    let demo =
        generate_corpus(&CorpusOptions { sentences: 14, ..CorpusOptions::default() }).unwrap();
    demo.truth_corpus()
}

#[test]
fn bad_input_gets_a_one_line_error_naming_what() {
    let corpus = small_corpus();
    let mut empty = corpus.clone();
    empty.sentences[3].frames.clear();
    let err = saqp::cross_validate(&empty, &HashMap::new(), &CvOptions::default()).unwrap_err();
    assert_eq!(err, SaqpError::NoFrames(corpus.sentences[3].name.clone()));
    assert!(!err.to_string().contains('\n'));

    let name = corpus.sentences[0].name.clone();
    let n = corpus.sentences[0].frames.len();
    let ext = HashMap::from([(
        name.clone(),
        External::whole_meshes(vec![vec![Point3::origin(); 5]; n - 1]),
    )]);
    let opts = CvOptions { synths: vec![SynthKind::External], ..CvOptions::default() };
    let err = saqp::cross_validate(&corpus, &ext, &opts).unwrap_err();
    assert!(
        matches!(err, SaqpError::FrameCount { ref sentence, .. } if *sentence == name),
        "{err}"
    );

    let opts = saqp::TrainOptions {
        cv: CvOptions {
            satf: Some(Default::default()),
            omega_m: Some(3.0),
            ..CvOptions::default()
        },
        synth: SynthKind::Keyframe,
    };
    let (predictor, _) = saqp::train(&corpus, &HashMap::new(), &opts).unwrap();
    let phones = |labels: &[&str]| -> Vec<Phone> {
        labels
            .iter()
            .enumerate()
            .map(|(i, l)| Phone {
                start: i as f64 * 0.1,
                end: (i + 1) as f64 * 0.1,
                label: l.to_string(),
            })
            .collect()
    };
    // The default phone inventory and viseme tables.
    let tables = (Default::default(), Default::default());
    let predict = |p: &saqp::Predictor, name: &str, labels: &[&str]| {
        p.predict(name, &phones(labels), &tables.0, &tables.1)
    };
    let err = predict(&predictor, "new", &["sil", "XX", "QQ", "sil"]).unwrap_err();
    assert_eq!(err, SaqpError::AllPhonesUnseen("new".into()));
    let q = predict(&predictor, "new", &["sil", "B", "IH", "N", "sil"]).unwrap();
    let (e, p) = (q.e, q.prediction);
    assert!(e.is_finite() && p.mean.is_finite() && p.std() > 0.0);
    assert!(q.unseen.is_empty(), "{:?}", q.unseen);
    // The same phones written in IPA are the same phones (the phone inventory's keys).
    let ipa = predict(&predictor, "new", &["", "b", "ɪ", "n", ""]).unwrap();
    assert!(ipa.unseen.is_empty(), "{:?}", ipa.unseen);
    assert_eq!(ipa.e, e);
    // A phone outside the inventory is named, not silently scored as if it were known.
    let mixed = predict(&predictor, "new", &["sil", "B", "œ", "N", "sil"]).unwrap();
    assert_eq!(mixed.unseen, vec!["œ".to_string()]);
    // A sentence far longer than any of the corpus's: E past the training range, named.
    let mut long = vec!["sil"];
    long.extend(["B", "IH", "N", "L", "UW"].repeat(30));
    long.push("sil");
    let far = predict(&predictor, "long", &long).unwrap();
    assert!(far.extrapolated.contains(&"E"), "{far:?}");
    assert!(far.prediction.mean.is_finite());
    let (lo, hi) = predictor.input_range(1);
    assert!(0.0 <= lo && lo <= hi && hi <= 1.0, "coverage range {lo}–{hi}");
    // The predictor survives serde.
    let json = serde_json::to_string(&predictor).unwrap();
    let back: saqp::Predictor = serde_json::from_str(&json).unwrap();
    let q2 = predict(&back, "new", &["sil", "B", "IH", "N", "sil"]).unwrap();
    let (e2, p2) = (q2.e, q2.prediction);
    assert!((e - e2).abs() < 1e-9 * e.abs().max(1.0) && (p.mean - p2.mean).abs() < 1e-9);
}
