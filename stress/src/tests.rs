//! Unit tests of the sampler, the judge, the shrinker and the campaign (with synthetic
//! flyers: no simulator here).

use std::path::Path;

use vbap_mission::config::Mission;
use vbap_mission::rundir::{FormationSummary, RunDir, Summary};

use crate::campaign::{self, read_results, Config};
use crate::draw::Draw;
use crate::grid::write_grid;
use crate::judge::{judge, stall_why};
use crate::shrink::shrink;
use crate::space::Space;

fn grid_in(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("grid.nc");
    write_grid(&p).unwrap();
    p
}

/// A summary that passes every criterion.
fn passing() -> Summary {
    Summary {
        converged: true,
        verdict: "converged".into(),
        formation: Some(FormationSummary {
            all_in_contact_t: Some(0.0),
            alive_at_end: 4,
            in_formation_at_end: 4,
            ..FormationSummary::default()
        }),
        ..Summary::default()
    }
}

#[test]
fn the_same_seed_and_index_give_the_same_mission_text() {
    let space = Space::default();
    let grid = Path::new("/nonexistent/grid.nc");
    for i in 0..50 {
        let a = Draw::sample(&space, 7, i, 0).toml("robust", grid);
        let b = Draw::sample(&space, 7, i, 0).toml("robust", grid);
        assert_eq!(a, b, "mission {i}");
    }
    let a = Draw::sample(&space, 7, 3, 0).toml("robust", grid);
    assert_ne!(a, Draw::sample(&space, 8, 3, 0).toml("robust", grid));
    assert_ne!(a, Draw::sample(&space, 7, 4, 0).toml("robust", grid));
    assert_ne!(a, Draw::sample(&space, 7, 3, 1).toml("robust", grid));
}

#[test]
fn every_sampled_mission_of_the_first_200_validates() {
    let tmp = tempfile::tempdir().unwrap();
    let grid = grid_in(tmp.path());
    let space = Space::default();
    let laws = vec!["robust".to_string(), "paper".to_string()];
    let mut kinds = std::collections::BTreeSet::new();
    for i in 0..200 {
        let s = campaign::sample(&space, 1, i, &laws, &grid, &[]).unwrap();
        for law in &laws {
            let m = campaign::mission_of(&s.draw, law, &grid, &[]).unwrap();
            assert_eq!(m.vehicles.count, s.draw.n);
            // The resolved text parses back to the same mission.
            let again = Mission::from_toml_str(&m.to_toml_string(), "again").unwrap();
            assert_eq!(again, m, "mission {i}");
        }
        kinds.insert(s.draw.field.kind.clone());
    }
    assert_eq!(kinds.len(), 6, "every field kind is drawn: {kinds:?}");
}

