//! The table of a campaign: pass rate overall and by law, by each dimension of the space
//! (binned), failures by criterion, the validator's redraws, and the failures themselves.
//! Made from the result lines alone (no wall time), so a resumed campaign gives the same.

use std::collections::BTreeMap;
use std::fmt::Write;

use serde::Serialize;

use crate::judge::CRITERIA;
use crate::results::{flight_name, Dims, FlightResult, Plan};

/// Flights and passes of one bin (overall, and per law in plan order).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Cell {
    pub flights: usize,
    pub passed: usize,
}

impl Cell {
    fn add(&mut self, pass: bool) {
        self.flights += 1;
        self.passed += usize::from(pass);
    }
    /// "passed/flights (rate %)", or "-" when empty.
    pub fn text(&self) -> String {
        if self.flights == 0 {
            "-".into()
        } else {
            format!(
                "{}/{} ({:.0}%)",
                self.passed,
                self.flights,
                100.0 * self.passed as f64 / self.flights as f64
            )
        }
    }
}

/// One bin of a dimension.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// The bin's label.
    pub bin: String,
    /// All laws together.
    pub all: Cell,
    /// Per law, in the plan's law order.
    pub by_law: Vec<Cell>,
}

/// One failure, for the list.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Failure {
    pub flight: String,
    pub failed: Vec<String>,
    pub verdict: String,
    pub why: String,
    pub file: Option<String>,
    pub shrunk: Option<String>,
    pub shrunk_steps: Vec<String>,
}

/// The table (`stress.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Table {
    pub missions: u64,
    pub seed: u64,
    pub laws: Vec<String>,
    pub v_bound: f64,
    pub sets: Vec<String>,
    /// Every flight.
    pub overall: Cell,
    /// Per law, in plan order.
    pub by_law: Vec<Cell>,
    /// Per dimension: its name and its bins.
    pub dimensions: Vec<(String, Vec<Row>)>,
    /// Failed flights by criterion (a flight may fail several).
    pub failures_by_criterion: BTreeMap<String, usize>,
    /// Invalid draws redrawn, by the validator's key.
    pub redraws: BTreeMap<String, usize>,
    /// The failures.
    pub failures: Vec<Failure>,
}

fn yes_no(b: bool) -> String {
    if b { "yes" } else { "no" }.into()
}

fn bin(x: f64, edges: &[(f64, &str)], last: &str) -> String {
    edges
        .iter()
        .find(|(e, _)| x < *e)
        .map_or(last, |(_, l)| l)
        .to_string()
}

/// The order of a bin: by its leading number (`3-4` before `9-16`, `0` before
/// `0.01-0.05`), then by its label.
fn bin_order(label: &str) -> (u64, String) {
    let lead: String = label
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    let n = lead.parse::<f64>().map_or(u64::MAX, |x| (x * 1e6) as u64);
    (n, label.to_string())
}

