//! Text for PNG charts: DejaVu Sans (cut down to Latin, IPA, Greek and chart symbols, inside
//! the binary; `assets/fonts/` says what and under which licence) rasterised by `ab_glyph`,
//! so phone labels print as the aligner wrote them, IPA included.
//!
//! Glyphs are placed one after another by their advances with no shaping: combining marks
//! (tie bars, syllabic marks) have no advance in DejaVu and land on the letter before them,
//! which is all phone labels need. Text is first rendered to a coverage mask
//! ([`render_text`]) and then blended at whole pixels, so the same text always gives the same
//! pixels; [`find_text`] relies on that to check a chart carries its labels.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use image::{GrayImage, Luma, Rgb, RgbImage};
use std::sync::LazyLock;

/// The embedded font (see the module notes).
const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

static FONT: LazyLock<FontRef<'static>> = LazyLock::new(|| {
    FontRef::try_from_slice(FONT_BYTES).expect("the embedded font parses (tested)")
});

/// Whether the font has a glyph for `c` (others draw as the font's empty box).
pub fn has_glyph(c: char) -> bool {
    FONT.glyph_id(c).0 != 0
}

/// Height in pixels of one line at `px` (ascent + descent, no line gap).
pub fn text_height(px: f32) -> u32 {
    let f = FONT.as_scaled(PxScale::from(px));
    (f.ascent() - f.descent()).ceil().max(1.0) as u32
}

/// Width in pixels of `text` at `px` (the sum of the advances).
pub fn text_width(text: &str, px: f32) -> u32 {
    let f = FONT.as_scaled(PxScale::from(px));
    let w: f32 = text.chars().map(|c| f.h_advance(f.glyph_id(c))).sum();
    w.ceil() as u32
}

/// `text` at `px` as a coverage mask (0 none – 255 full), [`text_width`] × [`text_height`],
/// the top of the ascent at row 0. Ink falling outside the box (a combining mark on the first
/// letter, a descent deeper than the font's) is clipped.
pub fn render_text(text: &str, px: f32) -> GrayImage {
    let scale = PxScale::from(px);
    let f = FONT.as_scaled(scale);
    let (w, h) = (text_width(text, px).max(1), text_height(px));
    let mut mask = GrayImage::new(w, h);
    let mut caret = 0.0f32;
    for c in text.chars() {
        let id = f.glyph_id(c);
        let glyph = id.with_scale_and_position(scale, point(caret, f.ascent()));
        caret += f.h_advance(id);
        let Some(outline) = FONT.outline_glyph(glyph) else { continue };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, cov| {
            let (x, y) = (b.min.x as i64 + i64::from(gx), b.min.y as i64 + i64::from(gy));
            if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                let p = mask.get_pixel_mut(x as u32, y as u32);
                p.0[0] = p.0[0].max((cov.clamp(0.0, 1.0) * 255.0).round() as u8);
            }
        });
    }
    mask
}

/// Draws `text` at `px` with the top-left of its box at (x, y), blended over what is there.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, px: f32, colour: Rgb<u8>) {
    blend_mask(img, &render_text(text, px), x, y, colour);
}

/// Draws `text` turned a quarter left (reading bottom to top, as a y-axis label), the top-left
/// of its turned box ([`text_height`] wide, [`text_width`] tall) at (x, y).
pub fn draw_text_up(img: &mut RgbImage, x: i64, y: i64, text: &str, px: f32, colour: Rgb<u8>) {
    blend_mask(img, &image::imageops::rotate270(&render_text(text, px)), x, y, colour);
}

/// The colour of a pixel covered `a` (0–255) by `ink` over `under`.
fn over(under: Rgb<u8>, ink: Rgb<u8>, a: u8) -> Rgb<u8> {
    let a = u32::from(a);
    Rgb(std::array::from_fn(|k| {
        ((u32::from(under.0[k]) * (255 - a) + u32::from(ink.0[k]) * a + 127) / 255) as u8
    }))
}

fn blend_mask(img: &mut RgbImage, mask: &GrayImage, x: i64, y: i64, colour: Rgb<u8>) {
    for (mx, my, Luma([a])) in mask.enumerate_pixels() {
        let (px, py) = (x + i64::from(mx), y + i64::from(my));
        if *a == 0 || px < 0 || py < 0 || px >= i64::from(img.width()) {
            continue;
        }
        if py >= i64::from(img.height()) {
            continue;
        }
        let p = img.get_pixel_mut(px as u32, py as u32);
        *p = over(*p, colour, *a);
    }
}

