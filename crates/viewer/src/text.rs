//! Text and panels drawn into 0x00RRGGBB display words: the one text path of
//! relight, used by the viewer's HUD ([`crate::hud`]) and by the labels of
//! `relight demo`'s composite ([`crate::sheet`]).
//!
//! # Why bitmap text and not a UI toolkit
//! The developers' guide suggests a small UI crate for the HUD; the one
//! checked here (egui 0.34 with the 0.0.x `egui_software_backend`) draws
//! well into a softbuffer window. It was not taken, for three reasons:
//! * **One text path, headless.** The same labels go into the window and
//!   into `demo.png`, which is written with no window and no event loop. A
//!   glyph blitter over a `&mut [u32]` serves both and is tested by reading
//!   pixels back; egui's path (layout → tessellation → software raster) would
//!   have to run offscreen for the PNG through a 0.0.x backend.
//! * **Nothing to interact with.** The HUD shows text and two bars; every
//!   control is a key. Widgets, hit-testing and a per-frame immediate-mode
//!   pass would be dead weight on a 2-core machine where a frame's budget is
//!   16 ms.
//! * **Build cost.** The glyph data is one dependency-free crate
//!   (`font8x8`, the public-domain 8×8 font, legacy tables only), against
//!   egui's dozen crates on a machine that compiles for four engineers.
//!
//! # Glyphs
//! Each glyph is 8×8 bits (`font8x8` legacy tables: row `r` is byte `r`, bit
//! 0 the leftmost pixel), drawn at an integer `scale` (a glyph covers
//! `8·scale` pixels square, and glyphs sit edge to edge: the font keeps its
//! own one-pixel spacing). Basic Latin, Latin-1 (`×`, `²`, `·`, `°`) and
//! Greek (`σ`, `α`) are drawn as themselves; a few typographic characters
//! map to the nearest ASCII (`—`/`–` → `-`, `≤` → `<`, `≥` → `>`, `≈` →
//! `~`, `→` → `>`), `…` (the mark of a cut label) is drawn here as three of
//! the font's 2×2 dots, anything else is `?`. One `char` is always
//! one cell, so widths are `8·scale·chars`.

use font8x8::legacy::{BASIC_LEGACY, GREEK_LEGACY, LATIN_LEGACY};

/// Side of a glyph cell at scale 1, pixels.
pub const GLYPH: usize = 8;

/// `…`: three 2×2 dots on the rows of the font's `.` (one cell, so a cut
/// label keeps its width).
const ELLIPSIS: [u8; 8] = [0, 0, 0, 0, 0, 0xdb, 0xdb, 0];

/// The 8×8 bitmap of `c` (see the module docs for the mapping).
#[must_use]
pub fn glyph(c: char) -> [u8; 8] {
    let c = match c {
        '…' => return ELLIPSIS,
        '—' | '–' | '−' => '-',
        '≤' => '<',
        '≥' | '→' => '>',
        '≈' => '~',
        '\t' => ' ',
        c => c,
    };
    let u = c as u32;
    match u {
        0x20..=0x7e => BASIC_LEGACY[u as usize],
        0xa0..=0xff => LATIN_LEGACY[(u - 0xa0) as usize],
        0x390..=0x3c9 => GREEK_LEGACY[(u - 0x390) as usize],
        _ => BASIC_LEGACY[b'?' as usize],
    }
}

/// Width and height in pixels of one line of `text` at `scale`.
#[must_use]
pub fn text_size(text: &str, scale: usize) -> (usize, usize) {
    (text.chars().count() * GLYPH * scale, GLYPH * scale)
}

/// Splits `text` into lines of at most `max_chars` characters, at spaces
/// where it can (a word longer than a line is cut).
#[must_use]
pub fn wrap(text: &str, max_chars: usize) -> Vec<String> {
    let max = max_chars.max(1);
    let mut lines = Vec::new();
    for para in text.split('\n') {
        let mut line = String::new();
        for word in para.split(' ') {
            let mut word: Vec<char> = word.chars().collect();
            loop {
                let len = line.chars().count();
                let need = if len == 0 {
                    word.len()
                } else {
                    len + 1 + word.len()
                };
                if need <= max {
                    if len > 0 {
                        line.push(' ');
                    }
                    line.extend(word.iter());
                    break;
                }
                if len > 0 {
                    lines.push(std::mem::take(&mut line));
                    continue;
                }
                // A word longer than a whole line.
                let rest = word.split_off(max);
                lines.push(word.iter().collect());
                word = rest;
            }
        }
        lines.push(line);
    }
    lines
}