/// The dimensions of the table, each with its binning of a flight.
#[allow(clippy::type_complexity)]
pub fn dimensions() -> Vec<(&'static str, Box<dyn Fn(&Dims) -> String>)> {
    vec![
        (
            "vehicles N",
            Box::new(|d: &Dims| bin(d.n as f64, &[(5.0, "3-4"), (9.0, "5-8")], "9-16")),
        ),
        ("dim", Box::new(|d: &Dims| d.dim.to_string())),
        ("field", Box::new(|d: &Dims| d.field.clone())),
        (
            "noise σ/range",
            Box::new(|d: &Dims| {
                bin(
                    d.noise_fraction,
                    &[(0.03, "0.01-0.03"), (0.1, "0.03-0.1")],
                    "0.1-0.3",
                )
            }),
        ),
        (
            "delay, s",
            Box::new(|d: &Dims| {
                bin(
                    d.delay,
                    &[(1e-12, "0"), (0.25, "0.05-0.25"), (1.0, "0.25-1")],
                    "1-2",
                )
            }),
        ),
        ("jitter", Box::new(|d: &Dims| yes_no(d.jitter > 0.0))),
        (
            "loss",
            Box::new(|d: &Dims| {
                bin(
                    d.loss,
                    &[(1e-12, "0"), (0.05, "0.01-0.05"), (0.1, "0.05-0.1")],
                    "0.1-0.3",
                )
            }),
        ),
        ("bursty", Box::new(|d: &Dims| yes_no(d.bursty))),
        ("surfacing", Box::new(|d: &Dims| yes_no(d.surfacing))),
        ("Iridium sessions", Box::new(|d: &Dims| yes_no(d.iridium))),
        ("acoustic modems", Box::new(|d: &Dims| yes_no(d.acoustic))),
        (
            "links",
            Box::new(|d: &Dims| {
                if d.is_ideal_links() {
                    "ideal".to_string()
                } else {
                    "impaired".to_string()
                }
            }),
        ),
        ("faults", Box::new(|d: &Dims| d.faults.to_string())),
        ("adapt", Box::new(|d: &Dims| yes_no(d.adapt))),
        ("glider", Box::new(|d: &Dims| yes_no(d.glider))),
        ("current", Box::new(|d: &Dims| yes_no(d.current))),
        (
            "v0, L/s",
            Box::new(|d: &Dims| bin(d.v0, &[(0.4, "0.2-0.4"), (0.7, "0.4-0.7")], "0.7-1")),
        ),
        (
            "alpha, L²/s²",
            Box::new(|d: &Dims| bin(d.alpha, &[(50.0, "20-50"), (100.0, "50-100")], "100-150")),
        ),
        (
            "damping, 1/s",
            Box::new(|d: &Dims| bin(d.damping, &[(4.5, "2-4.5")], "4.5-10")),
        ),
        (
            "radius ÷ spacing-preserving",
            Box::new(|d: &Dims| {
                bin(
                    d.radius_factor,
                    &[(0.8, "0.5-0.8"), (1.2, "0.8-1.2")],
                    "1.2-1.5",
                )
            }),
        ),
        (
            "min_scale (adaptation on)",
            Box::new(|d: &Dims| {
                if d.adapt {
                    bin(d.min_scale, &[(0.3, "0.15-0.3")], "0.3-0.7")
                } else {
                    "off".to_string()
                }
            }),
        ),
    ]
}

impl Table {
    /// The table of `results` (ordered by flight) of the campaign `plan`.
    pub fn of(plan: &Plan, results: &[FlightResult], redraws: BTreeMap<String, usize>) -> Table {
        let laws = plan.laws.clone();
        let law_index = |l: &str| laws.iter().position(|x| x == l);
        let mut overall = Cell::default();
        let mut by_law = vec![Cell::default(); laws.len()];
        let mut failures_by_criterion = BTreeMap::new();
        for c in CRITERIA {
            failures_by_criterion.insert(c.to_string(), 0);
        }
        let mut failures = Vec::new();
        for r in results {
            overall.add(r.pass);
            if let Some(i) = law_index(&r.law) {
                by_law[i].add(r.pass);
            }
            for c in &r.judgement.failed {
                *failures_by_criterion.entry(c.clone()).or_default() += 1;
            }
            if !r.pass {
                failures.push(Failure {
                    flight: flight_name(r.mission, &r.law),
                    failed: r.judgement.failed.clone(),
                    verdict: r.judgement.verdict.clone(),
                    why: r.judgement.why.clone(),
                    file: r.file.clone(),
                    shrunk: r.shrunk.as_ref().map(|s| s.file.clone()),
                    shrunk_steps: r.shrunk.as_ref().map_or(Vec::new(), |s| s.steps.clone()),
                });
            }
        }
        let mut dims = Vec::new();
        for (name, f) in dimensions() {
            let mut rows: BTreeMap<String, Row> = BTreeMap::new();
            for r in results {
                let row = rows.entry(f(&r.dims)).or_insert_with_key(|k| Row {
                    bin: k.clone(),
                    all: Cell::default(),
                    by_law: vec![Cell::default(); laws.len()],
                });
                row.all.add(r.pass);
                if let Some(i) = law_index(&r.law) {
                    row.by_law[i].add(r.pass);
                }
            }
            let mut rows: Vec<Row> = rows.into_values().collect();
            rows.sort_by_key(|r| bin_order(&r.bin));
            dims.push((name.to_string(), rows));
        }
        Table {
            missions: plan.missions,
            seed: plan.seed,
            laws,
            v_bound: plan.v_bound,
            sets: plan.sets.clone(),
            overall,
            by_law,
            dimensions: dims,
            failures_by_criterion,
            redraws,
            failures,
        }
    }

