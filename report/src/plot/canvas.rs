//! A pixel canvas on plotters' SVG backend: the primitives the panel charts ([`super::chart`])
//! and the contact timeline are drawn with (lines, dashed lines, polylines, rectangles,
//! polygons, dots and text), in pixel coordinates (origin top left, y down).
//!
//! Colours are `#rrggbb` strings of [`super::style`]. Text is written as SVG `<text>` (no font
//! files); `_{sub}` and `^{sup}` in a label become Unicode sub- and superscripts where Unicode
//! has them (plotters writes plain text). Output is deterministic: same calls, same bytes.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{draw_err, style, PlotError};

/// The font family of every text of the charts.
pub const FONT: &str = "sans-serif";

/// A dash pattern: (dash, gap), px.
pub type Dash = (u32, u32);

/// Where a text sits relative to its point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// Starts at the point.
    Start,
    /// Centred on the point.
    Middle,
    /// Ends at the point.
    End,
}

/// How a text is drawn.
#[derive(Clone, Copy, Debug)]
pub struct TextOpts {
    /// Font size, px (the SVG `font-size`).
    pub size: f64,
    /// `#rrggbb`.
    pub colour: &'static str,
    /// Horizontal anchor.
    pub anchor: Anchor,
    /// Bold.
    pub bold: bool,
    /// Italic.
    pub italic: bool,
    /// Rotated a quarter turn counter-clockwise (reads bottom to top).
    pub vertical: bool,
}

impl TextOpts {
    /// Black, upright, starting at the point.
    pub const fn new(size: f64) -> Self {
        Self {
            size,
            colour: "#000000",
            anchor: Anchor::Start,
            bold: false,
            italic: false,
            vertical: false,
        }
    }
    /// With the anchor `a`.
    pub const fn anchor(mut self, a: Anchor) -> Self {
        self.anchor = a;
        self
    }
    /// In colour `c` (`#rrggbb`).
    pub const fn colour(mut self, c: &'static str) -> Self {
        self.colour = c;
        self
    }
    /// Bold.
    pub const fn bold(mut self) -> Self {
        self.bold = true;
        self
    }
    /// Italic.
    pub const fn italic(mut self) -> Self {
        self.italic = true;
        self
    }
    /// Rotated to read bottom to top.
    pub const fn vertical(mut self) -> Self {
        self.vertical = true;
        self
    }
}

/// `#rrggbb` as a plotters colour.
pub fn colour(hex: &str) -> RGBColor {
    let (r, g, b) = style::rgb(hex);
    RGBColor(r, g, b)
}

fn px((x, y): (f64, f64)) -> (i32, i32) {
    (x.round() as i32, y.round() as i32)
}

/// A drawing surface of `width` × `height` px.
pub struct Canvas<'a> {
    area: DrawingArea<SVGBackend<'a>, Shift>,
}

/// Renders an SVG document of `size` px (white background) drawn by `draw`.
pub fn render(
    size: (f64, f64),
    draw: impl FnOnce(&Canvas<'_>) -> Result<(), PlotError>,
) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let dims = (size.0.ceil() as u32, size.1.ceil() as u32);
        let area = SVGBackend::with_string(&mut svg, dims).into_drawing_area();
        area.fill(&WHITE).map_err(draw_err)?;
        let canvas = Canvas { area };
        draw(&canvas)?;
        canvas.area.present().map_err(draw_err)?;
    }
    Ok(svg)
}

