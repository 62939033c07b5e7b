//! The mission plot's chart: validation, the equal-aspect chart, tracks, formation
//! snapshots, the optimum star and event crosses.

use super::*;

/// Renders the mission plot and writes it to `path` (normally `<run dir>/plot.svg`).
pub fn write_mission_svg(plot: &MissionPlot<'_>, path: &Path) -> Result<(), PlotError> {
    let svg = render_mission_svg(plot)?;
    write_file(path, &svg)
}

/// Renders the mission plot to an SVG document (a `String` starting with `<svg`).
pub fn render_mission_svg(plot: &MissionPlot<'_>) -> Result<String, PlotError> {
    validate_mission(plot)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, MISSION_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (title_area, body) = root.split_vertically(TITLE_H);
        draw_title(&title_area, &plot.title)?;
        let (chart_area, side) = body.split_horizontally(MISSION_CHART_W);

        let (span_x, span_y) = mission_plot_span_px(&chart_area)?;
        let bounds = choose_bounds(plot, span_x / span_y)?;
        let mut chart = mission_chart(&chart_area, bounds)?;
        let px = (bounds.width() / span_x, bounds.height() / span_y);

        // Field: filled bands, then contour lines at the band edges.
        let (grid, levels, rects) = sampled_field(plot, bounds, span_x / span_y);
        draw_field(&mut chart, &grid, levels.as_ref(), rects, px)?;
        if let Some(current) = plot.current {
            draw_current(&mut chart, current, bounds)?;
        }
        draw_axes(&mut chart, plot, bounds)?;

        // Formation snapshots (under the tracks).
        for snap in &plot.snapshots {
            draw_snapshot(&mut chart, snap)?;
        }

        // Body path, then tracks on top.
        let body = simplify_path(&plot.body_path, px, SIMPLIFY_PX);
        if body.len() >= 2 {
            chart
                .draw_series(DashedLineSeries::new(body, 14, 7, BLACK.stroke_width(3)))
                .map_err(draw_err)?;
        }
        for track in &plot.tracks {
            draw_track(&mut chart, track, px)?;
        }

        draw_marks(&root, &chart, plot)?;
        draw_mission_side(&side, plot, levels.as_ref(), grid.has_no_data())?;
        root.present().map_err(draw_err)?;
    }
    Ok(svg)
}

/// The field sampled for its filled bands: on a fine grid, or on the coarse one when the
/// fine grid's rectangles would exceed [`FIELD_RECT_BUDGET`]; with its levels.
fn sampled_field(
    plot: &MissionPlot<'_>,
    bounds: Bounds,
    aspect: f64,
) -> (Grid, Option<Levels>, Vec<FieldRect>) {
    let fine = sample_field(plot.field, bounds, aspect, 2 * FIELD_GRID);
    let fine_levels = fine.levels();
    let fine_rects = field_rects(&fine, fine_levels.as_ref());
    if fine_rects.len() <= FIELD_RECT_BUDGET {
        (fine, fine_levels, fine_rects)
    } else {
        let g = sample_field(plot.field, bounds, aspect, FIELD_GRID);
        let l = g.levels();
        let r = field_rects(&g, l.as_ref());
        (g, l, r)
    }
}

