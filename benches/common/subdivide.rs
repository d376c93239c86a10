//! A denser copy of an OBJ head for the transfer benches: every face outside the helper and
//! joint groups split once at its edge midpoints and centre (an n-gon into n quads, the
//! first step of Catmull–Clark without the smoothing, so the surface is unchanged). The
//! original vertices keep their indices, so the head's landmark map still holds; the new
//! vertices follow them. Groups, and so the skin mask, are kept.

use std::collections::HashMap;

/// The OBJ text of `text` with its skin faces subdivided once, and the new vertex count.
pub fn subdivide_skin(text: &str) -> (String, usize) {
    let is_aux = |g: &str| g.starts_with("helper-") || g.starts_with("joint-");
    let mut points: Vec<[f64; 3]> = Vec::new();
    for line in text.lines() {
        let mut t = line.split_whitespace();
        if t.next() == Some("v") {
            let c: Vec<f64> = t.take(3).map(|x| x.parse().expect("vertex coordinate")).collect();
            points.push([c[0], c[1], c[2]]);
        }
    }
    let original = points.len();
    let mut midpoint: HashMap<(usize, usize), usize> = HashMap::new();
    let mut body = String::new();
    let mut in_aux = false;
    for line in text.lines() {
        let mut t = line.split_whitespace();
        match t.next() {
            Some("v" | "vt" | "vn") => {}
            Some("g" | "o") => {
                in_aux = t.next().is_some_and(is_aux);
                body.push_str(line);
                body.push('\n');
            }
            Some("f") => {
                let corners: Vec<usize> = t
                    .map(|tok| tok.split('/').next().unwrap().parse::<usize>().unwrap() - 1)
                    .collect();
                if in_aux {
                    let ids: Vec<String> = corners.iter().map(|c| (c + 1).to_string()).collect();
                    body.push_str(&format!("f {}\n", ids.join(" ")));
                    continue;
                }
                let n = corners.len();
                let mut centre = [0.0; 3];
                for &c in &corners {
                    for k in 0..3 {
                        centre[k] += points[c][k] / n as f64;
                    }
                }
                points.push(centre);
                let centre = points.len() - 1;
                let mids: Vec<usize> = (0..n)
                    .map(|i| {
                        let (a, b) = (corners[i], corners[(i + 1) % n]);
                        *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                            let m = [0, 1, 2].map(|k| 0.5 * (points[a][k] + points[b][k]));
                            points.push(m);
                            points.len() - 1
                        })
                    })
                    .collect();
                for i in 0..n {
                    let quad = [corners[i], mids[i], centre, mids[(i + n - 1) % n]];
                    let [a, b, c, d] = quad.map(|v| v + 1);
                    body.push_str(&format!("f {a} {b} {c} {d}\n"));
                }
            }
            _ => {
                body.push_str(line);
                body.push('\n');
            }
        }
    }
    let mut out = String::with_capacity(body.len() + 40 * points.len());
    for p in &points {
        out.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
    }
    out.push_str(&body);
    debug_assert!(points.len() > original);
    (out, points.len())
}