impl Canvas<'_> {
    /// A straight line from `a` to `b`.
    pub fn line(
        &self,
        a: (f64, f64),
        b: (f64, f64),
        colour_hex: &str,
        width: u32,
        dash: Option<Dash>,
    ) -> Result<(), PlotError> {
        self.polyline(&[a, b], colour_hex, width, dash)
    }

    /// A polyline through `points` (at least two).
    pub fn polyline(
        &self,
        points: &[(f64, f64)],
        colour_hex: &str,
        width: u32,
        dash: Option<Dash>,
    ) -> Result<(), PlotError> {
        let st = colour(colour_hex).stroke_width(width);
        let pts: Vec<(i32, i32)> = points.iter().map(|&p| px(p)).collect();
        match dash {
            None => self.area.draw(&PathElement::new(pts, st)),
            Some((on, off)) => self.area.draw(&DashedPathElement::new(pts, on, off, st)),
        }
        .map_err(draw_err)
    }

    /// A rectangle at `(x, y)` (top left) of `w` × `h` px, filled with `fill` at `opacity`.
    pub fn rect(
        &self,
        (x, y): (f64, f64),
        (w, h): (f64, f64),
        fill: &str,
        opacity: f64,
    ) -> Result<(), PlotError> {
        let st = colour(fill).mix(opacity).filled();
        self.area
            .draw(&Rectangle::new([px((x, y)), px((x + w, y + h))], st))
            .map_err(draw_err)
    }

    /// The outline of a rectangle at `(x, y)` (top left) of `w` × `h` px.
    pub fn frame(
        &self,
        (x, y): (f64, f64),
        (w, h): (f64, f64),
        stroke: &str,
    ) -> Result<(), PlotError> {
        self.area
            .draw(&Rectangle::new(
                [px((x, y)), px((x + w, y + h))],
                colour(stroke),
            ))
            .map_err(draw_err)
    }

    /// A filled polygon through `points`.
    pub fn polygon(&self, points: &[(f64, f64)], fill: &str) -> Result<(), PlotError> {
        let pts: Vec<(i32, i32)> = points.iter().map(|&p| px(p)).collect();
        self.area
            .draw(&Polygon::new(pts, colour(fill).filled()))
            .map_err(draw_err)
    }

    /// A filled dot of radius `r` px at `c`.
    pub fn dot(&self, c: (f64, f64), r: u32, fill: &str) -> Result<(), PlotError> {
        self.area
            .draw(&Circle::new(px(c), r, colour(fill).filled()))
            .map_err(draw_err)
    }

    /// `text` with its baseline at `at` (`_{sub}`, `^{sup}` as in [`rich`]).
    pub fn text(&self, at: (f64, f64), text: &str, o: TextOpts) -> Result<(), PlotError> {
        let font_style = match (o.bold, o.italic) {
            (true, _) => FontStyle::Bold,
            (false, true) => FontStyle::Italic,
            _ => FontStyle::Normal,
        };
        let h = match o.anchor {
            Anchor::Start => HPos::Left,
            Anchor::Middle => HPos::Center,
            Anchor::End => HPos::Right,
        };
        // plotters places a text by its middle (`dy = 0.5ex`); the baseline lies ~0.27 em
        // below it.
        let shift = 0.27 * o.size;
        let (at, transform) = if o.vertical {
            ((at.0 - shift, at.1), FontTransform::Rotate270)
        } else {
            ((at.0, at.1 - shift), FontTransform::None)
        };
        let fill = colour(o.colour);
        let ts = TextStyle::from((FONT, o.size * 1.24).into_font().style(font_style))
            .color(&fill)
            .pos(Pos::new(h, VPos::Center))
            .transform(transform);
        self.area
            .draw(&Text::new(rich(text), px(at), ts))
            .map_err(draw_err)
    }
}

/// `_{…}` and `^{…}` turned into Unicode sub- and superscripts; a group with a character
/// Unicode has no sub- or superscript for keeps its marker (`V_{U}` reads `V_U`).
pub fn rich(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find(['_', '^']) {
        let (before, after) = rest.split_at(i);
        let close = after.find('}');
        let (Some(close), true) = (close, after[1..].starts_with('{')) else {
            out.push_str(&rest[..i + 1]);
            rest = &rest[i + 1..];
            continue;
        };
        out.push_str(before);
        let inner = &after[2..close];
        let table = if after.starts_with('_') { sub } else { sup };
        match inner.chars().map(table).collect::<Option<String>>() {
            Some(mapped) => out.push_str(&mapped),
            None => {
                out.push_str(&after[..1]);
                out.push_str(inner);
            }
        }
        rest = &after[close + 1..];
    }
    out.push_str(rest);
    out
}

fn sub(c: char) -> Option<char> {
    const FROM: &str = "0123456789+-=()aehijklmnoprstuvx";
    const TO: &str = "₀₁₂₃₄₅₆₇₈₉₊₋₌₍₎ₐₑₕᵢⱼₖₗₘₙₒₚᵣₛₜᵤᵥₓ";
    FROM.chars()
        .position(|f| f == c)
        .and_then(|i| TO.chars().nth(i))
}

fn sup(c: char) -> Option<char> {
    const FROM: &str = "0123456789+-=()in";
    const TO: &str = "⁰¹²³⁴⁵⁶⁷⁸⁹⁺⁻⁼⁽⁾ⁱⁿ";
    FROM.chars()
        .position(|f| f == c)
        .and_then(|i| TO.chars().nth(i))
}

/// Approximate rendered width of `s` at font size `size`, px.
pub fn text_width(s: &str, size: f64) -> f64 {
    rich(s).chars().count() as f64 * size * 0.58
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rich_text_maps_what_unicode_has_and_keeps_the_rest() {
        assert_eq!(rich("10^{-3}"), "10⁻³");
        assert_eq!(rich("‖∇T_{est}‖"), "‖∇Tₑₛₜ‖");
        assert_eq!(rich("V/V_{U}"), "V/V_U");
        assert_eq!(rich("a_b"), "a_b");
        assert_eq!(rich("plain"), "plain");
    }

    #[test]
    fn canvas_draws_deterministic_svg_with_escaped_text() {
        let draw = |c: &Canvas<'_>| {
            c.line((0.0, 0.0), (10.0, 10.0), "#ff0000", 1, Some((5, 3)))?;
            c.rect((1.0, 1.0), (5.0, 5.0), "#00ff00", 0.5)?;
            c.text((5.0, 20.0), "a < b", TextOpts::new(13.0).bold())
        };
        let a = render((40.0, 30.0), draw).unwrap();
        let b = render((40.0, 30.0), draw).unwrap();
        assert_eq!(a, b);
        assert!(a.starts_with("<svg"), "{a}");
        assert!(a.contains("a &lt; b"), "{a}");
        assert!(a.contains(r#"font-size="13"#), "{a}");
        assert!(a.contains("#FF0000") || a.contains("#ff0000"), "{a}");
    }
}
