//! The plan horizon H of the robust law (beyond the paper): the longest a vehicle can go
//! without a fresh body command, from the link model of `[links]`. The coordinator commits
//! the virtual body's path H ahead (`vbap_math::schedule`), so every plan a vehicle holds
//! stays true until the vehicle hears again. Pure.

use crate::config::{LawKind, LinksSection, Mission};

/// Probability below which a run of losses is treated as impossible (per vehicle and
/// contact): the horizon covers every run of lost commands more likely than this.
pub const NEGLIGIBLE: f64 = 1e-6;

/// Plan horizon H, s, of links `l` at tick length `dt` (s):
///
/// - ideal links, or a model that spares the downlink (`downlink = false`): 0, commands
///   are always fresh;
/// - surfacing (`surfacing_period` P > 0): a vehicle hears at least once per window unless
///   every command of a window is lost; H = (1 + e)·P + delay + jitter + dt, with e the
///   fewest extra periods such that losing all `window / dt` commands of e + 1 windows in a
///   row has probability ≤ [`NEGLIGIBLE`] (e = 0 unless the loss is severe);
/// - always in contact: H = delay + jitter + (n + 1)·dt, with n the longest run of lost
///   commands more likely than [`NEGLIGIBLE`] (loss p: the least n with pⁿ ≤ NEGLIGIBLE;
///   bursty loss counts the bad state's loss).
///
/// - Iridium sessions (`[links.iridium]`, interval I, failure f): a session carries nothing
///   with probability q = f + (1 − f)·p, p the loss of a session's command after a lost
///   one (`session_loss`: under bursts, by the chain's memory over I / dt ticks); with surfacing, as above with the sessions of a
///   window in place of its ticks; without, H = delay + jitter + (n + 1)·I + dt with n the
///   longest likely run of empty sessions; both plus `latency_full`, the transfer of a
///   full message.
///
/// `link_down` faults are not covered: they are failures, not the link's nature.
pub fn plan_horizon(l: &LinksSection, dt: f64) -> f64 {
    let p = if l.burst_enter > 0.0 {
        l.loss.max(l.burst_loss)
    } else {
        l.loss
    };
    if let Some(i) = l.iridium.as_ref().filter(|_| l.downlink) {
        let q = i.session_failure
            + (1.0 - i.session_failure) * session_loss(l, i.session_interval / dt);
        let lag = l.delay + l.jitter + i.latency_full;
        if l.surfacing_period > 0.0 {
            let per_window = (l.surfacing_window / i.session_interval).ceil().max(1.0);
            let windows = runs_until_negligible(q.powf(per_window)).max(1);
            return windows as f64 * l.surfacing_period + lag + dt;
        }
        return lag + (runs_until_negligible(q) + 1) as f64 * i.session_interval + dt;
    }
    let ideal = l.delay == 0.0 && l.jitter == 0.0 && p == 0.0 && l.surfacing_period == 0.0;
    if ideal || !l.downlink {
        return 0.0;
    }
    let lag = l.delay + l.jitter;
    if l.surfacing_period > 0.0 {
        let per_window = (l.surfacing_window / dt).floor().max(1.0);
        let miss = p.powf(per_window);
        let windows = runs_until_negligible(miss).max(1);
        return windows as f64 * l.surfacing_period + lag + dt;
    }
    lag + (runs_until_negligible(p) + 1) as f64 * dt
}

/// The probability that the command of a session is lost given that the previous
/// session's was lost in the worst way (`loss` for Bernoulli loss; under bursts, lost in
/// the bad state), for sessions `ticks` ticks apart. The burst chain moves once a tick:
/// from bad, it is bad `ticks` later with probability π + (1 − π)·λ^ticks (π = enter /
/// (enter + exit), the stationary share of bad; λ = 1 − enter − exit, |λ| taken), so
/// sessions far apart in ticks lose nearly independently at the stationary rate, and
/// sessions a tick apart as a burst does.
fn session_loss(l: &LinksSection, ticks: f64) -> f64 {
    if l.burst_enter <= 0.0 {
        return l.loss;
    }
    let pi = l.burst_enter / (l.burst_enter + l.burst_exit);
    let memory = (1.0 - l.burst_enter - l.burst_exit)
        .abs()
        .powf(ticks.max(1.0));
    let bad = pi + (1.0 - pi) * memory;
    (bad * l.burst_loss + (1.0 - bad) * l.loss).min(1.0)
}

