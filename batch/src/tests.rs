use super::*;
use vbap_mission::config::MAX_NAME_LEN;

/// A mission with a `[batch]` table after `table` (TOML lines).
fn mission(table: &str) -> Result<Mission, vbap_mission::config::ConfigError> {
    let text = format!(
        "[mission]\nname = \"b\"\n[field]\ncenter = [1.0, 2.0]\namplitude = 1.0\nwidth = 2.0\n{table}"
    );
    Mission::from_toml_str(&text, "m.toml")
}

#[test]
fn the_batch_table_is_read_into_the_criteria() {
    let m = mission(
        "[batch]  # criteria\nmin_convergence_rate = 0.9 # most\nmax_final_distance = 1_000\n",
    )
    .unwrap();
    let c = Criteria::of(&m).unwrap();
    assert_eq!(c.min_convergence_rate, Some(0.9));
    assert_eq!(c.max_final_distance, Some(1000.0));
    assert_eq!(c.max_time_to_converge, None);
    assert!(!m.to_toml_string().contains("batch"));
    let none = mission("").unwrap();
    assert_eq!(Criteria::of(&none).unwrap(), Criteria::default());
}

#[test]
fn bad_batch_tables_name_the_key() {
    for (table, needle) in [
        (
            "[batch]\nmin_rate = 1\n",
            "m.toml: batch.min_rate: unknown key",
        ),
        (
            "[batch]\n[batch.sub]\nx = 1\n",
            "m.toml: batch.sub: unknown key",
        ),
        (
            "[batch]\nmin_convergence_rate = 2\n",
            "m.toml: batch.min_convergence_rate = 2: must be between 0 and 1",
        ),
        (
            "[batch]\nmax_final_distance = \"x\"\n",
            "m.toml: [batch]: invalid type: string \"x\", expected f64 in `max_final_distance`",
        ),
        (
            "[batch]\nmax_time_to_converge = nan\n",
            "m.toml: batch.max_time_to_converge = NaN: must be a finite number",
        ),
        (
            "[batch]\nmax_final_distance = -1\n",
            "m.toml: batch.max_final_distance = -1: must be >= 0",
        ),
    ] {
        let m = mission(table).unwrap();
        let e = Criteria::of(&m).unwrap_err().to_string();
        assert!(e.contains(needle), "{table:?}: {e}");
    }
    // A key given twice is no TOML.
    let e = mission("[batch]\nmax_final_distance = 1\nmax_final_distance = 2\n").unwrap_err();
    assert!(
        e.to_string()
            .contains("m.toml: line 9, column 1: invalid TOML"),
        "{e}"
    );
}

#[test]
fn seed_names_fit() {
    assert_eq!(seed_name("paper", 3), "paper_s3");
    let long = "a".repeat(32);
    let n = seed_name(&long, 12345);
    assert_eq!(n.len(), MAX_NAME_LEN);
    assert!(n.ends_with("_s12345"));
}

fn row(seed: u64, converged: bool, t: Option<f64>, d: f64) -> SeedResult {
    SeedResult {
        seed,
        converged,
        time_to_converge_s: t,
        final_distance_to_optimum: Some(d),
        final_grad_norm: Some(d),
        max_v_over_vu: Some(0.2),
        in_set_m: Some(converged),
        wall_time_s: 1.0,
        status: "ok".into(),
        run_dir: PathBuf::new(),
        ..SeedResult::default()
    }
}

#[test]
fn aggregate_and_criteria() {
    let rows = vec![
        row(1, true, Some(40.0), 0.1),
        row(2, true, Some(50.0), 0.2),
        row(3, false, None, 3.0),
        SeedResult::failed(4, "boom".into(), 0.5, PathBuf::new()),
    ];
    let ok = aggregate(&rows[..2], &Criteria::default());
    assert!(ok.passed);
    assert_eq!(ok.convergence_rate, 1.0);
    assert_eq!(ok.time_to_converge_s.p50, 40.0);
    assert_eq!(ok.time_to_converge_s.max, 50.0);
    assert_eq!(ok.time_to_converge_s.mean, 45.0);
    let c = Criteria {
        min_convergence_rate: Some(0.75),
        max_final_distance: Some(1.0),
        max_time_to_converge: Some(45.0),
    };
    let a = aggregate(&rows, &c);
    assert!(!a.passed);
    assert_eq!(a.runs, 4);
    assert_eq!(a.completed, 3);
    assert_eq!(a.convergence_rate, 0.5);
    assert_eq!(a.in_set_m_rate, Some(2.0 / 3.0));
    let all = a.failures.join("\n");
    for needle in [
        "1 run(s) failed (seeds 4)",
        "min_convergence_rate: 2 of 4",
        "max_final_distance: 1 run(s)",
        "seed 3: 3.0000",
        "max_time_to_converge: 1 converged run(s)",
        "seed 2: 50 s",
    ] {
        assert!(all.contains(needle), "{needle} in {all}");
    }
    assert_eq!(
        csv_row(&rows[2]),
        "3,false,,3,3,0.2,false,1,ok,,,,,,,,,,,,",
        "empty cells for missing values"
    );
    assert_eq!(csv_row(&rows[3]), "4,false,,,,,,0.5,boom,,,,,,,,,,,,");
}