#[test]
fn the_judge_names_each_criterion() {
    assert!(judge(&passing(), None, 2.0).pass());

    let mut s = passing();
    s.formation.as_mut().unwrap().near_collision_ticks = 3;
    assert_eq!(judge(&s, None, 2.0).failed, ["near_collision"]);

    let mut s = passing();
    s.formation.as_mut().unwrap().out_of_formation_at_end = vec![2];
    assert_eq!(judge(&s, None, 2.0).failed, ["out_of_formation"]);

    // V after first contact from truth.csv: the rows before all_in_contact_t do not count.
    let truth = "t,k,V_true_over_VU,V_seen_over_VU\n0,0,5.0,5.0\n1,20,1.5,1.5\n2,40,1.9,1.0\n";
    let mut s = passing();
    s.formation.as_mut().unwrap().all_in_contact_t = Some(1.0);
    let j = judge(&s, Some(truth), 2.0);
    assert!(j.pass(), "{j:?}");
    assert_eq!(j.v_after_contact, 1.9);
    assert_eq!(judge(&s, Some(truth), 1.8).failed, ["v_bound"]);
    s.formation.as_mut().unwrap().all_in_contact_t = Some(0.0);
    assert_eq!(judge(&s, Some(truth), 2.0).failed, ["v_bound"]);
    // Without truth.csv, the summary's maximum.
    let mut s = passing();
    s.formation.as_mut().unwrap().max_v_true_over_vu = 2.5;
    assert_eq!(judge(&s, None, 2.0).failed, ["v_bound"]);

    // The body: a stall not caused by V passes, one caused by V fails.
    let stalled = |why: &str| {
        let mut s = passing();
        s.converged = false;
        s.verdict = "stalled".into();
        s.reasons = vec![format!(
            "the body stalled from t = 2.500 s to the end (ṡ below 0.1 v0; why: {why})"
        )];
        s
    };
    assert_eq!(stall_why(&stalled("holding")).as_deref(), Some("holding"));
    assert!(judge(&stalled("slow"), None, 2.0).pass());
    assert!(judge(&stalled("waiting for reports"), None, 2.0).pass());
    assert_eq!(judge(&stalled("V above V_U"), None, 2.0).failed, ["body"]);
    assert_eq!(judge(&stalled("V above V_U/2"), None, 2.0).failed, ["body"]);
    for (verdict, pass) in [
        ("not converged", false),
        ("diverged", false),
        ("converged to a stationary point", true),
        ("converged, formation broken", true),
        ("formation kept", true),
    ] {
        let mut s = passing();
        s.converged = false;
        s.verdict = verdict.into();
        assert_eq!(judge(&s, None, 2.0).pass(), pass, "{verdict}");
    }
    // Several at once, in order.
    let mut s = stalled("V above V_U");
    s.formation.as_mut().unwrap().near_collision_ticks = 1;
    assert_eq!(judge(&s, None, 2.0).failed, ["near_collision", "body"]);
    // No formation figures: an error.
    let mut s = passing();
    s.formation = None;
    assert_eq!(judge(&s, None, 2.0).failed, ["error"]);
}

/// A flyer that fails (near collision) iff N > 4 and the links lose messages; it writes
/// the summary as the simulator does.
fn synthetic(m: &Mission, dir: &RunDir) -> anyhow::Result<Summary> {
    let mut s = passing();
    if m.vehicles.count > 4 && m.links.loss > 0.0 {
        s.formation.as_mut().unwrap().near_collision_ticks = 1;
    }
    s.write(dir)?;
    Ok(s)
}

#[test]
fn the_shrinker_keeps_only_what_the_failure_needs() {
    let tmp = tempfile::tempdir().unwrap();
    let grid = grid_in(tmp.path());
    let space = Space::default();
    let laws = vec!["robust".to_string()];
    // A draw with everything on: many vehicles, loss, faults, delay, glider, adapt.
    let mut d = campaign::sample(&space, 1, 0, &laws, &grid, &[])
        .unwrap()
        .draw;
    d.n = 12;
    d.loss = 0.2;
    d.burst = Some((0.05, 0.3, 0.5));
    d.delay = 1.0;
    d.jitter = 0.5;
    d.surfacing = Some((4.0, 1.0));
    d.adapt = true;
    d.glider = Some((1.0, 5.0, 2.0));
    d.current = Some(vec![0.05; d.dim]);
    d.faults = vec![
        crate::draw::FaultDraw {
            vehicle: 1,
            at: 10.0,
            until: None,
        },
        crate::draw::FaultDraw {
            vehicle: 7,
            at: 20.0,
            until: Some(30.0),
        },
    ];
    d.noise_fraction = 0.2;
    let mut fails = |d: &Draw| -> Option<Vec<String>> {
        let m = campaign::mission_of(d, "robust", &grid, &[]).ok()?;
        Some(if m.vehicles.count > 4 && m.links.loss > 0.0 {
            vec!["near_collision".into()]
        } else {
            vec![]
        })
    };
    let s = shrink(&d, "near_collision", &mut fails);
    assert_eq!(s.draw.n, 5, "{:?}", s.steps);
    assert_eq!(s.draw.loss, 0.2);
    assert!(s.draw.faults.is_empty());
    assert_eq!((s.draw.delay, s.draw.jitter), (0.0, 0.0));
    assert_eq!(s.draw.burst, None);
    assert_eq!(s.draw.surfacing, None);
    assert_eq!(s.draw.glider, None);
    assert_eq!(s.draw.current, None);
    assert!(!s.draw.adapt);
    assert_eq!(s.draw.noise_fraction, 0.01);
    assert!(s.flights <= crate::shrink::MAX_SHRINK_FLIGHTS);
    // Minimal: no simplification of the result still fails.
    for (label, c) in crate::shrink::simplifications(&s.draw) {
        assert_ne!(fails(&c), Some(vec!["near_collision".into()]), "{label}");
    }
}

