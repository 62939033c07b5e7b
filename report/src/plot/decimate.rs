//! Streaming decimation of long series, so the files of a plot stay small whatever the
//! number of ticks while spikes survive.

/// Points kept per series of a time-series plot (as min/max pairs of half as many buckets).
pub const MAX_POINTS: usize = 3000;

/// Streaming decimation: keeps the first, minimum, maximum and last point of each bucket of
/// `bucket` consecutive samples (in time order), so peaks survive.
#[derive(Clone, Debug, Default)]
pub struct Decimator {
    /// Samples per bucket (0 or 1: keep everything).
    pub bucket: u64,
    out: Vec<(f64, f64)>,
    cur: Vec<(f64, f64)>,
}

impl Decimator {
    /// A decimator keeping about `points` points of `total` samples.
    pub fn new(total: u64, points: usize) -> Self {
        Self {
            bucket: total.div_ceil((points / 4).max(1) as u64).max(1),
            ..Self::default()
        }
    }
    /// A decimator with buckets of `bucket` samples.
    pub fn with_bucket(bucket: u64) -> Self {
        Self {
            bucket,
            ..Self::default()
        }
    }
    /// Adds a sample (non-finite samples are kept: they break the line).
    pub fn push(&mut self, x: f64, y: f64) {
        self.cur.push((x, y));
        if self.cur.len() as u64 >= self.bucket.max(1) {
            self.flush();
        }
    }
    fn flush(&mut self) {
        if self.cur.is_empty() {
            return;
        }
        if self.cur.len() <= 4 {
            self.out.append(&mut self.cur);
            return;
        }
        let first = 0;
        let last = self.cur.len() - 1;
        // Extremes among the finite values; the first gap (non-finite value) is kept too,
        // so a line broken inside the bucket stays broken.
        let finite = |i: &usize| self.cur[*i].1.is_finite();
        let mut lo = (0..self.cur.len()).find(finite).unwrap_or(first);
        let mut hi = lo;
        for (i, p) in self.cur.iter().enumerate() {
            if p.1 < self.cur[lo].1 {
                lo = i;
            }
            if p.1 > self.cur[hi].1 {
                hi = i;
            }
        }
        let gap = (0..self.cur.len()).find(|i| !finite(i)).unwrap_or(first);
        let mut keep: Vec<usize> = vec![first, lo, hi, gap, last];
        keep.sort_unstable();
        keep.dedup();
        for i in keep {
            self.out.push(self.cur[i]);
        }
        self.cur.clear();
    }
    /// The points kept so far (and the pending bucket).
    pub fn points(&self) -> Vec<(f64, f64)> {
        let mut out = self.out.clone();
        out.extend_from_slice(&self.cur);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimator_keeps_peaks_and_ends() {
        let mut d = Decimator::with_bucket(100);
        for i in 0..1000 {
            let y = if i == 537 {
                50.0
            } else {
                (i as f64 * 0.01).sin()
            };
            d.push(i as f64, y);
        }
        let pts = d.points();
        assert!(pts.len() <= 40, "{} points", pts.len());
        assert!(pts.contains(&(537.0, 50.0)));
        assert_eq!(pts.first().unwrap().0, 0.0);
        assert_eq!(pts.last().unwrap().0, 999.0);
        assert!(pts.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
