//! A contact sheet: rendered images side by side, each under a labelled
//! header drawn with the HUD's text ([`crate::text`]) — what `relight demo`
//! writes as `demo.png`.
//!
//! Layout: tiles of one size in rows of [`SHEET_COLUMNS`], each cell a header
//! strip of [`header_height`] pixels over its image. Detail lines wider than
//! a cell wrap at its edge; the headers of one sheet are as tall as the
//! longest one needs (at least [`MIN_DETAIL_LINES`], at most
//! [`MAX_DETAIL_LINES`] rows under the title). The sheet is kept twice:
//! as display words (tone-mapped like the viewer's frames, labels drawn in)
//! for the PNG, and as linear radiance at the same places (headers and
//! refused tiles black, no text) for the EXR, so a pixel of either file
//! means the same spot of the same render.

use crate::text::{Canvas, GLYPH, GREY, Line, RED, Rect, WHITE, line_height, wrap};
use glam::Vec3;
use relight_render::Image;

/// Tiles per row.
pub const SHEET_COLUMNS: usize = 2;

/// Header text rows under the title line, at least (a sheet's headers keep
/// this height when every cell's details fit in it).
pub const MIN_DETAIL_LINES: usize = 3;

/// Header text rows under the title line, at most: wrapped details beyond
/// them are cut, the last row ending in `…`.
pub const MAX_DETAIL_LINES: usize = 6;

/// Background of the headers and of refused tiles.
const HEADER: u32 = 0x18_18_1c;

/// One cell of the sheet.
#[derive(Clone, Debug)]
pub struct Cell {
    /// Drawn large: the method's name and its time.
    pub title: String,
    /// Lines under it, each wrapped at the cell's edge (up to
    /// [`MAX_DETAIL_LINES`] rows in all).
    pub details: Vec<Line>,
    /// The image, or why there is none (shown across the tile in red).
    pub image: Result<Image, String>,
}

/// Glyph scale of a sheet whose tiles are `tile_width` pixels wide.
#[must_use]
pub fn text_scale(tile_width: usize) -> usize {
    (tile_width / 480).max(1)
}

/// Height of a cell's header for tiles `tile_width` wide with
/// `detail_lines` rows under the title.
#[must_use]
pub fn header_height(tile_width: usize, detail_lines: usize) -> usize {
    let s = text_scale(tile_width);
    let pad = 4 * s;
    2 * pad + line_height(2 * s) + detail_lines * line_height(s)
}

/// The rows of `details` wrapped to `chars` characters: at most `max`
/// rows, the last one ending in `…` when more were cut.
fn detail_rows(details: &[Line], chars: usize, max: usize) -> Vec<Line> {
    let mut rows: Vec<Line> = details
        .iter()
        .flat_map(|l| {
            wrap(&l.text, chars)
                .into_iter()
                .map(|t| Line::new(t, l.color))
        })
        .collect();
    if rows.len() > max {
        rows.truncate(max);
        if let Some(last) = rows.last_mut() {
            last.text = clip(&format!("{} …", last.text), chars);
        }
    }
    rows
}

/// A composed sheet.
pub struct Sheet {
    pub width: usize,
    pub height: usize,
    /// 0x00RRGGBB sRGB words, labels drawn in.
    pub words: Vec<u32>,
    /// Linear radiance of the tiles at the same places (no labels).
    pub linear: Image,
    /// Where each cell's image lies.
    pub tiles: Vec<Rect>,
    /// Height of every cell's header, pixels ([`header_height`] of the rows
    /// the longest cell needed).
    pub header_height: usize,
}

/// `text` cut to `chars` characters, its last one `…` when cut.
fn clip(text: &str, chars: usize) -> String {
    if text.chars().count() <= chars {
        return text.to_string();
    }
    let mut out: String = text.chars().take(chars.saturating_sub(1)).collect();
    out.push('…');
    out
}

