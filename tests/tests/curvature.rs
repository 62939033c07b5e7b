//! Issue 13 item 4, end to end: on a gentle field with no Hessian configured, the robust
//! law estimates the curvature from the readings and flies the formation within 20 % of
//! the (V.7) optimum for the TRUE curvature once the estimate has settled; the paper's law,
//! with its default H = I, flies it about 4 × too small.

use vbap_math::formation::design_regular;
use vbap_math::optimal::optimal_scale;
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::field::Field;

use tests::*;

/// A gentle Gaussian hill (curvature 0.044 at the top), six vehicles, ideal links, no
/// `formation.hessian_guess` (H = I, ~23 × too stiff), adaptation on; the curvature
/// estimated online (`control.curvature = "estimated"`; the paper's law ignores it).
fn gentle(law: &str) -> String {
    format!(
        "[mission]\nname = \"{}\"\nseed = 1\nduration = 300.0\ndt = 0.1\ngoal = \"max\"\n\
         [field]\nkind = \"gaussian\"\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n\
         noise_std = 0.1\n\
         [vehicles]\ncount = 6\nstart = [0.0, 0.0]\nstart_spread = 0.5\ndamping = 1.0\n\
         [formation]\nradius = 1.5\nadapt = true\nadapt_gain = 0.5\nalpha = 10.0\n\
         min_scale = 0.2\nmax_scale = 5.0\nsigma_h = 1.0\n\
         [body]\nv0 = 0.5\nv_u = 1.0\n[estimator]\nkalman_b = 0.05\n\
         [control]\nlaw = \"{law}\"\ncurvature = \"estimated\"\n",
        unique_name("gentle")
    )
}

/// (t, flown scale, optimal scale of (V.7) for the true Hessian at the body centre and the
/// true σ_M, clamped to the mission's scale range) for every 10th row of `body.csv` from
/// mission time `from` on.
fn scale_vs_optimum(run: &std::path::Path, from: f64) -> Vec<(f64, f64, f64)> {
    let m = Mission::load(&run.join("mission.toml")).unwrap();
    let field = Field::from_config(&m.field, 2);
    let f = &m.formation;
    let body = columns::Table::read(&run.join("body.csv"));
    let n_rows = body.rows().count();
    body.rows()
        .enumerate()
        .filter(|(i, row)| row.num("t") >= from && (i % 10 == 0 || *i + 1 == n_rows))
        .map(|(_, row)| {
            let (t, n) = (row.num("t"), row.num("n_vehicles") as usize);
            let r = Vec3::new(row.num("rx"), row.num("ry"), 0.0);
            let design = design_regular(n, 2, f.radius, f.alpha, f.alpha).unwrap();
            let h = field.hessian(&r, t);
            let (k, _) = optimal_scale(&design.slots, 2, &h, f.sigma_h, m.field.noise_std).unwrap();
            (t, row.num("scale"), k.clamp(f.min_scale, f.max_scale))
        })
        .collect()
}

#[test]
fn the_flown_formation_ends_within_20_percent_of_the_optimum_for_the_true_curvature() {
    let tmp = TempDir::new("curvature");
    let robust = write_mission(&tmp, "robust.toml", &gentle("robust"));
    let out = tmp.join("robust");
    vbap_quiet("sim", &robust, &out);
    // Settled: the last third of the mission (the body is at the top from ~150 s on).
    let series = scale_vs_optimum(&out, 200.0);
    assert!(series.len() >= 100);
    for &(t, flown, best) in &series {
        let ratio = flown / best;
        assert!(
            (0.8..=1.2).contains(&ratio),
            "t = {t}: flown scale {flown} vs the optimum {best} (ratio {ratio})"
        );
    }
    let s = summary(&out);
    assert_eq!(s["verdict"], "converged", "{s}");

    // The paper's law with its default H = I stays far below the optimum.
    let paper = write_mission(&tmp, "paper.toml", &gentle("paper"));
    let out = tmp.join("paper");
    vbap_quiet("sim", &paper, &out);
    let &(_, flown, best) = scale_vs_optimum(&out, 299.0).last().unwrap();
    assert!(flown / best < 0.5, "paper: {flown} vs {best}");
}
