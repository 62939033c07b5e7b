//! Simple time-series plots (plotters' own chart).

use super::*;

/// Renders a time-series plot and writes it to `path`.
///
/// `series`: (legend label, points (x, y)) drawn as lines in palette order; `markers`: vertical
/// dashed lines at x with a short label (events). Markers outside the data's x range are not
/// drawn.
pub fn write_timeseries_svg(
    path: &Path,
    title: &str,
    x_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    y_label: &str,
    markers: &[(f64, String)],
) -> Result<(), PlotError> {
    let svg = render_timeseries_svg(title, x_label, series, y_label, markers)?;
    write_file(path, &svg)
}

/// Renders a time-series plot to an SVG document (see [`write_timeseries_svg`]).
pub fn render_timeseries_svg(
    title: &str,
    x_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    y_label: &str,
    markers: &[(f64, String)],
) -> Result<String, PlotError> {
    let mut x_range: Option<(f64, f64)> = None;
    let mut y_range: Option<(f64, f64)> = None;
    for (name, pts) in series {
        for (i, &(x, y)) in pts.iter().enumerate() {
            if !x.is_finite() || !y.is_finite() {
                return Err(PlotError::NonFinite {
                    what: format!("series '{name}'"),
                    index: i,
                });
            }
            x_range = Some(extend(x_range, x));
            y_range = Some(extend(y_range, y));
        }
    }
    for (i, (x, _)) in markers.iter().enumerate() {
        if !x.is_finite() {
            return Err(PlotError::NonFinite {
                what: "markers".into(),
                index: i,
            });
        }
    }
    let (Some((x0, x1)), Some((y0, y1))) = (x_range, y_range) else {
        return Err(PlotError::Empty("every series is empty".into()));
    };
    let (x0, x1) = widen_if_flat(x0, x1);
    let (y0, y1) = widen_if_flat(y0, y1);
    let pad = 0.05 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, TIMESERIES_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (title_area, body) = root.split_vertically(TITLE_H - 5);
        draw_title(&title_area, title)?;
        let (chart_area, side) = body.split_horizontally(TS_CHART_W);
        let mut chart = ChartBuilder::on(&chart_area)
            .margin_left(10)
            .margin_right(15)
            .margin_top(10)
            .margin_bottom(10)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .light_line_style(RGBColor(0xee, 0xee, 0xee))
            .bold_line_style(RGBColor(0xdd, 0xdd, 0xdd))
            .x_labels(10)
            .y_labels(8)
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| style::fmt_tick_span(*v, x1 - x0))
            .y_label_formatter(&|v| style::fmt_tick_span(*v, y1 - y0))
            .label_style(font(14.0))
            .axis_desc_style(font(17.0))
            .draw()
            .map_err(draw_err)?;

        let (xr, yr) = chart.plotting_area().get_pixel_range();
        let px = (
            (x1 - x0) / f64::from((xr.end - xr.start - 1).max(1)),
            (y1 - y0) / f64::from((yr.end - yr.start - 1).max(1)),
        );
        let marker_style = RGBColor(0x55, 0x55, 0x55).mix(0.8).stroke_width(1);
        for (x, _) in markers {
            if *x >= x0 && *x <= x1 {
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(*x, y0), (*x, y1)],
                        6,
                        4,
                        marker_style,
                    ))
                    .map_err(draw_err)?;
            }
        }
        for (k, (_, pts)) in series.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let pts = simplify_path(pts, px, SIMPLIFY_PX);
            if pts.len() == 1 {
                chart
                    .draw_series(std::iter::once(Circle::new(pts[0], 3, colour.filled())))
                    .map_err(draw_err)?;
            } else {
                chart
                    .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                    .map_err(draw_err)?;
            }
        }
        let mut placer = LabelPlacer::new((xr.clone(), yr.clone()));
        for (x, label) in markers {
            if *x >= x0 && *x <= x1 && !label.is_empty() {
                let c = chart.backend_coord(&(*x, y1));
                placer.place_label(&root, label, (c.0, c.1 + 4), 13.0, LabelSide::Below)?;
            }
        }
        root.draw(&Rectangle::new(
            [(xr.start, yr.start), (xr.end - 1, yr.end - 1)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)?;

        // Legend in the side panel.
        let mut entries: Vec<(LegendSymbol, String)> = series
            .iter()
            .enumerate()
            .map(|(k, (name, _))| (LegendSymbol::Line(PALETTE[k % PALETTE.len()]), name.clone()))
            .collect();
        if markers.iter().any(|(x, _)| *x >= x0 && *x <= x1) {
            entries.push((
                LegendSymbol::DashedLine(RGBColor(0x55, 0x55, 0x55)),
                "event".into(),
            ));
        }
        let (_, side_h) = side.dim_in_pixel();
        draw_legend(&side, &entries, 20, side_h as i32 - 20)?;
        root.present().map_err(draw_err)?;
    }
    Ok(svg)
}