/// Where `text` (at `px`, in `colour`, turned a quarter left when `up`) is drawn in `img` on
/// white: the top-left of its box, or `None` when no place shows it whole. A test's proof that
/// a chart's labels are there and unobstructed (a label crossed by a line or cut off is not
/// found).
#[cfg(any(test, feature = "test-fixtures"))]
pub fn find_text(
    img: &RgbImage,
    text: &str,
    px: f32,
    colour: Rgb<u8>,
    up: bool,
) -> Option<(u32, u32)> {
    let mask = render_text(text, px);
    let mask = if up { image::imageops::rotate270(&mask) } else { mask };
    let white = Rgb([255, 255, 255]);
    let inked: Vec<(u32, u32, Rgb<u8>)> = mask
        .enumerate_pixels()
        .filter(|(_, _, a)| a.0[0] > 0)
        .map(|(x, y, a)| (x, y, over(white, colour, a.0[0])))
        .collect();
    // Anchor on the most covered pixel: few image pixels share its exact colour.
    let &(ax, ay, want) =
        inked.iter().min_by_key(|(_, _, c)| c.0.iter().map(|&v| u32::from(v)).sum::<u32>())?;
    let close = |a: Rgb<u8>, b: Rgb<u8>| a.0.iter().zip(b.0).all(|(&p, q)| p.abs_diff(q) <= 2);
    for (x, y, p) in img.enumerate_pixels() {
        if !close(*p, want) || x < ax || y < ay {
            continue;
        }
        let (ox, oy) = (x - ax, y - ay);
        if ox + mask.width() > img.width() || oy + mask.height() > img.height() {
            continue;
        }
        if inked.iter().all(|&(mx, my, c)| close(*img.get_pixel(ox + mx, oy + my), c)) {
            return Some((ox, oy));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ipa_and_greek_symbols_have_glyphs() {
        for c in "əθœɪʊæɑɔʃʒŋðɹɾʔːˈʰ\u{0361}\u{0329}ωξσ±−–".chars() {
            assert!(has_glyph(c), "{c} (U+{:04X})", c as u32);
        }
        assert!(!has_glyph('\u{4E2D}'));
    }

    #[test]
    fn text_inks_pixels_inside_its_box_only() {
        let mut img = RgbImage::from_pixel(120, 40, Rgb([255, 255, 255]));
        draw_text(&mut img, 5, 7, "AA1 ə", 16.0, Rgb([200, 0, 0]));
        let (w, h) = (text_width("AA1 ə", 16.0), text_height(16.0));
        let mut inked = 0;
        for (x, y, p) in img.enumerate_pixels() {
            if p.0 != [255, 255, 255] {
                inked += 1;
                assert!((5..5 + w).contains(&x) && (7..7 + h).contains(&y), "({x}, {y})");
            }
        }
        assert!(inked > 60, "{inked}");
    }

    #[test]
    fn distinct_phone_labels_render_distinctly() {
        // The old bitmap font drew ə, θ and œ alike as `?` and folded case.
        let masks: Vec<GrayImage> =
            ["ə", "θ", "œ", "i", "I", "o", "O"].iter().map(|t| render_text(t, 14.0)).collect();
        for (i, a) in masks.iter().enumerate() {
            assert!(a.pixels().any(|p| p.0[0] > 128), "{i} has ink");
            for b in &masks[i + 1..] {
                assert_ne!(a.as_raw(), b.as_raw());
            }
        }
    }

    #[test]
    fn drawn_text_is_found_where_it_was_drawn_and_nowhere_else() {
        let mut img = RgbImage::from_pixel(200, 120, Rgb([255, 255, 255]));
        let ink = Rgb([30, 30, 30]);
        draw_text(&mut img, 17, 9, "t͡ʃ ə time (s)", 13.0, ink);
        draw_text_up(&mut img, 150, 20, "W (min–max)", 13.0, ink);
        assert_eq!(find_text(&img, "t͡ʃ ə time (s)", 13.0, ink, false), Some((17, 9)));
        assert_eq!(find_text(&img, "W (min–max)", 13.0, ink, true), Some((150, 20)));
        assert_eq!(find_text(&img, "W (min–max)", 13.0, ink, false), None);
        assert_eq!(find_text(&img, "θ", 13.0, ink, false), None);
        // A line through the label hides it.
        for x in 0..200 {
            img.put_pixel(x, 14, ink);
        }
        assert_eq!(find_text(&img, "t͡ʃ ə time (s)", 13.0, ink, false), None);
    }
}