/// The axes of the mission chart: lon/lat degrees for a geographic field, else x and y in
/// the length unit.
fn draw_axes(
    chart: &mut Chart<'_, '_>,
    plot: &MissionPlot<'_>,
    bounds: Bounds,
) -> Result<(), PlotError> {
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(9)
        .y_labels(9)
        .x_desc(match plot.geographic {
            Some(_) => "longitude (°E)".to_string(),
            None => axis_desc("x", &plot.length_unit),
        })
        .y_desc(match plot.geographic {
            Some(_) => "latitude (°N)".to_string(),
            None => axis_desc("y", &plot.length_unit),
        })
        .x_label_formatter(&|v| match plot.geographic {
            Some([lon0, lat0]) => {
                let lon = vbap_math::gridmath::equirectangular_inverse(*v, 0.0, lon0, lat0).0;
                format!("{lon:.3}")
            }
            None => style::fmt_tick_span(*v, bounds.width()),
        })
        .y_label_formatter(&|v| match plot.geographic {
            Some([lon0, lat0]) => {
                let lat = vbap_math::gridmath::equirectangular_inverse(0.0, *v, lon0, lat0).1;
                format!("{lat:.3}")
            }
            None => style::fmt_tick_span(*v, bounds.height()),
        })
        .label_style(font(14.0))
        .axis_desc_style(font(17.0))
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

/// Markers (the optimum, event crosses) and labels (formation snapshots in one time unit,
/// events), in backend pixels on the root area, placed clear of each other; then the frame
/// of the plotting area on top of everything.
fn draw_marks(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    chart: &Chart<'_, '_>,
    plot: &MissionPlot<'_>,
) -> Result<(), PlotError> {
    let time_unit =
        TimeUnit::for_span(plot.snapshots.iter().map(|s| s.t.abs()).fold(0.0, f64::max));
    let mut placer = LabelPlacer::new(chart.plotting_area().get_pixel_range());
    let to_px = |p: (f64, f64)| chart.backend_coord(&p);
    if let Some(opt) = plot.optimum {
        let c = to_px(opt);
        root.draw(&star(c, 12.0, 5.0, RED_STAR.filled()))
            .map_err(draw_err)?;
        root.draw(&star_outline(c, 12.0, 5.0, BLACK.stroke_width(2)))
            .map_err(draw_err)?;
        placer.block((c.0 - 12, c.1 - 12, c.0 + 12, c.1 + 12));
    }
    for (x, y, _) in &plot.events {
        let c = to_px((*x, *y));
        draw_cross(root, c, 6)?;
        placer.block((c.0 - 7, c.1 - 7, c.0 + 7, c.1 + 7));
    }
    for snap in &plot.snapshots {
        // Above or below the formation's core: a vehicle flung far away does not
        // carry the label off with it.
        let core = formation_core(snap);
        let ys = core.iter().map(|&p| to_px(p).1);
        let (top, bottom) = (ys.clone().min(), ys.max());
        let mut text = format!("t = {}", time_unit.fmt(snap.t));
        if !snap.label.is_empty() {
            text = format!("{text}: {}", snap.label);
        }
        let (x, y) = to_px(snap.centre);
        placer.place_label(
            root,
            &text,
            (x, top.unwrap_or(y) - 6),
            13.0,
            LabelSide::AboveOrBelow(bottom.unwrap_or(y) + 6),
        )?;
    }
    for (x, y, label) in &plot.events {
        if !label.is_empty() {
            let c = to_px((*x, *y));
            placer.place_label(root, label, c, 13.0, LabelSide::Around)?;
        }
    }
    // Frame of the plotting area on top of everything.
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    root.draw(&Rectangle::new(
        [(xr.start, yr.start), (xr.end - 1, yr.end - 1)],
        BLACK.stroke_width(1),
    ))
    .map_err(draw_err)?;
    Ok(())
}

/// Arrows of the current on a lattice of [`CURRENT_ARROWS`] columns over `bounds`, the
/// longest as long as 0.8 of a lattice cell; a label gives the longest's speed.
fn draw_current(
    chart: &mut Chart<'_, '_>,
    current: &dyn Fn(f64, f64) -> (f64, f64),
    bounds: Bounds,
) -> Result<(), PlotError> {
    let cell = bounds.width() / CURRENT_ARROWS as f64;
    let rows = (bounds.height() / cell).floor().max(1.0) as usize;
    let mut arrows = Vec::new();
    for i in 0..CURRENT_ARROWS {
        for j in 0..rows {
            let x = bounds.x_min + (i as f64 + 0.5) * cell;
            let y = bounds.y_min + (j as f64 + 0.5) * cell;
            let (u, v) = current(x, y);
            if u.is_finite() && v.is_finite() {
                arrows.push(((x, y), (u, v)));
            }
        }
    }
    let longest = arrows
        .iter()
        .map(|(_, (u, v))| u.hypot(*v))
        .fold(0.0, f64::max);
    if longest <= 0.0 {
        return Ok(());
    }
    let scale = 0.8 * cell / longest;
    let style = RGBColor(0x33, 0x33, 0x33).stroke_width(1);
    for ((x, y), (u, v)) in arrows {
        let (dx, dy) = (u * scale, v * scale);
        let tip = (x + dx / 2.0, y + dy / 2.0);
        let tail = (x - dx / 2.0, y - dy / 2.0);
        // The head: two strokes back from the tip at ±25° of a quarter of the length.
        let (c, s) = (25f64.to_radians().cos(), 25f64.to_radians().sin());
        let head = |sign: f64| {
            let (bx, by) = (-dx * 0.25, -dy * 0.25);
            (
                tip.0 + bx * c - sign * by * s,
                tip.1 + sign * bx * s + by * c,
            )
        };
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![tail, tip, head(1.0), tip, head(-1.0)],
                style,
            )))
            .map_err(draw_err)?;
    }
    let label = format!("current arrows: longest {longest:.3} length unit/s");
    chart
        .draw_series(std::iter::once(Text::new(
            label,
            (
                bounds.x_min + 0.02 * bounds.width(),
                bounds.y_min + 0.03 * bounds.height(),
            ),
            font(12.0),
        )))
        .map_err(draw_err)?;
    Ok(())
}