/// Composes `cells` of `tile_width × tile_height` images.
///
/// # Panics
/// When an image is not `tile_width × tile_height`.
#[must_use]
pub fn compose(cells: &[Cell], tile_width: usize, tile_height: usize) -> Sheet {
    let cols = SHEET_COLUMNS.min(cells.len()).max(1);
    let rows = cells.len().div_ceil(cols).max(1);
    let s = text_scale(tile_width);
    let pad = 4 * s;
    let chars = |scale: usize| (tile_width - 2 * pad) / (GLYPH * scale);
    let details: Vec<Vec<Line>> = cells
        .iter()
        .map(|c| detail_rows(&c.details, chars(s), MAX_DETAIL_LINES))
        .collect();
    let detail_lines = details
        .iter()
        .map(Vec::len)
        .max()
        .unwrap_or(0)
        .max(MIN_DETAIL_LINES);
    let hh = header_height(tile_width, detail_lines);
    let (cw, ch) = (tile_width, hh + tile_height);
    let (width, height) = (cols * cw, rows * ch);
    let mut words = vec![HEADER; width * height];
    let mut linear = Image::new(width, height);
    let mut tiles = Vec::new();
    let mut tile_words = vec![0u32; tile_width * tile_height];
    for (i, (cell, details)) in cells.iter().zip(&details).enumerate() {
        let (x0, y0) = ((i % cols) * cw, (i / cols) * ch);
        let tile = Rect {
            x: x0,
            y: y0 + hh,
            w: tile_width,
            h: tile_height,
        };
        tiles.push(tile);
        match &cell.image {
            Ok(img) => {
                assert_eq!((img.width, img.height), (tile_width, tile_height));
                crate::state::to_display(img, &mut tile_words);
                for y in 0..tile_height {
                    let dst = (tile.y + y) * width + tile.x;
                    words[dst..dst + tile_width]
                        .copy_from_slice(&tile_words[y * tile_width..(y + 1) * tile_width]);
                    linear.pixels[dst..dst + tile_width]
                        .copy_from_slice(&img.pixels[y * tile_width..(y + 1) * tile_width]);
                }
            }
            Err(why) => {
                let mut c = Canvas::new(&mut words, width, height);
                c.fill(tile, 0x0c_0c_0e, 1.0);
                let chars = (tile_width - 2 * pad) / (GLYPH * s);
                let lines = wrap(why, chars);
                let lh = line_height(s);
                let top = tile.y + tile_height.saturating_sub(lines.len() * lh) / 2;
                for (k, l) in lines.iter().enumerate() {
                    c.text(tile.x + pad, top + k * lh, s, RED, l);
                }
            }
        }
        let mut c = Canvas::new(&mut words, width, height);
        // The title stops at its own cell's edge.
        let fit = |scale: usize, text: &str| clip(text, chars(scale));
        // The title large when it fits, else at the details' size (a
        // 160-pixel tile holds 9 large glyphs: `sh  13.1 ms/frame` is 17).
        let title_scale = if cell.title.chars().count() <= chars(2 * s) {
            2 * s
        } else {
            s
        };
        c.text(
            x0 + pad,
            y0 + pad,
            title_scale,
            WHITE,
            &fit(title_scale, &cell.title),
        );
        let mut y = y0 + pad + line_height(2 * s);
        for l in details {
            c.text(x0 + pad, y, s, l.color, &l.text);
            y += line_height(s);
        }
        // A one-pixel rule between headers (the images stay untouched).
        c.fill(
            Rect {
                x: x0,
                y: y0,
                w: cw,
                h: 1,
            },
            GREY,
            0.25,
        );
        c.fill(
            Rect {
                x: x0,
                y: y0,
                w: 1,
                h: hh,
            },
            GREY,
            0.25,
        );
    }
    Sheet {
        width,
        height,
        words,
        linear,
        tiles,
        header_height: hh,
    }
}