fn config(out: &Path, missions: u64) -> Config {
    Config {
        missions,
        seed: 3,
        out: out.to_path_buf(),
        jobs: 2,
        laws: vec!["robust".into(), "paper".into()],
        v_bound: 2.0,
        shrink: true,
        sets: Vec::new(),
        space: Space::default(),
        verbose: false,
        only: Vec::new(),
    }
}

/// `--only`: a campaign flies the chosen indices alone, each the same flight, with the same
/// result, as in the whole campaign; an index beyond the campaign is bad input.
#[test]
fn only_some_indices_fly_the_same_flights_as_the_whole_campaign() {
    let tmp = tempfile::tempdir().unwrap();
    let whole = campaign::run(&config(&tmp.path().join("whole"), 12), &synthetic).unwrap();
    let chosen = Config {
        only: vec![3, 7, 11],
        ..config(&tmp.path().join("chosen"), 12)
    };
    let part = campaign::run(&chosen, &synthetic).unwrap();
    assert_eq!(part.flown, 6);
    // The same flights, judged the same (the wall time aside).
    let timeless = |r: &crate::results::FlightResult| crate::results::FlightResult {
        wall_s: 0.0,
        ..r.clone()
    };
    let expected: Vec<_> = whole
        .results
        .iter()
        .filter(|r| chosen.only.contains(&r.mission))
        .map(timeless)
        .collect();
    assert_eq!(
        part.results.iter().map(timeless).collect::<Vec<_>>(),
        expected
    );
    let beyond = Config {
        only: vec![12],
        ..config(&tmp.path().join("beyond"), 12)
    };
    let e = campaign::run(&beyond, &synthetic).unwrap_err();
    assert!(e.to_string().contains("--only 12"), "{e:#}");
}

#[test]
fn a_resumed_campaign_gives_the_table_of_one_shot() {
    let tmp = tempfile::tempdir().unwrap();
    let one = tmp.path().join("one");
    let a = campaign::run(&config(&one, 12), &synthetic).unwrap();
    assert_eq!(a.results.len(), 24);
    assert_eq!(a.flown, 24);
    assert!(!a.all_passed(), "some draw has N > 4 and loss");
    // Failures keep their mission files and run directories; passes leave nothing.
    for r in &a.results {
        let dir = one
            .join("runs")
            .join(crate::results::flight_name(r.mission, &r.law));
        assert_eq!(dir.exists(), !r.pass, "{dir:?}");
        if !r.pass {
            assert!(one.join(r.file.as_ref().unwrap()).exists());
            let shrunk = r.shrunk.as_ref().unwrap();
            assert_eq!(shrunk.dims.n, 5);
            assert!(one.join(&shrunk.file).exists());
        }
    }

    // Interrupted: the first 7 lines and a torn eighth are all that is left.
    let two = tmp.path().join("two");
    campaign::run(&config(&two, 12), &synthetic).unwrap();
    let text = std::fs::read_to_string(two.join(campaign::RESULTS_FILE)).unwrap();
    let mut kept: String = text.lines().take(7).map(|l| format!("{l}\n")).collect();
    kept.push_str(&text.lines().nth(7).unwrap()[..20]);
    std::fs::write(two.join(campaign::RESULTS_FILE), kept).unwrap();
    let b = campaign::run(&config(&two, 12), &synthetic).unwrap();
    assert_eq!(b.flown, 17);
    assert_eq!(a.table, b.table);
    assert_eq!(read_results(&two).len(), 24);
    assert_eq!(
        std::fs::read_to_string(one.join("stress.md")).unwrap(),
        std::fs::read_to_string(two.join("stress.md")).unwrap()
    );
    // Again: nothing left to fly, the same table.
    let c = campaign::run(&config(&two, 12), &synthetic).unwrap();
    assert_eq!(c.flown, 0);
    assert_eq!(a.table, c.table);
    // Another plan on the same directory is refused.
    let e = campaign::run(&config(&two, 13), &synthetic).unwrap_err();
    assert!(e.downcast_ref::<campaign::BadInput>().is_some(), "{e:#}");
}

