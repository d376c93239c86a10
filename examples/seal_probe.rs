// scratch probe (not committed)
use lipmap::fit::{FitSettings, fit_clip};
use lipmap::landmarks::closure::{Closure, inner_lip_gap};
use lipmap::measure::lip_reach::InnerLipGap;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::PathBuf::from(&args[1]);
    let opened = lipmap::workflow::session::open_for_read_at(&path).unwrap();
    let session = &opened.session;
    let res = lipmap::workflow::resources::Resources::load(session).unwrap();
    let mut settings: FitSettings = session.fit_settings.clone();
    for kv in &args[2..] {
        let (k, v) = kv.split_once('=').unwrap();
        match k {
            "lambda" => settings.lambda = v.parse().unwrap(),
            "lexp" => settings.lambda_expression = v.parse().unwrap(),
            "clip" => settings.clip = v == "1",
            "set" => settings.set = serde_json::from_str(&format!("\"{v}\"")).unwrap(),
            "closure" => settings.closure = if v == "off" { Closure::Off } else { Closure::Seal },
            "w" => {
                // w=61:5,62:5
                let mut w = vec![1.0; 68];
                for p in v.split(',') {
                    let (i, x) = p.split_once(':').unwrap();
                    w[i.parse::<usize>().unwrap()] = x.parse().unwrap();
                }
                settings.landmark_weights = w;
            }
            "noise" => {
                settings.solver = lipmap::fit::Solver::Joint {
                    pose_refinement_steps: 1,
                    estimate_noise: v == "1",
                }
            }
            _ => panic!("{k}"),
        }
    }
    let nclips = session.clips.len();
    for clip in 0..nclips {
    let h = lipmap::workflow::session::image_height(session, clip).unwrap();
    let tracked = session.effective_track(clip).unwrap();
    let mut track = lipmap::landmarks::closure::with_sealed_lips(tracked.clone(), settings.closure);
    if std::env::var("NOCONTACT").is_ok() { for f in &mut track.frames { f.lip_contact_px = None; } }
    eprintln!("contact frames {}", track.frames.iter().filter(|f| f.lip_contact_px.is_some()).count());
    let fits = fit_clip(&res.model, &res.map, &track.frames, h, &settings, None);
    let gap = InnerLipGap::of(&res.model, &res.map).unwrap();
    let (vu, vl) = (res.map.vertex(62).unwrap(), res.map.vertex(66).unwrap());
    let gaps: Vec<f64> = fits.iter().map(|f| if std::env::var("G3D").is_ok() { gap.length(&f.identity, &f.expression) } else { let sh = res.model.shape_at(&f.identity, &f.expression); ((sh[3*vu]-sh[3*vl]).powi(2) + (sh[3*vu+1]-sh[3*vl+1]).powi(2)).sqrt() }).collect();
    let widest = gaps.iter().cloned().fold(0.0, f64::max);
    let vg: Vec<f64> = track.frames.iter().map(|f| inner_lip_gap(f).unwrap_or(f64::NAN)).collect();
    let vmax = vg.iter().cloned().fold(0.0, f64::max);
    let frac: f64 = std::env::var("FRAC").ok().map(|v| v.parse().unwrap()).unwrap_or(0.05);
    let sealed: Vec<usize> = (0..fits.len()).filter(|&i| vg[i] <= frac * vmax).collect();
    let mut s: Vec<f64> = sealed.iter().map(|&i| gaps[i]).collect();
    s.sort_by(f64::total_cmp);
    let med = if s.is_empty() { f64::NAN } else { s[s.len() / 2] };
    let rms: Vec<f64> = fits.iter().map(|f| f.reproj_rms_px).collect();
    let mut r = rms.clone();
    r.sort_by(f64::total_cmp);
    {
        let (mut sse, mut n, mut pp) = (0.0, 0.0, 0.0);
        for f in &fits {
            for r in f.residuals.iter().flatten() { sse += r[0]*r[0] + r[1]*r[1]; n += 2.0; }
            pp += 6.0 + f.expression.iter().filter(|b| **b > 0.0).count() as f64 + if settings.clip { 0.0 } else { f.identity.len() as f64 };
        }
        if settings.clip { pp += fits[0].identity.len() as f64; }
        let v = sse / (n - pp);
        eprintln!("pooled sigma2 {v:.3} n {n} p {pp} -> lambda {:.3}", settings.lambda * v / 9.0);
    }
    let reach = gap.smallest(&fits[0].identity).map(|r| r.0);
    println!(
        "{} sealed {} median {:.2} max {:.2} widest {:.2} share {:.1}% rms {:.2} reach(id0) {:?}",
        session.clips[clip].name, s.len(),
        med,
        s.last().copied().unwrap_or(f64::NAN),
        widest,
        100.0 * med / widest,
        r[r.len() / 2],
        reach
    );
    if std::env::var("PER").is_ok() {
        for (i, f) in fits.iter().enumerate() {
            let r62 = f.residuals[62].map(|r| r[1]);
            let r66 = f.residuals[66].map(|r| r[1]);
            let r51 = f.residuals[51].map(|r| r[1]);
            let r57 = f.residuals[57].map(|r| r[1]);
            let top = f.expression.iter().enumerate().filter(|(_, b)| **b > 0.05).map(|(j, b)| format!("{j}:{b:.2}")).collect::<Vec<_>>().join(" ");
            println!(
                "{:3} vec {:?} sealed {} gap3d {:5.2} tgap {:.2} res62y {:?} res66y {:?} res51y {:?} res57y {:?} pitch {:.0} β {}",
                f.frame,
                { let sh = res.model.shape_at(&f.identity, &f.expression); let (u,l)=(res.map.vertex(62).unwrap(), res.map.vertex(66).unwrap()); [(sh[3*u]-sh[3*l]).round(), ((sh[3*u+1]-sh[3*l+1])*10.0).round()/10.0, ((sh[3*u+2]-sh[3*l+2])*10.0).round()/10.0] },
                sealed.contains(&i) as u8,
                gaps[i],
                inner_lip_gap(&tracked.frames[i]).unwrap(),
                r62.map(|v| (v * 100.0).round() / 100.0),
                r66.map(|v| (v * 100.0).round() / 100.0),
                r51.map(|v| (v * 100.0).round() / 100.0),
                r57.map(|v| (v * 100.0).round() / 100.0),
                f.pitch,
                top
            );
        }
    }
}
}
