// scratch: mouth crops of carphone enlarged with dlib points (not committed)
use image::{Rgb, RgbImage};
use lipmap::plot::font::draw_text;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scale: u32 = std::env::var("SCALE").ok().map(|s| s.parse().unwrap()).unwrap_or(12);
    let pad: i64 = std::env::var("PAD").ok().map(|s| s.parse().unwrap()).unwrap_or(5);
    let d = "/work/shared/data/carphone";
    let mut tiles = Vec::new();
    for a in &args[1..] {
        let f: usize = a.parse().unwrap();
        let img = image::open(format!("{d}/frames/frame_{f:04}.png")).unwrap().to_rgb8();
        let p = lipmap::io::pts::read_pts(
            std::path::Path::new(&format!("{d}/dlib68_pts/frame_{f:04}.pts")),
            f,
        )
        .unwrap();
        let xs: Vec<f64> = (48..68).map(|i| p.points[i].x).collect();
        let ys: Vec<f64> = (48..68).map(|i| p.points[i].y).collect();
        let x0 = xs.iter().cloned().fold(f64::MAX, f64::min).floor() as i64 - pad;
        let y0 = ys.iter().cloned().fold(f64::MAX, f64::min).floor() as i64 - pad;
        let x1 = xs.iter().cloned().fold(f64::MIN, f64::max).ceil() as i64 + pad;
        let y1 = ys.iter().cloned().fold(f64::MIN, f64::max).ceil() as i64 + pad;
        let (w, h) = ((x1 - x0) as u32, (y1 - y0) as u32);
        let margin = 40u32;
        let mut out = RgbImage::new(w * scale + margin, h * scale + 20);
        let lum_mode = std::env::var("LUM").is_ok();
        let (mut lo, mut hi) = (255.0f64, 0.0f64);
        if lum_mode {
            for y in 0..h { for x in 0..w {
                let (sx, sy) = (x0 + x as i64, y0 + y as i64);
                if sx >= 0 && sy >= 0 && (sx as u32) < img.width() && (sy as u32) < img.height() {
                    let c = img.get_pixel(sx as u32, sy as u32);
                    let l = 0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64;
                    lo = lo.min(l); hi = hi.max(l);
                }
            }}
        }
        for y in 0..h {
            for x in 0..w {
                let (sx, sy) = (x0 + x as i64, y0 + y as i64);
                let mut c = if sx >= 0 && sy >= 0 && (sx as u32) < img.width() && (sy as u32) < img.height() {
                    *img.get_pixel(sx as u32, sy as u32)
                } else {
                    Rgb([0, 0, 0])
                };
                if lum_mode {
                    let l = 0.299 * c[0] as f64 + 0.587 * c[1] as f64 + 0.114 * c[2] as f64;
                    let v = (255.0 * (l - lo) / (hi - lo).max(1.0)).clamp(0.0, 255.0) as u8;
                    c = Rgb([v, v, v]);
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        out.put_pixel(margin + x * scale + dx, y * scale + dy, c);
                    }
                }
            }
        }
        if std::env::var("SMOOTH").is_ok() {
            // Catmull-Rom upscale of the crop (cell centres stay where nearest-neighbour put them)
            let crop = image::imageops::crop_imm(&img, x0.max(0) as u32, y0.max(0) as u32, w, h).to_image();
            let big = image::imageops::resize(&crop, w * scale, h * scale, image::imageops::FilterType::CatmullRom);
            image::imageops::overlay(&mut out, &big, margin as i64, 0);
        }
        // y ruler: pixel rows (centre of row y at (y - y0 + 0.5)·scale)
        for y in 0..h {
            let yy = y * scale + scale / 2;
            for dx in 0..6 {
                out.put_pixel(margin - 6 + dx, yy, Rgb([200, 200, 200]));
            }
            if (y0 + y as i64) % 2 == 0 {
                draw_text(&mut out, 2, yy as i64 - 6, &format!("{}", y0 + y as i64), 11.0, Rgb([255, 255, 255]));
            }
        }
        let show = std::env::var("ONLY").ok();
        for i in 48..68 {
            if let Some(o) = &show {
                if !o.split(',').any(|s| s.parse::<usize>().unwrap() == i + 1) {
                    continue;
                }
            }
            let col = match i {
                60..=64 => Rgb([255, 60, 60]),
                65..=67 => Rgb([255, 255, 0]),
                55..=59 => Rgb([0, 200, 255]),
                _ => Rgb([0, 255, 0]),
            };
            // integer coordinate = pixel centre
            let cx = margin as f64 + (p.points[i].x - x0 as f64 + 0.5) * scale as f64;
            let cy = (p.points[i].y - y0 as f64 + 0.5) * scale as f64;
            let arm: i64 = std::env::var("ARM").ok().map(|s| s.parse().unwrap()).unwrap_or(3);
            for t in -arm..=arm {
                for (px, py) in [(cx as i64 + t, cy as i64), (cx as i64, cy as i64 + t)] {
                    if px >= 0 && py >= 0 && (px as u32) < out.width() && (py as u32) < out.height() {
                        out.put_pixel(px as u32, py as u32, col);
                    }
                }
            }
            draw_text(&mut out, cx as i64 + 3, cy as i64 - 12, &format!("{}", i + 1), 10.0, col);
        }
        draw_text(&mut out, margin as i64 + 4, (h * scale + 4) as i64, &format!("frame {f}"), 13.0, Rgb([255, 255, 255]));
        tiles.push(out);
    }
    // tile horizontally
    let tw: u32 = tiles.iter().map(|t| t.width() + 4).sum();
    let th: u32 = tiles.iter().map(|t| t.height()).max().unwrap();
    let mut all = RgbImage::new(tw, th);
    let mut x = 0;
    for t in &tiles {
        image::imageops::overlay(&mut all, t, x as i64, 0);
        x += t.width() + 4;
    }
    let out = std::env::var("OUT").unwrap_or("/tmp/measures27/r/out.png".into());
    all.save(&out).unwrap();
    println!("{out}");
}