/// A pixel rectangle: top-left corner and size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Rect {
    pub x: usize,
    pub y: usize,
    pub w: usize,
    pub h: usize,
}

impl Rect {
    /// True when pixel (`x`, `y`) lies inside.
    #[must_use]
    pub fn contains(&self, x: usize, y: usize) -> bool {
        x >= self.x && x < self.x + self.w && y >= self.y && y < self.y + self.h
    }
}

/// A `width × height` grid of 0x00RRGGBB words (sRGB, row 0 at the top): a
/// window's softbuffer, or an image about to be written as PNG. Drawing is
/// clipped to the grid.
pub struct Canvas<'a> {
    words: &'a mut [u32],
    width: usize,
    height: usize,
}

/// `a` blended over `b` with `alpha` in [0, 1], per 8-bit sRGB channel.
#[inline]
fn blend(a: u32, b: u32, alpha: f32) -> u32 {
    let t = (alpha.clamp(0.0, 1.0) * 256.0) as u32;
    let ch = |s: u32| {
        let (ca, cb) = ((a >> s) & 0xff, (b >> s) & 0xff);
        ((ca * t + cb * (256 - t)) >> 8) << s
    };
    ch(16) | ch(8) | ch(0)
}

impl<'a> Canvas<'a> {
    /// A canvas over `words` (at least `width · height` of them).
    ///
    /// # Panics
    /// When `words` is shorter than `width · height`.
    pub fn new(words: &'a mut [u32], width: usize, height: usize) -> Self {
        assert!(
            words.len() >= width * height,
            "canvas smaller than its size"
        );
        Self {
            words,
            width,
            height,
        }
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// The word at (`x`, `y`).
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> u32 {
        self.words[y * self.width + x]
    }

    /// Blends `color` over the rectangle with opacity `alpha` (1 = opaque).
    pub fn fill(&mut self, r: Rect, color: u32, alpha: f32) {
        let x1 = (r.x + r.w).min(self.width);
        let y1 = (r.y + r.h).min(self.height);
        for y in r.y.min(y1)..y1 {
            let row = &mut self.words[y * self.width..(y + 1) * self.width];
            for w in &mut row[r.x.min(x1)..x1] {
                *w = blend(color, *w, alpha);
            }
        }
    }

    /// Draws one line of `text` with its top-left corner at (`x`, `y`) in
    /// `color`, glyphs `scale` times their 8×8 size; returns the rectangle
    /// the line occupies (clipped or not).
    pub fn text(&mut self, x: usize, y: usize, scale: usize, color: u32, text: &str) -> Rect {
        let s = scale.max(1);
        let mut cx = x;
        for c in text.chars() {
            let g = glyph(c);
            for (row, bits) in g.iter().enumerate() {
                if *bits == 0 {
                    continue;
                }
                for col in 0..GLYPH {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for dy in 0..s {
                        let py = y + row * s + dy;
                        if py >= self.height {
                            break;
                        }
                        for dx in 0..s {
                            let px = cx + col * s + dx;
                            if px < self.width {
                                self.words[py * self.width + px] = color;
                            }
                        }
                    }
                }
            }
            cx += GLYPH * s;
        }
        let (w, h) = text_size(text, s);
        Rect { x, y, w, h }
    }

    /// A panel: `lines` of text at `scale` on a translucent dark box whose
    /// top-left corner is (`x`, `y`), `pad` pixels of margin; returns the box.
    pub fn panel(&mut self, x: usize, y: usize, scale: usize, lines: &[Line], pad: usize) -> Rect {
        let r = panel_rect(x, y, scale, lines, pad);
        self.fill(r, PANEL, PANEL_ALPHA);
        let lh = line_height(scale);
        for (i, l) in lines.iter().enumerate() {
            self.text(x + pad, y + pad + i * lh, scale, l.color, &l.text);
        }
        r
    }
}

/// Panel background colour and opacity.
pub const PANEL: u32 = 0x10_10_14;
pub const PANEL_ALPHA: f32 = 0.72;
/// Text colours.
pub const WHITE: u32 = 0xff_ff_ff;
pub const GREY: u32 = 0xb4_b4_b4;
pub const YELLOW: u32 = 0xff_d2_4a;
pub const RED: u32 = 0xff_6e_5a;
pub const GREEN: u32 = 0x8c_e6_8c;

/// One line of a panel: text and colour.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Line {
    pub text: String,
    pub color: u32,
}

