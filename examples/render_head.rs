//! Renders a head OBJ from the front and the side to PNGs, to look at a transferred frame
//! or a landmark map: `cargo run --example render_head -- HEAD.obj OUT_PREFIX [MAP.toml]`
//! writes `OUT_PREFIX_front.png` and `OUT_PREFIX_side.png`, framed on the mapped landmarks
//! (on the whole head without a map), the map's points drawn as dots (red odd iBUG ids, blue
//! even). Helper and joint geometry (MakeHuman's `helper-*`, `joint-*` groups) is not drawn.

use lipmap::io::{landmark_map_toml::read_landmark_map, obj};
use lipmap::math::Point3;
use lipmap::render::{Camera, RenderOptions, View, render_mesh};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [head, prefix, rest @ ..] = args.as_slice() else {
        anyhow::bail!("usage: render_head HEAD.obj OUT_PREFIX [MAP.toml]");
    };
    let head = PathBuf::from(head);
    let mesh = obj::read_obj(&head)?;
    let skin = obj::labelable_vertices(&head)?;
    let is_skin = |v: u32| skin.as_ref().is_none_or(|s| s[v as usize]);
    let triangles: Vec<[u32; 3]> =
        mesh.triangles().into_iter().filter(|t| t.iter().all(|&v| is_skin(v))).collect();
    let map = rest.first().map(|m| read_landmark_map(&PathBuf::from(m))).transpose()?;
    let framed: Vec<Point3> = match &map {
        Some(m) => m.pairs().filter_map(|(_, v)| mesh.vertices.get(v).copied()).collect(),
        None => mesh.vertices.clone(),
    };
    let size = 900;
    for (view, name) in [(View::Front, "front"), (View::Side, "side")] {
        let camera = Camera::fit_to_points(view, 0.0, &framed, 0.25, size, size)
            .ok_or_else(|| anyhow::anyhow!("{}: nothing to frame", head.display()))?;
        let mut img = render_mesh(
            &mesh.vertices,
            &triangles,
            &[[200, 190, 180]],
            &camera,
            &RenderOptions::default(),
        )?;
        for (l, v) in map.iter().flat_map(|m| m.pairs()) {
            let p = camera.project(&mesh.vertices[v]);
            let colour = if l % 2 == 0 { [220, 0, 0] } else { [0, 0, 220] };
            for dx in -2i64..=2 {
                for dy in -2i64..=2 {
                    let (x, y) = (p.x.round() as i64 + dx, p.y.round() as i64 + dy);
                    if (0..size as i64).contains(&x) && (0..size as i64).contains(&y) {
                        img.put_pixel(x as u32, y as u32, image::Rgb(colour));
                    }
                }
            }
        }
        img.save(format!("{prefix}_{name}.png"))?;
    }
    Ok(())
}
