//! The legend column of a panel: a sample of each series, reference line and kind of event
//! marker, "… and N more" when they do not fit, then the panel's notes.

use std::collections::BTreeSet;

use super::super::canvas::{Canvas, Dash, TextOpts};
use super::super::PlotError;
use super::{Panel, PLOT_H};

/// Height of a legend row, px.
pub const LEGEND_ROW: f64 = 20.0;

/// What a legend entry shows before its text.
#[derive(Clone, Copy, Debug)]
pub enum Swatch {
    /// A horizontal line sample.
    Line {
        colour: &'static str,
        width: u32,
        dash: Option<Dash>,
    },
    /// A vertical dashed line (an event marker).
    Marker { colour: &'static str, dash: Dash },
    /// A filled box of the given height, px.
    Box { colour: &'static str, height: f64 },
}

/// Draws one legend entry whose row is centred at `(x, y)`.
pub fn entry(
    c: &Canvas<'_>,
    (x, y): (f64, f64),
    swatch: Swatch,
    label: &str,
) -> Result<(), PlotError> {
    match swatch {
        Swatch::Line {
            colour,
            width,
            dash,
        } => c.line((x, y), (x + 28.0, y), colour, width, dash)?,
        Swatch::Marker { colour, dash } => c.line(
            (x + 14.0, y - 8.0),
            (x + 14.0, y + 8.0),
            colour,
            2,
            Some(dash),
        )?,
        Swatch::Box { colour, height } => {
            c.rect((x, y - height / 2.0), (28.0, height), colour, 1.0)?
        }
    }
    c.text(
        (x + 36.0, y + 4.5),
        &shorten(label, 34),
        TextOpts::new(13.0),
    )
}

/// `label` cut to `max` characters (an ellipsis at the end).
pub fn shorten(label: &str, max: usize) -> String {
    if label.chars().count() > max {
        let mut s: String = label.chars().take(max - 1).collect();
        s.push('…');
        s
    } else {
        label.to_string()
    }
}

/// "… and N more" at a legend row.
pub fn more(c: &Canvas<'_>, (x, y): (f64, f64), n: usize) -> Result<(), PlotError> {
    c.text(
        (x, y + 4.5),
        &format!("… and {n} more"),
        TextOpts::new(13.0).colour("#555555"),
    )
}

/// The legend of panel `p` from `(x, y)` down: series, reference lines, kinds of markers
/// (when `markers`), then the notes.
pub fn draw_panel_legend(
    c: &Canvas<'_>,
    p: &Panel,
    (x, mut y): (f64, f64),
    markers: bool,
) -> Result<(), PlotError> {
    let mut entries: Vec<(Swatch, &str)> = Vec::new();
    for s in &p.series {
        let dash = s.dashed.then_some((7, 4));
        entries.push((
            Swatch::Line {
                colour: s.colour,
                width: 3,
                dash,
            },
            &s.label,
        ));
    }
    for h in &p.hlines {
        let dash = Some((8, 4));
        entries.push((
            Swatch::Line {
                colour: h.colour,
                width: 2,
                dash,
            },
            &h.label,
        ));
    }
    let mut kinds = BTreeSet::new();
    for m in p.markers.iter().filter(|_| markers) {
        if kinds.insert((m.legend.as_str(), m.colour)) {
            entries.push((
                Swatch::Marker {
                    colour: m.colour,
                    dash: (5, 3),
                },
                &m.legend,
            ));
        }
    }
    let max_entries = ((PLOT_H - 10.0) / LEGEND_ROW) as usize;
    let total = entries.len();
    for (i, (swatch, label)) in entries.into_iter().enumerate() {
        if i + 1 == max_entries && total > max_entries {
            more(c, (x, y), total - i)?;
            y += LEGEND_ROW;
            break;
        }
        entry(c, (x, y), swatch, label)?;
        y += LEGEND_ROW;
    }
    for line in p.notes.iter().flat_map(|n| wrap(n, 40)) {
        let o = TextOpts::new(12.0).colour("#555555").italic();
        c.text((x, y + 4.0), &line, o)?;
        y += 16.0;
    }
    Ok(())
}

/// Splits `text` into lines of at most `width` characters at spaces.
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut cur = String::new();
    for word in text.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}