impl Line {
    #[must_use]
    pub fn new(text: impl Into<String>, color: u32) -> Self {
        Self {
            text: text.into(),
            color,
        }
    }
}

/// Pixels from one line's top to the next's at `scale` (glyph + 1/4 leading).
#[must_use]
pub fn line_height(scale: usize) -> usize {
    GLYPH * scale.max(1) + 2 * scale.max(1)
}

/// The box [`Canvas::panel`] fills for `lines`.
#[must_use]
pub fn panel_rect(x: usize, y: usize, scale: usize, lines: &[Line], pad: usize) -> Rect {
    let w = lines
        .iter()
        .map(|l| text_size(&l.text, scale).0)
        .max()
        .unwrap_or(0);
    let h = lines.len() * line_height(scale);
    Rect {
        x,
        y,
        w: w + 2 * pad,
        h: h + 2 * pad - if lines.is_empty() { 0 } else { 2 * scale },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glyphs_map_known_characters_and_fall_back_to_a_question_mark() {
        assert_eq!(glyph(' '), [0; 8]);
        assert_ne!(glyph('A'), glyph('B'));
        assert_eq!(glyph('—'), glyph('-'));
        assert_ne!(glyph('×'), glyph('?'));
        assert_ne!(glyph('σ'), glyph('?'));
        assert_eq!(glyph('\u{4e00}'), glyph('?'));
        // `…`: three dots on the rows of `.`'s dot.
        let (dot, ellipsis) = (glyph('.'), glyph('…'));
        for (d, e) in dot.iter().zip(ellipsis) {
            assert_eq!(*d != 0, e != 0);
            assert_eq!(e.count_ones(), if e == 0 { 0 } else { 6 });
        }
        // 'L': the foot runs to the right, so bit 0 is the leftmost pixel.
        let l = glyph('L');
        assert!(l[6] & 1 != 0 && l[6] & 0x40 != 0 && l[1] & 0x40 == 0);
    }

    #[test]
    fn text_lands_inside_its_rectangle_only() {
        let (w, h) = (64, 24);
        let mut words = vec![0u32; w * h];
        let mut c = Canvas::new(&mut words, w, h);
        let r = c.text(3, 5, 2, WHITE, "Hi");
        assert_eq!(
            r,
            Rect {
                x: 3,
                y: 5,
                w: 32,
                h: 16
            }
        );
        let mut inside = 0;
        for y in 0..h {
            for x in 0..w {
                let v = c.get(x, y);
                if r.contains(x, y) {
                    inside += usize::from(v == WHITE);
                } else {
                    assert_eq!(v, 0, "({x}, {y}) outside the text changed");
                }
            }
        }
        // 'H' and 'i' at scale 2: each lit font bit is 4 pixels.
        let bits: u32 = [glyph('H'), glyph('i')]
            .iter()
            .flatten()
            .map(|b| b.count_ones())
            .sum();
        assert_eq!(inside as u32, 4 * bits);
        // Clipped at the edges, never a panic.
        c.text(60, 20, 3, WHITE, "clipped text");
    }

    #[test]
    fn fill_blends_and_clips() {
        let mut words = vec![0x00_ff_00u32; 4 * 3];
        let mut c = Canvas::new(&mut words, 4, 3);
        c.fill(
            Rect {
                x: 2,
                y: 1,
                w: 10,
                h: 10,
            },
            0xff_00_00,
            0.5,
        );
        assert_eq!(c.get(0, 0), 0x00_ff_00);
        let v = c.get(3, 2);
        assert!(
            (v >> 16) & 0xff >= 127 && (v >> 8) & 0xff <= 128 && v & 0xff == 0,
            "{v:06x}"
        );
    }

    #[test]
    fn wrap_breaks_at_spaces_and_cuts_long_words() {
        assert_eq!(
            wrap("method sh cannot render point lights", 12),
            ["method sh", "cannot", "render point", "lights"]
        );
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap("a\nb", 10), ["a", "b"]);
        for l in wrap("a fairly long message that goes on and on", 7) {
            assert!(l.chars().count() <= 7, "{l}");
        }
    }
}