/// The sheet's words as display-referred linear RGB in [0, 1] (the sRGB
/// curve undone), for a PNG writer that re-encodes sRGB without tone mapping.
#[must_use]
pub fn words_to_display_linear(words: &[u32]) -> Vec<Vec3> {
    let lut: Vec<f32> = (0..256)
        .map(|v| relight_assets::image_io::srgb_to_linear(v as f32 / 255.0))
        .collect();
    words
        .iter()
        .map(|w| {
            Vec3::new(
                lut[((w >> 16) & 0xff) as usize],
                lut[((w >> 8) & 0xff) as usize],
                lut[(w & 0xff) as usize],
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::text::GREEN;

    fn flat(w: usize, h: usize, v: f32) -> Image {
        let mut img = Image::new(w, h);
        img.pixels.fill(Vec3::splat(v));
        img
    }

    #[test]
    fn cells_are_placed_in_rows_with_labels_above_and_refusals_inside() {
        let (tw, th) = (96, 40);
        let cells = vec![
            Cell {
                title: "reference".into(),
                details: vec![Line::new("64 spp", GREY)],
                image: Ok(flat(tw, th, 0.5)),
            },
            Cell {
                title: "sh".into(),
                details: vec![Line::new("error 3 %", GREEN)],
                image: Ok(flat(tw, th, 2.0)),
            },
            Cell {
                title: "fog".into(),
                details: vec![],
                image: Err("method fog cannot render area lights".into()),
            },
        ];
        let s = compose(&cells, tw, th);
        let hh = header_height(tw, MIN_DETAIL_LINES);
        assert_eq!(s.header_height, hh);
        assert_eq!((s.width, s.height), (2 * tw, 2 * (hh + th)));
        assert_eq!(
            s.tiles[2],
            Rect {
                x: 0,
                y: 2 * hh + th,
                w: tw,
                h: th
            }
        );
        // The linear copy holds the renders where the PNG shows them.
        let at = |img: &Image, x: usize, y: usize| img.pixels[y * s.width + x];
        assert_eq!(at(&s.linear, tw + 10, hh + 10), Vec3::splat(2.0));
        assert_eq!(at(&s.linear, 10, hh + 10), Vec3::splat(0.5));
        assert_eq!(at(&s.linear, 10, 5), Vec3::ZERO);
        // Tile pixels are the tone-mapped render, untouched by the labels.
        let mut tone = vec![0u32; tw * th];
        crate::state::to_display(&flat(tw, th, 0.5), &mut tone);
        for y in 0..th {
            for x in 0..tw {
                assert_eq!(s.words[(hh + y) * s.width + x], tone[y * tw + x]);
            }
        }
        // Titles are white text in the headers; the refusal is red in its tile.
        let count = |r: Rect, c: u32| {
            (r.y..r.y + r.h)
                .flat_map(|y| (r.x..r.x + r.w).map(move |x| (x, y)))
                .filter(|&(x, y)| s.words[y * s.width + x] == c)
                .count()
        };
        let header = Rect {
            x: 0,
            y: 0,
            w: tw,
            h: hh,
        };
        assert!(count(header, WHITE) > 30);
        assert!(count(s.tiles[2], RED) > 30);
        assert_eq!(count(s.tiles[0], RED), 0);
    }

    /// A label longer than its cell is cut there (with `…`), not drawn
    /// over the next cell's header.
    #[test]
    fn long_labels_stop_at_their_cells_edge() {
        let (tw, th) = (96, 40);
        let long = "x".repeat(200);
        let cells = vec![
            Cell {
                title: long.clone(),
                details: vec![Line::new(long.clone(), GREEN)],
                image: Ok(flat(tw, th, 0.5)),
            },
            Cell {
                title: String::new(),
                details: vec![],
                image: Ok(flat(tw, th, 0.5)),
            },
        ];
        let s = compose(&cells, tw, th);
        let hh = s.header_height;
        assert_eq!(hh, header_height(tw, MAX_DETAIL_LINES));
        let drawn = |c: u32| {
            (0..hh)
                .flat_map(|y| (tw..2 * tw).map(move |x| (x, y)))
                .filter(|&(x, y)| s.words[y * s.width + x] == c)
                .count()
        };
        assert_eq!((drawn(WHITE), drawn(GREEN)), (0, 0));
        assert_eq!(clip("abcdef", 4), "abc…");
        assert_eq!(clip("abc", 4), "abc");
    }

    /// Details wider than the cell wrap at word breaks, and the sheet's
    /// headers grow to hold the longest cell's rows (up to
    /// [`MAX_DETAIL_LINES`], the last row then ending in `…`).
    #[test]
    fn details_wrap_at_the_cells_edge_and_the_headers_grow() {
        // A 200-pixel tile holds (200 − 8) / 8 = 24 glyphs a row.
        let note = Line::new("unshadowed: sh cannot render visibility (shadows)", GREEN);
        let rows = detail_rows(std::slice::from_ref(&note), 24, MAX_DETAIL_LINES);
        let text: Vec<&str> = rows.iter().map(|l| l.text.as_str()).collect();
        assert_eq!(
            text,
            ["unshadowed: sh cannot", "render visibility", "(shadows)"]
        );
        assert!(rows.iter().all(|l| l.color == GREEN));
        let many = vec![note; 4];
        let rows = detail_rows(&many, 24, MAX_DETAIL_LINES);
        assert_eq!(rows.len(), MAX_DETAIL_LINES);
        assert_eq!(rows[5].text, "(shadows) …");

        let (tw, th) = (200, 40);
        let cell = |details: Vec<Line>| Cell {
            title: "sh".into(),
            details,
            image: Ok(flat(tw, th, 0.5)),
        };
        let short = compose(&[cell(vec![Line::new("ok", GREEN)])], tw, th);
        assert_eq!(short.header_height, header_height(tw, MIN_DETAIL_LINES));
        let long = vec![
            Line::new("error 40.2 % rel. RMS vs reference", GREEN),
            Line::new("relight 0.9 ms · bake/load 1.2 s", GREY),
            Line::new("unshadowed: sh cannot render visibility (shadows)", WHITE),
        ];
        let s = compose(&[cell(vec![]), cell(long)], tw, th);
        // 2 + 2 + 3 rows.
        assert_eq!(s.header_height, header_height(tw, 7.min(MAX_DETAIL_LINES)));
        assert_eq!(s.height, s.header_height + th);
        // The rows' text stays inside the second cell.
        let drawn_right = (0..s.header_height)
            .flat_map(|y| (tw..2 * tw).map(move |x| (x, y)))
            .filter(|&(x, y)| s.words[y * s.width + x] == GREEN)
            .count();
        assert!(drawn_right > 30);
    }

    /// A title too long for large glyphs (17 characters on a 160-pixel
    /// tile, which holds 9) is drawn whole at the details' size instead of
    /// cut to `sh  13.1…`.
    #[test]
    fn a_long_title_on_a_small_tile_is_drawn_small_and_whole() {
        let (tw, th) = (160, 40);
        let cells = vec![Cell {
            title: "sh  13.1 ms/frame".into(),
            details: vec![],
            image: Ok(flat(tw, th, 0.5)),
        }];
        let s = compose(&cells, tw, th);
        let white: Vec<(usize, usize)> = (0..s.header_height)
            .flat_map(|y| (0..tw).map(move |x| (x, y)))
            .filter(|&(x, y)| s.words[y * s.width + x] == WHITE)
            .collect();
        let (x_max, y_min, y_max) = white.iter().fold((0, usize::MAX, 0), |(a, b, c), &(x, y)| {
            (a.max(x), b.min(y), c.max(y))
        });
        // The 17th glyph (`e`, 8 pixels from x = 4 + 16 · 8) is drawn, one
        // glyph high.
        assert!(x_max >= 4 + 16 * GLYPH, "last white column {x_max}");
        assert!(y_max - y_min < GLYPH, "rows {y_min}…{y_max}");
    }

    #[test]
    fn display_words_round_trip_through_the_srgb_curve() {
        let words = [0x00_00_00, 0xff_80_01];
        let lin = words_to_display_linear(&words);
        assert_eq!(lin[0], Vec3::ZERO);
        let back = |v: f32| (relight_assets::linear_to_srgb(v) * 255.0).round() as u32;
        assert_eq!(
            (back(lin[1].x), back(lin[1].y), back(lin[1].z)),
            (255, 128, 1)
        );
    }
}
