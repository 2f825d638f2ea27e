//! A tiny 5x7 bitmap font, drawn straight into RGB buffers, so the crate's pictures can carry
//! words without a font dependency. Each glyph is seven rows of five bits, the leftmost pixel
//! in bit 4; lowercase letters with descenders are lifted to fit the seven rows.

/// Columns of a glyph, before scaling.
pub const GLYPH_WIDTH: u32 = 5;
/// Rows of a glyph, before scaling.
pub const GLYPH_HEIGHT: u32 = 7;
/// Columns from one glyph's left edge to the next's: the glyph and one blank column.
const ADVANCE: u32 = GLYPH_WIDTH + 1;

/// What an unknown character draws: a small box, so a missing glyph shows instead of vanishing.
const UNKNOWN: [u8; 7] = [
    0b00000, 0b11111, 0b10001, 0b10001, 0b10001, 0b11111, 0b00000,
];

#[rustfmt::skip]
const GLYPHS: &[(char, [u8; 7])] = &[
    (' ', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000]),
    ('0', [0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110]),
    ('1', [0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('2', [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111]),
    ('3', [0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110]),
    ('4', [0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010]),
    ('5', [0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110]),
    ('6', [0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110]),
    ('7', [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000]),
    ('8', [0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110]),
    ('9', [0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100]),
    ('A', [0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001]),
    ('B', [0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110]),
    ('C', [0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110]),
    ('D', [0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100]),
    ('E', [0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111]),
    ('F', [0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000]),
    ('G', [0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111]),
    ('H', [0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001]),
    ('I', [0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('J', [0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100]),
    ('K', [0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001]),
    ('L', [0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111]),
    ('M', [0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001]),
    ('N', [0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001]),
    ('O', [0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('P', [0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000]),
    ('Q', [0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101]),
    ('R', [0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001]),
    ('S', [0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110]),
    ('T', [0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100]),
    ('U', [0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('V', [0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100]),
    ('W', [0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010]),
    ('X', [0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001]),
    ('Y', [0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100]),
    ('Z', [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111]),
    ('a', [0b00000, 0b00000, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111]),
    ('b', [0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b11110]),
    ('c', [0b00000, 0b00000, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110]),
    ('d', [0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111]),
    ('e', [0b00000, 0b00000, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110]),
    ('f', [0b00110, 0b01001, 0b01000, 0b11100, 0b01000, 0b01000, 0b01000]),
    ('g', [0b00000, 0b01111, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110]),
    ('h', [0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001]),
    ('i', [0b00100, 0b00000, 0b01100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('j', [0b00010, 0b00000, 0b00110, 0b00010, 0b00010, 0b10010, 0b01100]),
    ('k', [0b10000, 0b10000, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010]),
    ('l', [0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('m', [0b00000, 0b00000, 0b11010, 0b10101, 0b10101, 0b10001, 0b10001]),
    ('n', [0b00000, 0b00000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001]),
    ('o', [0b00000, 0b00000, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('p', [0b00000, 0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000]),
    ('q', [0b00000, 0b01111, 0b10001, 0b10001, 0b01111, 0b00001, 0b00001]),
    ('r', [0b00000, 0b00000, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000]),
    ('s', [0b00000, 0b00000, 0b01111, 0b10000, 0b01110, 0b00001, 0b11110]),
    ('t', [0b01000, 0b01000, 0b11100, 0b01000, 0b01000, 0b01001, 0b00110]),
    ('u', [0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b10011, 0b01101]),
    ('v', [0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100]),
    ('w', [0b00000, 0b00000, 0b10001, 0b10001, 0b10101, 0b10101, 0b01010]),
    ('x', [0b00000, 0b00000, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001]),
    ('y', [0b00000, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110]),
    ('z', [0b00000, 0b00000, 0b11111, 0b00010, 0b00100, 0b01000, 0b11111]),
    ('.', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100]),
    (',', [0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000]),
    (':', [0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000]),
    (';', [0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b00100, 0b01000]),
    ('=', [0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000]),
    ('-', [0b00000, 0b00000, 0b00000, 0b11111, 0b00000, 0b00000, 0b00000]),
    ('+', [0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000]),
    ('%', [0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011]),
    ('(', [0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010]),
    (')', [0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000]),
    ('[', [0b01110, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01110]),
    (']', [0b01110, 0b00010, 0b00010, 0b00010, 0b00010, 0b00010, 0b01110]),
    ('/', [0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000]),
    ('_', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111]),
    ('!', [0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00000, 0b00100]),
    ('?', [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b00000, 0b00100]),
    ('\'', [0b00100, 0b00100, 0b01000, 0b00000, 0b00000, 0b00000, 0b00000]),
    ('"', [0b01010, 0b01010, 0b01010, 0b00000, 0b00000, 0b00000, 0b00000]),
    ('*', [0b00000, 0b00100, 0b10101, 0b01110, 0b10101, 0b00100, 0b00000]),
    ('<', [0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010]),
    ('>', [0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000]),
    ('#', [0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010]),
];

/// The rows of `c`'s glyph, or the box of an unknown character.
fn glyph(c: char) -> [u8; 7] {
    GLYPHS
        .iter()
        .find(|(g, _)| *g == c)
        .map_or(UNKNOWN, |(_, rows)| *rows)
}

/// Width in pixels of `text` drawn at `scale`: one advance per character, less the blank column
/// after the last one, so centring on the result centres the ink.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let count = text.chars().count() as u32;
    (count * ADVANCE).saturating_sub(1) * scale
}

/// Draws `text` into `image` (RGB, row-major, `width` x `height`) with its top left corner at
/// (`x`, `y`), each font pixel a `scale` x `scale` square of `color`. Whatever falls outside the
/// image is clipped, so callers can place text near edges without checks.
#[allow(clippy::too_many_arguments)]
pub fn draw_text(
    image: &mut [u8],
    width: u32,
    height: u32,
    x: i64,
    y: i64,
    text: &str,
    scale: u32,
    color: [u8; 3],
) {
    let s = scale.max(1) as i64;
    for (i, c) in text.chars().enumerate() {
        let left = x + i as i64 * ADVANCE as i64 * s;
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..GLYPH_WIDTH as i64 {
                let mask = 0b10000u8 >> col;
                if (bits & mask) == 0 {
                    continue;
                }
                let (px, py) = (left + col * s, y + row as i64 * s);
                fill(image, width, height, (px, py), s, color);
            }
        }
    }
}

/// One font pixel: an `s` x `s` square with its top left at `at`, clipped to the image.
fn fill(image: &mut [u8], width: u32, height: u32, at: (i64, i64), s: i64, color: [u8; 3]) {
    let (w, h) = (width as i64, height as i64);
    for y in at.1.max(0)..(at.1 + s).min(h) {
        for x in at.0.max(0)..(at.0 + s).min(w) {
            let i = 3 * (y * w + x) as usize;
            // A buffer shorter than width x height is clipped too rather than a panic.
            if let Some(pixel) = image.get_mut(i..i + 3) {
                pixel.copy_from_slice(&color);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pixels of an RGB image that are not white.
    fn inked(image: &[u8], width: u32) -> Vec<(u32, u32)> {
        image
            .chunks_exact(3)
            .enumerate()
            .filter(|(_, p)| p.iter().any(|&v| v != 255))
            .map(|(i, _)| (i as u32 % width, i as u32 / width))
            .collect()
    }

    #[test]
    fn a_glyph_inks_its_box_only_and_widths_add_up() {
        let (width, height) = (40, 30);
        let mut image = vec![255u8; (width * height * 3) as usize];
        draw_text(&mut image, width, height, 7, 5, "A", 2, [0, 0, 0]);
        let ink = inked(&image, width);
        assert!(!ink.is_empty(), "the glyph draws");
        for &(x, y) in &ink {
            assert!(
                (7..7 + 2 * GLYPH_WIDTH).contains(&x),
                "x {x} outside the box"
            );
            assert!(
                (5..5 + 2 * GLYPH_HEIGHT).contains(&y),
                "y {y} outside the box"
            );
        }
        // The top row of A is its middle three columns.
        assert!(ink.contains(&(9, 5)) && !ink.contains(&(7, 5)));

        assert_eq!(text_width("", 3), 0);
        assert_eq!(text_width("A", 2), 2 * GLYPH_WIDTH);
        assert_eq!(text_width("t = 1.17 s", 1), 10 * ADVANCE - 1);
        assert_eq!(text_width("ab", 3), 3 * (ADVANCE + GLYPH_WIDTH));

        // Every character the pictures use has its own glyph, not the unknown box.
        for c in "azAZ09 .,:=-+%()/_".chars() {
            assert!(GLYPHS.iter().any(|(g, _)| *g == c), "{c:?} has no glyph");
        }
    }

    #[test]
    fn text_is_clipped_at_the_edges_and_unknown_characters_draw_a_box() {
        let (width, height) = (12, 9);
        let mut image = vec![255u8; (width * height * 3) as usize];
        draw_text(
            &mut image,
            width,
            height,
            -4,
            -3,
            "W\u{e9}W",
            2,
            [10, 20, 30],
        );
        draw_text(&mut image, width, height, 8, 6, "W", 2, [10, 20, 30]);
        assert_eq!(image.len(), (width * height * 3) as usize);
        let mut boxed = vec![255u8; (width * height * 3) as usize];
        draw_text(&mut boxed, width, height, 0, 0, "\u{e9}", 1, [0, 0, 0]);
        let ink = inked(&boxed, width);
        assert_eq!(ink.len(), 16, "the box's outline: 5 + 5 + 3 x 2 pixels");
        assert!(ink.contains(&(0, 1)) && ink.contains(&(4, 5)) && !ink.contains(&(2, 3)));
    }
}