/// Columns of the current's arrow lattice on the mission plot.
const CURRENT_ARROWS: usize = 16;

pub(super) const RED_STAR: RGBColor = RGBColor(0xe4, 0x1a, 0x1c);

pub(super) fn validate_mission(plot: &MissionPlot<'_>) -> Result<(), PlotError> {
    let check = |what: String, pts: &mut dyn Iterator<Item = (f64, f64)>| {
        for (i, (x, y)) in pts.enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(PlotError::NonFinite { what, index: i });
            }
        }
        Ok(())
    };
    for t in &plot.tracks {
        check(
            format!("track of vehicle {}", t.id),
            &mut t.points.iter().copied(),
        )?;
    }
    check("body path".into(), &mut plot.body_path.iter().copied())?;
    for (k, s) in plot.snapshots.iter().enumerate() {
        if !s.t.is_finite() {
            return Err(PlotError::NonFinite {
                what: "snapshot times".into(),
                index: k,
            });
        }
        check(
            format!("snapshot {k}"),
            &mut s.positions.iter().copied().chain(std::iter::once(s.centre)),
        )?;
    }
    check("optimum".into(), &mut plot.optimum.into_iter())?;
    check(
        "events".into(),
        &mut plot.events.iter().map(|(x, y, _)| (*x, *y)),
    )?;
    Ok(())
}

pub(super) type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

pub(super) fn axis_desc(axis: &str, unit: &str) -> String {
    if unit.is_empty() {
        axis.to_string()
    } else {
        format!("{axis} ({unit})")
    }
}

pub(super) fn mission_chart<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>,
    b: Bounds,
) -> Result<Chart<'a, 'b>, PlotError> {
    let chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(20)
        .margin_top(10)
        .margin_bottom(10)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d(b.x_min..b.x_max, b.y_min..b.y_max)
        .map_err(draw_err)?;
    Ok(chart)
}

/// The plotting area's span in pixels (x, y) between the first and the last pixel, which is
/// what the data range maps onto.
pub(super) fn mission_plot_span_px(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
) -> Result<(f64, f64), PlotError> {
    let unit_box = Bounds {
        x_min: 0.0,
        x_max: 1.0,
        y_min: 0.0,
        y_max: 1.0,
    };
    let chart = mission_chart(area, unit_box)?;
    let a = chart.backend_coord(&(0.0, 1.0));
    let b = chart.backend_coord(&(1.0, 0.0));
    Ok((f64::from(b.0 - a.0), f64::from(b.1 - a.1)))
}

pub(super) fn draw_track(
    chart: &mut Chart<'_, '_>,
    track: &Track,
    px: (f64, f64),
) -> Result<(), PlotError> {
    let colour = track_colour(track.id);
    let pts = simplify_path(&track.points, px, SIMPLIFY_PX);
    if pts.len() >= 2 {
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts.clone(),
                WHITE.mix(0.7).stroke_width(4),
            )))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts.clone(),
                colour.stroke_width(2),
            )))
            .map_err(draw_err)?;
    }
    if let (Some(&first), Some(&last)) = (pts.first(), pts.last()) {
        chart
            .draw_series([
                Circle::new(first, 4, colour.stroke_width(2)),
                Circle::new(last, 6, WHITE.filled()),
                Circle::new(last, 5, colour.filled()),
            ])
            .map_err(draw_err)?;
    }
    Ok(())
}

pub(super) fn track_colour(id: u32) -> RGBColor {
    PALETTE[id as usize % PALETTE.len()]
}

pub(super) const SNAPSHOT: RGBColor = RGBColor(0x22, 0x22, 0x22);
/// Colour of the snapshots taken at events.
pub(super) const EVENT_SNAPSHOT: RGBColor = RGBColor(0xb2, 0x18, 0x2b);

