//! The side column of the mission plot: the colour bar of the field and the legend.

use super::*;

/// The side panel of the mission plot: colour bar on top, legend below.
pub(super) fn draw_mission_side(
    side: &DrawingArea<SVGBackend<'_>, Shift>,
    plot: &MissionPlot<'_>,
    levels: Option<&Levels>,
    has_no_data: bool,
) -> Result<(), PlotError> {
    let (_, h) = side.dim_in_pixel();
    let h = h as i32;
    let left = 20;
    let mut y = 25;
    side.draw(&Text::new(
        plot.field_label.clone(),
        (left, y),
        font(16.0).pos(Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(draw_err)?;
    y += 22;
    let bar = Bar {
        left,
        top: y,
        w: 26,
        h: 340,
    };
    match levels {
        Some(l) => draw_colour_bar(side, &bar, l)?,
        None => {
            side.draw(&Text::new(
                "(no finite field values)",
                (left, y + 10),
                font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(draw_err)?;
        }
    }
    y += bar.h + 20;
    if has_no_data {
        side.draw(&Rectangle::new(
            [(left, y - 7), (left + bar.w, y + 7)],
            NO_DATA.filled(),
        ))
        .map_err(draw_err)?;
        side.draw(&Text::new(
            "no data",
            (left + bar.w + 9, y),
            font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
        y += 24;
    }
    y += 16;
    draw_legend(side, &legend_entries(plot), y, h - 10)
}

/// Where the colour bar goes in the side panel, pixels.
struct Bar {
    left: i32,
    top: i32,
    w: i32,
    h: i32,
}

/// The colour bar of the field's levels `l`, its edges labelled.
fn draw_colour_bar(
    side: &DrawingArea<SVGBackend<'_>, Shift>,
    bar: &Bar,
    l: &Levels,
) -> Result<(), PlotError> {
    let (left, y, bar_w, bar_h) = (bar.left, bar.top, bar.w, bar.h);
    let band_h = f64::from(bar_h) / l.n as f64;
    let y_of = |k: usize| y + bar_h - (k as f64 * band_h).round() as i32;
    for k in 0..l.n {
        side.draw(&Rectangle::new(
            [(left, y_of(k + 1)), (left + bar_w, y_of(k))],
            l.colour(k).filled(),
        ))
        .map_err(draw_err)?;
    }
    side.draw(&Rectangle::new(
        [(left, y), (left + bar_w, y + bar_h)],
        BLACK.stroke_width(1),
    ))
    .map_err(draw_err)?;
    // Label every edge when there is room, else every other one.
    let every = if band_h >= 20.0 { 1 } else { 2 };
    for k in (0..=l.n).filter(|k| k % every == 0 || *k == l.n) {
        if k == l.n && k % every != 0 {
            continue;
        }
        let yk = y_of(k);
        side.draw(&PathElement::new(
            vec![(left + bar_w, yk), (left + bar_w + 5, yk)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;
        side.draw(&Text::new(
            fmt_level(l.edge(k), l.step),
            (left + bar_w + 9, yk),
            font(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}

/// The legend's entries: what the mission plot draws.
fn legend_entries(plot: &MissionPlot<'_>) -> Vec<(LegendSymbol, String)> {
    let mut entries: Vec<(LegendSymbol, String)> = plot
        .tracks
        .iter()
        .map(|t| {
            (
                LegendSymbol::Track(track_colour(t.id)),
                format!("vehicle {}", t.id),
            )
        })
        .collect();
    if !plot.tracks.is_empty() {
        entries.push((LegendSymbol::StartEnd, "start / end".into()));
    }
    if plot.body_path.len() >= 2 {
        entries.push((LegendSymbol::DashedLine(BLACK), "virtual body".into()));
    }
    if plot.snapshots.iter().any(|s| s.label.is_empty()) {
        entries.push((LegendSymbol::Formation(SNAPSHOT), "formation".into()));
    }
    if plot.snapshots.iter().any(|s| !s.label.is_empty()) {
        entries.push((
            LegendSymbol::Formation(EVENT_SNAPSHOT),
            "formation at an event".into(),
        ));
    }
    if plot.optimum.is_some() {
        entries.push((LegendSymbol::Star, "optimum".into()));
    }
    if !plot.events.is_empty() {
        entries.push((LegendSymbol::Cross, "event".into()));
    }
    entries
}

#[derive(Debug, Clone, Copy)]
pub(super) enum LegendSymbol {
    Track(RGBColor),
    DashedLine(RGBColor),
    StartEnd,
    Formation(RGBColor),
    Star,
    Cross,
}

/// Legend rows from `top` to `bottom` (panel pixels): one column, or two when the rows do not
/// fit; entries that still do not fit are summarised as "+N more".
pub(super) fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[(LegendSymbol, String)],
    top: i32,
    bottom: i32,
) -> Result<(), PlotError> {
    const ROW: i32 = 24;
    let (w, _) = area.dim_in_pixel();
    let rows = ((bottom - top) / ROW).max(1) as usize;
    let cols = if entries.len() > rows { 2 } else { 1 };
    let col_w = (w as i32 - 20) / cols as i32;
    let capacity = rows * cols;
    let shown = if entries.len() > capacity {
        capacity - 1
    } else {
        entries.len()
    };
    for (k, (symbol, label)) in entries.iter().take(shown).enumerate() {
        let (col, row) = (k / rows, k % rows);
        let x = 20 + col as i32 * col_w;
        let y = top + row as i32 * ROW + ROW / 2;
        draw_symbol(area, *symbol, (x, y))?;
        area.draw(&Text::new(
            label.clone(),
            (x + 46, y),
            font(15.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    if shown < entries.len() {
        let k = shown;
        let (col, row) = (k / rows, k % rows);
        area.draw(&Text::new(
            format!("+{} more", entries.len() - shown),
            (
                20 + col as i32 * col_w + 46,
                top + row as i32 * ROW + ROW / 2,
            ),
            font(15.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}

pub(super) fn draw_symbol(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    symbol: LegendSymbol,
    (x, y): (i32, i32),
) -> Result<(), PlotError> {
    let seg = vec![(x, y), (x + 34, y)];
    match symbol {
        LegendSymbol::Track(c) => {
            area.draw(&PathElement::new(seg, c.stroke_width(2)))
                .map_err(draw_err)?;
            area.draw(&Circle::new((x + 34, y), 5, c.filled()))
                .map_err(draw_err)
        }
        LegendSymbol::DashedLine(c) => {
            let w = if c == BLACK { 3 } else { 1 };
            for k in 0..3 {
                let x0 = x + k * 13;
                area.draw(&PathElement::new(
                    vec![(x0, y), ((x0 + 8).min(x + 34), y)],
                    c.stroke_width(w),
                ))
                .map_err(draw_err)?;
            }
            Ok(())
        }
        LegendSymbol::StartEnd => {
            let grey = RGBColor(0x55, 0x55, 0x55);
            area.draw(&Circle::new((x + 6, y), 4, grey.stroke_width(2)))
                .map_err(draw_err)?;
            area.draw(&Circle::new((x + 27, y), 5, grey.filled()))
                .map_err(draw_err)
        }
        LegendSymbol::Formation(colour) => {
            let pts = vec![
                (x + 4, y + 7),
                (x + 17, y - 8),
                (x + 30, y + 7),
                (x + 4, y + 7),
            ];
            area.draw(&PathElement::new(pts.clone(), colour.stroke_width(2)))
                .map_err(draw_err)?;
            for p in &pts[..3] {
                area.draw(&Circle::new(*p, 3, colour.filled()))
                    .map_err(draw_err)?;
            }
            Ok(())
        }
        LegendSymbol::Star => {
            area.draw(&star((x + 17, y), 10.0, 4.0, RED_STAR.filled()))
                .map_err(draw_err)?;
            area.draw(&star_outline((x + 17, y), 10.0, 4.0, BLACK.stroke_width(2)))
                .map_err(draw_err)
        }
        LegendSymbol::Cross => draw_cross(area, (x + 17, y), 6),
    }
}
