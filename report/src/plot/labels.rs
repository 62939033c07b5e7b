//! Labels on the mission plot that avoid each other and the marks.

use super::*;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum LabelSide {
    /// Centred above the anchor or below this y (px), moving away when taken, then around
    /// the anchor.
    AboveOrBelow(i32),
    /// Any of the four diagonal positions, then further out.
    Around,
}

/// Greedy placement of text labels (boxes in backend pixels) inside a region.
pub(super) struct LabelPlacer {
    pub(super) region: (i32, i32, i32, i32),
    pub(super) taken: Vec<(i32, i32, i32, i32)>,
}

impl LabelPlacer {
    pub(super) fn new((xr, yr): (std::ops::Range<i32>, std::ops::Range<i32>)) -> Self {
        Self {
            region: (xr.start, yr.start, xr.end, yr.end),
            taken: Vec::new(),
        }
    }

    pub(super) fn block(&mut self, b: (i32, i32, i32, i32)) {
        self.taken.push(b);
    }

    pub(super) fn overlap(&self, b: (i32, i32, i32, i32)) -> i64 {
        let r = self.region;
        let outside = i64::from(b.0 < r.0 || b.1 < r.1 || b.2 > r.2 || b.3 > r.3) * 1_000_000;
        outside
            + self
                .taken
                .iter()
                .map(|t| {
                    let w = (b.2.min(t.2) - b.0.max(t.0)).max(0);
                    let h = (b.3.min(t.3) - b.1.max(t.1)).max(0);
                    i64::from(w) * i64::from(h)
                })
                .sum::<i64>()
    }

    /// Draws `text` (font size `size` px) on a white box near `anchor`, at the first free spot.
    pub(super) fn place_label(
        &mut self,
        area: &DrawingArea<SVGBackend<'_>, Shift>,
        text: &str,
        anchor: (i32, i32),
        size: f64,
        side: LabelSide,
    ) -> Result<(), PlotError> {
        let w = (text.chars().count() as f64 * 0.56 * size).ceil() as i32 + 8;
        let h = (size * 1.4).ceil() as i32;
        let (ax, ay) = anchor;
        let mut candidates: Vec<(i32, i32)> = Vec::new(); // top-left corners
        for step in 0..8 {
            match side {
                LabelSide::AboveOrBelow(below) => candidates.extend([
                    (ax - w / 2, ay - h - step * (h + 2)),
                    (ax - w / 2, below + step * (h + 2)),
                ]),
                LabelSide::Around => {
                    let d = 8 + step * (h + 2);
                    candidates.extend([
                        (ax + 8, ay - d - h + 4),
                        (ax + 8, ay + d - 4),
                        (ax - 8 - w, ay - d - h + 4),
                        (ax - 8 - w, ay + d - 4),
                    ]);
                }
            }
        }
        // Slid sideways into the region where it is too wide for where it was.
        let (left, right) = (self.region.0, self.region.2 - w);
        for c in &mut candidates {
            if right >= left {
                c.0 = c.0.clamp(left, right);
            }
        }
        let mut best = candidates[0];
        let mut best_cost = i64::MAX;
        for &(x, y) in &candidates {
            let cost = self.overlap((x, y, x + w, y + h));
            if cost < best_cost {
                best_cost = cost;
                best = (x, y);
            }
            if cost == 0 {
                break;
            }
        }
        let (x, y) = best;
        self.taken.push((x, y, x + w, y + h));
        area.draw(&Rectangle::new(
            [(x, y), (x + w, y + h)],
            WHITE.mix(0.8).filled(),
        ))
        .map_err(draw_err)?;
        area.draw(&Text::new(
            text.to_string(),
            (x + 4, y + h / 2),
            font(size).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)
    }
}
