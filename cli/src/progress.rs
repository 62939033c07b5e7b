//! The progress display of `vbap run`: mission time, vehicles alive, distance to the optimum.
//!
//! A thread with its own iceoryx2 node reads the newest body command (history 1) four
//! times a second (a WaitSet interval, not a busy poll) and updates an indicatif bar on
//! stderr; hidden when stderr is not a terminal.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use vbap_ipc::msg::to_vec3;
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::{ports, wait};
use vbap_mission::config::Mission;
use vbap_mission::field::ScalarField;

/// A running progress display.
pub struct ProgressView {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl ProgressView {
    /// Starts the display for `mission`, distances measured in `field` (a no-op when `show`
    /// is false).
    pub fn start(mission: &Mission, field: Arc<dyn ScalarField>, show: bool) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        if !show || !std::io::stderr().is_terminal() {
            return Self { stop, thread: None };
        }
        let mission = mission.clone();
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let _ = watch(&mission, field.as_ref(), &flag);
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }

    /// Stops and joins the display.
    pub fn finish(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for ProgressView {
    fn drop(&mut self) {
        self.finish();
    }
}

fn watch(mission: &Mission, field: &dyn ScalarField, stop: &AtomicBool) -> anyhow::Result<()> {
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.node("supervisor_progress")?;
    let sub = ports::subscriber(&domain.body_service(&node, &limits)?)?;
    let ticks = mission.ticks();
    let bar = ProgressBar::new(ticks);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:30} {pos}/{len} ticks  {msg}  [{elapsed_precise}, eta {eta}]",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let show = || {
        let mut newest = None;
        while let Ok(Some(sample)) = sub.receive() {
            newest = Some((
                sample.header.tick,
                sample.header.t,
                to_vec3(&sample.r),
                sample.n_vehicles,
            ));
        }
        if let Some((tick, t, r, n)) = newest {
            bar.set_position(tick);
            let distance = field
                .optimum(t, mission.mission.goal)
                .map(|o| format!("{:.3}", (r - o).norm()))
                .unwrap_or_else(|| "n/a".into());
            bar.set_message(format!(
                "t = {t:.1} s, vehicles {n}, distance to optimum {distance}"
            ));
        }
    };
    wait::every(
        Duration::from_millis(250),
        || !stop.load(Ordering::SeqCst),
        show,
    )?;
    bar.finish_and_clear();
    Ok(())
}