#[test]
fn sweep_lists_split_at_top_level_commas_and_name_the_key() {
    let s: SweepArg = "links.loss=0, 0.1,0.2".parse().unwrap();
    assert_eq!(s.key, "links.loss");
    assert_eq!(
        s.values,
        vec![
            toml::Value::Integer(0),
            toml::Value::Float(0.1),
            toml::Value::Float(0.2)
        ]
    );
    let s: SweepArg = "vehicles.start=[1.0, 2.0],[3.0, 4.0]".parse().unwrap();
    assert_eq!(s.values.len(), 2);
    let s: SweepArg = "control.law=paper,\"robust\"".parse().unwrap();
    assert_eq!(
        s.values.iter().map(sweep::label).collect::<Vec<_>>(),
        ["paper", "robust"]
    );
    for (bad, needle) in [
        ("links.loss=", "links.loss: empty list"),
        ("links.loss=0.1,,0.2", "links.loss: an empty value"),
        ("links.loss", "expected KEY=V1,V2"),
        ("links..loss=1", "a key is dotted words"),
    ] {
        let e = bad.parse::<SweepArg>().unwrap_err();
        assert!(e.contains(needle), "{bad}: {e}");
    }
}

#[test]
fn the_grid_is_every_combination_first_key_slowest() {
    let keys: Vec<SweepArg> = vec![
        "links.loss=0,0.1,0.2".parse().unwrap(),
        "control.law=paper,robust".parse().unwrap(),
    ];
    let grid = sweep::grid(&keys);
    assert_eq!(grid.len(), 6);
    assert_eq!(grid[0].labels(), ["0", "paper"]);
    assert_eq!(grid[1].labels(), ["0", "robust"]);
    assert_eq!(grid[5].labels(), ["0.2", "robust"]);
    assert_eq!(
        grid[3].dir_name().as_deref(),
        Some("p3_links.loss=0.1_control.law=robust")
    );
    assert_eq!(grid[3].describe(), "links.loss=0.1, control.law=robust");
    let none = sweep::grid(&[]);
    assert_eq!(none.len(), 1);
    assert_eq!(none[0].dir_name(), None);
}

#[test]
fn the_batch_sweep_table_and_the_command_line_merge() {
    let m = mission(
        "[batch]\n[batch.sweep]\n\"links.loss\" = [0.0, 0.1]\nvehicles = { count = [3, 4] }\n",
    )
    .unwrap();
    Criteria::of(&m).unwrap();
    let cli: Vec<SweepArg> = vec!["links.loss=0.3".parse().unwrap()];
    let keys = sweep::resolve(&cli, &m).unwrap();
    let swept = sweep::swept(&keys);
    assert_eq!(swept.len(), 2);
    assert_eq!(swept[0].key, "links.loss");
    assert_eq!(
        swept[0].values,
        ["0.3"],
        "the command line replaces the file's list"
    );
    assert_eq!(swept[1].key, "vehicles.count");
    assert_eq!(swept[1].values, ["3", "4"]);
    for (table, cli, needle) in [
        (
            "[batch.sweep]\n\"links.loss\" = []\n",
            "",
            "m.toml: batch.sweep.links.loss: must be a non-empty list",
        ),
        (
            "[batch]\nsweep = 1\n",
            "",
            "m.toml: batch.sweep: must be a table",
        ),
        (
            "",
            "links.loss=0.1,0.1",
            "--sweep links.loss: the value 0.1 is given twice",
        ),
        (
            "",
            "mission.seed=1,2",
            "--sweep mission.seed: the seed is swept by --seeds",
        ),
    ] {
        let m = mission(table).unwrap();
        let cli: Vec<SweepArg> = cli.split_whitespace().map(|c| c.parse().unwrap()).collect();
        let e = sweep::resolve(&cli, &m).unwrap_err().to_string();
        assert!(e.contains(needle), "{table} {cli:?}: {e}");
    }
}

#[test]
fn wilson_interval_matches_known_values() {
    // 8 of 10 at 95 %: [0.4902, 0.9433] (Wilson 1927; e.g. Newcombe 1998, method 3).
    let [lo, hi] = stats::wilson(8, 10, stats::Z95);
    assert!(
        (lo - 0.4902).abs() < 5e-5 && (hi - 0.9433).abs() < 5e-5,
        "{lo} {hi}"
    );
    let [lo, hi] = stats::wilson(0, 10, stats::Z95);
    assert_eq!(lo, 0.0);
    assert!((hi - 0.2775).abs() < 5e-5, "{hi}");
    let [lo, hi] = stats::wilson(10, 10, stats::Z95);
    assert!((lo - 0.7225).abs() < 5e-5, "{lo}");
    assert!((hi - 1.0).abs() < 1e-12, "{hi}");
    assert_eq!(stats::wilson(0, 0, stats::Z95), [0.0, 1.0]);
}

#[test]
fn a_run_is_complete_with_a_whole_summary_not_interrupted_nor_failed() {
    use vbap_mission::rundir::{RunDir, Summary};
    let tmp = tempfile::tempdir().unwrap();
    let dir = RunDir {
        root: tmp.path().to_path_buf(),
    };
    assert!(resume::complete(&dir.root).is_none(), "no summary");
    let mut s = Summary {
        verdict: "converged".into(),
        ..Summary::default()
    };
    s.write(&dir).unwrap();
    assert_eq!(resume::complete(&dir.root), Some(s.clone()));
    let text = std::fs::read_to_string(dir.summary()).unwrap();
    std::fs::write(dir.summary(), &text[..text.len() / 2]).unwrap();
    assert!(resume::complete(&dir.root).is_none(), "cut short");
    s.verdict = "interrupted".into();
    s.write(&dir).unwrap();
    assert!(resume::complete(&dir.root).is_none(), "interrupted");
    s.verdict = "converged".into();
    s.write(&dir).unwrap();
    std::fs::write(dir.root.join(resume::FAILED_FILE), "vbap run exited with 1").unwrap();
    assert!(resume::complete(&dir.root).is_none(), "failed");
}