pub(super) fn draw_snapshot(chart: &mut Chart<'_, '_>, snap: &Snapshot) -> Result<(), PlotError> {
    let colour = if snap.label.is_empty() {
        SNAPSHOT
    } else {
        EVENT_SNAPSHOT
    };
    let mut ring = angular_order(snap.centre, &snap.positions);
    if ring.len() >= 3 {
        chart
            .draw_series(std::iter::once(Polygon::new(
                ring.clone(),
                WHITE.mix(0.25).filled(),
            )))
            .map_err(draw_err)?;
    }
    if ring.len() >= 2 {
        if ring.len() >= 3 {
            ring.push(ring[0]);
        }
        chart
            .draw_series(std::iter::once(PathElement::new(
                ring.clone(),
                colour.mix(0.85).stroke_width(2),
            )))
            .map_err(draw_err)?;
    }
    chart
        .draw_series(
            snap.positions
                .iter()
                .map(|&p| Circle::new(p, 3, colour.filled())),
        )
        .map_err(draw_err)?;
    chart
        .draw_series(std::iter::once(
            EmptyElement::at(snap.centre)
                + PathElement::new(vec![(-5, 0), (5, 0)], colour.stroke_width(2))
                + PathElement::new(vec![(0, -5), (0, 5)], colour.stroke_width(2)),
        ))
        .map_err(draw_err)?;
    Ok(())
}

/// The centre and the vehicles of a snapshot not more than 3 × the median distance from it
/// (the vehicles flung far away left out).
pub(super) fn formation_core(snap: &Snapshot) -> Vec<(f64, f64)> {
    let d = |p: &(f64, f64)| (p.0 - snap.centre.0).hypot(p.1 - snap.centre.1);
    let mut dist: Vec<f64> = snap.positions.iter().map(d).collect();
    dist.sort_by(|a, b| a.total_cmp(b));
    let median = dist.get(dist.len() / 2).copied().unwrap_or(0.0);
    snap.positions
        .iter()
        .copied()
        .filter(|p| d(p) <= 3.0 * median)
        .chain(std::iter::once(snap.centre))
        .collect()
}

/// The points sorted by their angle about `centre` (atan2, from −π), ties by distance.
pub(super) fn angular_order(centre: (f64, f64), points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut keyed: Vec<(f64, f64, (f64, f64))> = points
        .iter()
        .map(|&(x, y)| {
            let (dx, dy) = (x - centre.0, y - centre.1);
            (dy.atan2(dx), dx.hypot(dy), (x, y))
        })
        .collect();
    keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    keyed.into_iter().map(|k| k.2).collect()
}

/// A five-pointed star (filled polygon) centred at `c` in backend pixels.
pub(super) fn star(c: (i32, i32), r_out: f64, r_in: f64, style: ShapeStyle) -> Polygon<(i32, i32)> {
    Polygon::new(star_points(c, r_out, r_in), style)
}

pub(super) fn star_outline(
    c: (i32, i32),
    r_out: f64,
    r_in: f64,
    style: ShapeStyle,
) -> PathElement<(i32, i32)> {
    let mut p = star_points(c, r_out, r_in);
    p.push(p[0]);
    PathElement::new(p, style)
}

pub(super) fn star_points(c: (i32, i32), r_out: f64, r_in: f64) -> Vec<(i32, i32)> {
    (0..10)
        .map(|k| {
            let r = if k % 2 == 0 { r_out } else { r_in };
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI / 5.0;
            (
                c.0 + (r * a.cos()).round() as i32,
                c.1 - (r * a.sin()).round() as i32,
            )
        })
        .collect()
}

pub(super) fn draw_cross(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    c: (i32, i32),
    r: i32,
) -> Result<(), PlotError> {
    for (style, w) in [(WHITE, 5), (BLACK, 2)] {
        area.draw(&PathElement::new(
            vec![(c.0 - r, c.1 - r), (c.0 + r, c.1 + r)],
            style.stroke_width(w),
        ))
        .map_err(draw_err)?;
        area.draw(&PathElement::new(
            vec![(c.0 - r, c.1 + r), (c.0 + r, c.1 - r)],
            style.stroke_width(w),
        ))
        .map_err(draw_err)?;
    }
    Ok(())
}