#[test]
fn a_set_applies_to_every_mission_and_a_bad_one_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let grid = grid_in(tmp.path());
    let space = Space::default();
    let laws = vec!["robust".to_string()];
    let sets = vec!["links.downlink=false".parse().unwrap()];
    let s = campaign::sample(&space, 1, 5, &laws, &grid, &sets).unwrap();
    let m = campaign::mission_of(&s.draw, "robust", &grid, &sets).unwrap();
    assert!(!m.links.downlink);
    let bad = vec!["links.lost=0.1".parse().unwrap()];
    let e = campaign::sample(&space, 1, 5, &laws, &grid, &bad).unwrap_err();
    assert!(e.0.contains("lost"), "{e}");
}

/// The space's rule `hessian_guess = |curvature at the optimum| · I` holds for gaussian
/// sums, whose optimum may sit on a side bump narrower than the main one: the guess is
/// the mean |second difference| of the true field at its optimum (central differences of
/// the field's value, independent of its analytic Hessian), not the main bump's A/w².
#[test]
fn a_gaussian_sums_hessian_guess_is_its_curvature_at_the_optimum() {
    use vbap_mission::config::FieldKind;
    let tmp = tempfile::tempdir().unwrap();
    let grid = grid_in(tmp.path());
    let space = Space::default();
    let laws = vec!["robust".to_string()];
    let (mut sums, mut off_main) = (0, 0);
    for i in 0..300 {
        let s = campaign::sample(&space, 3, i, &laws, &grid, &[]).unwrap();
        let m = campaign::mission_of(&s.draw, "robust", &grid, &[]).unwrap();
        if m.field.kind != FieldKind::GaussianSum {
            continue;
        }
        sums += 1;
        let field = m.field();
        let dim = m.mission.dim;
        let top = field.optimum(0.0, m.mission.goal).unwrap();
        let h = 1e-3
            * m.field
                .bumps
                .iter()
                .map(|b| b.width)
                .fold(f64::MAX, f64::min);
        let mut curvature = 0.0;
        for axis in 0..dim {
            let mut e = vbap_math::Vec3::zeros();
            e[axis] = h;
            let second = (field.value(&(top + e), 0.0) - 2.0 * field.value(&top, 0.0)
                + field.value(&(top - e), 0.0))
                / (h * h);
            curvature += second.abs() / dim as f64;
        }
        let guess = m
            .formation
            .hessian_guess
            .as_ref()
            .expect("the space writes a guess")[0][0];
        // The trace over dim of |H| equals the mean |eigenvalue| when H is definite (a peak).
        assert!(
            (guess - curvature).abs() <= 1e-4 * curvature,
            "mission {i}: guess {guess}, curvature at the optimum {curvature}"
        );
        let main = &m.field.bumps[0];
        if (guess - main.amplitude / (main.width * main.width)).abs() > 0.1 * guess {
            off_main += 1;
        }
    }
    assert!(sums >= 20, "gaussian sums drawn: {sums}");
    assert!(off_main > 0, "some optimum is not the main bump's top");
}