/// The fewest n ≥ 0 with qⁿ ≤ [`NEGLIGIBLE`] (q in [0, 1); q ≥ 1 is capped at 10⁶).
fn runs_until_negligible(q: f64) -> u64 {
    if q <= 0.0 {
        return 0;
    }
    if q >= 1.0 {
        return 1_000_000;
    }
    let n = (NEGLIGIBLE.ln() / q.ln()).ceil().max(0.0) as u64;
    // Rounding of the logarithms: step to the least n (within 1e-9 of the bound, so that
    // 0.1⁶ counts as 1e-6).
    let mut n = n.saturating_sub(1);
    while q.powi(n as i32) > NEGLIGIBLE * (1.0 + 1e-9) {
        n += 1;
    }
    n
}

impl Mission {
    /// The plan horizon in force, s: 0 for `law = "paper"`, else `control.plan_horizon`
    /// when given, else [`plan_horizon`] of `[links]`.
    pub fn plan_horizon(&self) -> f64 {
        match self.control.law {
            LawKind::Paper => 0.0,
            LawKind::Robust => self
                .control
                .plan_horizon
                .unwrap_or_else(|| plan_horizon(&self.links, self.mission.dt)),
        }
    }

    /// The plan horizon in whole ticks, ⌈H / dt⌉.
    pub fn plan_horizon_ticks(&self) -> u64 {
        let h = self.plan_horizon();
        if h <= 0.0 {
            0
        } else {
            (h / self.mission.dt - 1e-9).ceil().max(1.0) as u64
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn links(text: &str) -> LinksSection {
        let m = Mission::from_toml_str(
            &format!("[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\n{text}"),
            "<test>",
        )
        .unwrap();
        m.links
    }

    #[test]
    fn ideal_links_and_an_ideal_downlink_need_no_plan() {
        assert_eq!(plan_horizon(&links(""), 0.1), 0.0);
        assert_eq!(
            plan_horizon(&links("delay = 1.0\nloss = 0.2\ndownlink = false"), 0.1),
            0.0
        );
    }

    #[test]
    fn always_in_contact_covers_delay_jitter_and_a_negligible_run_of_losses() {
        // 0.1⁶ = 1e-6: six lost commands in a row are the longest run not negligible.
        let h = plan_horizon(&links("delay = 0.5\njitter = 0.2\nloss = 0.1"), 0.1);
        assert!((h - (0.7 + 7.0 * 0.1)).abs() < 1e-12, "{h}");
        // No loss: delay, jitter and one tick of quantisation.
        let h = plan_horizon(&links("delay = 2.0\njitter = 1.0"), 0.5);
        assert!((h - 3.5).abs() < 1e-12, "{h}");
        // Bursty loss: the bad state's loss rules (0.9^n ≤ 1e-6 first at n = 132).
        let h = plan_horizon(
            &links("loss = 0.01\nburst_enter = 0.05\nburst_exit = 0.2\nburst_loss = 0.9"),
            1.0,
        );
        assert_eq!(h, 133.0);
        assert!(0.9f64.powi(131) > NEGLIGIBLE && 0.9f64.powi(132) <= NEGLIGIBLE);
    }

    #[test]
    fn surfacing_covers_one_period_unless_whole_windows_are_lost() {
        let text = "delay = 20.0\njitter = 10.0\nloss = 0.2\nsurfacing_period = 7200.0\nsurfacing_window = 900.0";
        let h = plan_horizon(&links(text), 10.0);
        assert!((h - (7200.0 + 30.0 + 10.0)).abs() < 1e-9, "{h}");
        // A window of one command at 50 % loss: 0.5^20 ≤ 1e-6 first, 20 periods.
        let h = plan_horizon(
            &links("loss = 0.5\nsurfacing_period = 100.0\nsurfacing_window = 1.0"),
            1.0,
        );
        assert!((h - (20.0 * 100.0 + 1.0)).abs() < 1e-9, "{h}");
    }

    #[test]
    fn the_law_and_the_key_choose_the_horizon() {
        let base = "[mission]\nname = \"t\"\ndt = 0.1\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\ndelay = 0.5\n";
        let m = |extra: &str| Mission::from_toml_str(&format!("{base}{extra}"), "<test>");
        assert_eq!(
            m("[control]\nlaw = \"paper\"\n").unwrap().plan_horizon(),
            0.0
        );
        assert!(
            (m("").unwrap().plan_horizon() - 0.6).abs() < 1e-12,
            "robust by default"
        );
        let robust = m("[control]\nlaw = \"robust\"\n").unwrap();
        assert!((robust.plan_horizon() - 0.6).abs() < 1e-12);
        assert_eq!(robust.plan_horizon_ticks(), 6);
        let set = m("[control]\nlaw = \"robust\"\nplan_horizon = 2.5\n").unwrap();
        assert_eq!((set.plan_horizon(), set.plan_horizon_ticks()), (2.5, 25));
        let err = m("[control]\nlaw = \"robust\"\nplan_horizon = -1.0\n").unwrap_err();
        assert!(err.to_string().contains("control.plan_horizon"), "{err}");
    }
}