    /// The campaign's `--set`s joined as `A=1 --set B=2` (None without any).
    fn sets_joined(&self) -> Option<String> {
        (!self.sets.is_empty()).then(|| self.sets.join(" --set "))
    }

    /// The table as plain text (what `vbap stress` prints).
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "stress: {} missions, seed {}, laws {}, V bound {} V_U{}",
            self.missions,
            self.seed,
            self.laws.join(", "),
            self.v_bound,
            self.sets_joined()
                .map_or(String::new(), |j| format!(", --set {j}"))
        );
        let _ = writeln!(s, "pass overall: {}", self.overall.text());
        for (l, c) in self.laws.iter().zip(&self.by_law) {
            let _ = writeln!(s, "pass {l}: {}", c.text());
        }
        let width = 16;
        let _ = write!(s, "\n{:<24}{:<width$}", "dimension / bin", "all");
        for l in &self.laws {
            let _ = write!(s, "{l:<width$}");
        }
        let _ = writeln!(s);
        for (name, rows) in &self.dimensions {
            let _ = writeln!(s, "{name}");
            for r in rows {
                let _ = write!(s, "  {:<22}{:<width$}", r.bin, r.all.text());
                for c in &r.by_law {
                    let _ = write!(s, "{:<width$}", c.text());
                }
                let _ = writeln!(s);
            }
        }
        let _ = writeln!(s, "\nfailures by criterion:");
        for (c, n) in &self.failures_by_criterion {
            let _ = writeln!(s, "  {c:<18}{n}");
        }
        let _ = writeln!(s, "invalid draws redrawn, by the validator's key:");
        if self.redraws.is_empty() {
            let _ = writeln!(s, "  none");
        }
        for (k, n) in &self.redraws {
            let _ = writeln!(s, "  {k:<28}{n}");
        }
        if !self.failures.is_empty() {
            let _ = writeln!(s, "failures ({}):", self.failures.len());
            for f in &self.failures {
                let _ = writeln!(
                    s,
                    "  {} [{}] {}{}",
                    f.flight,
                    f.failed.join(","),
                    f.why,
                    f.shrunk
                        .as_ref()
                        .map_or(String::new(), |p| format!(" -> {p}"))
                );
            }
        }
        s
    }

    /// The table as Markdown (`stress.md`).
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# vbap stress: {} missions, seed {}\n\nLaws {}; V bound {} V_U{}.\n",
            self.missions,
            self.seed,
            self.laws.join(", "),
            self.v_bound,
            self.sets_joined()
                .map_or(String::new(), |j| format!("; `--set {j}`"))
        );
        let _ = writeln!(s, "| | pass |\n|---|---|");
        let _ = writeln!(s, "| overall | {} |", self.overall.text());
        for (l, c) in self.laws.iter().zip(&self.by_law) {
            let _ = writeln!(s, "| {l} | {} |", c.text());
        }
        let _ = write!(s, "\n| dimension | bin | all |");
        for l in &self.laws {
            let _ = write!(s, " {l} |");
        }
        let _ = write!(s, "\n|---|---|---|");
        for _ in &self.laws {
            let _ = write!(s, "---|");
        }
        let _ = writeln!(s);
        for (name, rows) in &self.dimensions {
            for r in rows {
                let _ = write!(s, "| {name} | {} | {} |", r.bin, r.all.text());
                for c in &r.by_law {
                    let _ = write!(s, " {} |", c.text());
                }
                let _ = writeln!(s);
            }
        }
        let _ = writeln!(s, "\n| criterion | failed flights |\n|---|---|");
        for (c, n) in &self.failures_by_criterion {
            let _ = writeln!(s, "| {c} | {n} |");
        }
        let _ = writeln!(s, "\n| redrawn for key | draws |\n|---|---|");
        for (k, n) in &self.redraws {
            let _ = writeln!(s, "| `{k}` | {n} |");
        }
        if !self.failures.is_empty() {
            let _ = writeln!(
                s,
                "\n| flight | failed | why | file | shrunk |\n|---|---|---|---|---|"
            );
            for f in &self.failures {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} |",
                    f.flight,
                    f.failed.join(", "),
                    f.why.replace('|', "/"),
                    f.file.as_deref().unwrap_or("-"),
                    f.shrunk.as_deref().map_or("-".to_string(), |p| format!(
                        "{p} ({})",
                        f.shrunk_steps.join(", ")
                    ))
                );
            }
        }
        s
    }
}
