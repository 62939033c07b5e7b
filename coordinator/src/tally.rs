//! The message counts of `summary.json`, in one place.
//!
//! The in-process simulator counts every message of the vehicle ↔ coordinator links the
//! link model decided ([`LinkTally`]); the coordinator process counts what it saw itself
//! ([`process_counts`]), which the analysis of the message records replaces after a
//! supervised run (it counts, from the records of every process, what the simulator
//! counts).

use vbap_mission::acoustic::AcousticModel;
use vbap_mission::rundir::{AcousticTotals, MessageCounts};

use crate::fleet::Fleet;

/// The downlink (coordinator → vehicle) side of the simulator's count: the commands each
/// vehicle's link model delivered or dropped, summed over every vehicle that ever ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkTally {
    /// The acoustic receptions of every vehicle that ever ran (`[acoustic]`).
    pub acoustic: AcousticTotals,
    /// Commands delivered by the link model.
    pub downlink_delivered: u64,
    /// Commands dropped by the link model.
    pub downlink_dropped: u64,
    /// Commands the shore replaced with a newer one (Iridium).
    pub downlink_superseded: u64,
}

impl LinkTally {
    /// Adds the downlink counters of one vehicle (at its loss, or at the end).
    pub fn add_downlink(&mut self, delivered: u64, dropped: u64, superseded: u64) {
        self.downlink_delivered += delivered;
        self.downlink_dropped += dropped;
        self.downlink_superseded += superseded;
    }

    /// The `acoustic` object of the summary on `channel` (None without one).
    pub fn acoustic_totals(&self, channel: Option<&AcousticModel>) -> Option<AcousticTotals> {
        channel.map(|m| AcousticTotals {
            frame_b: m.frame_bytes(),
            ..self.acoustic
        })
    }

    /// The link messages of the whole run, uplink from `fleet`'s counters. Reports still
    /// held by the uplink when the mission ends were let through by the link model (as the
    /// commands' fates count them): their delivery time lies after the end.
    pub fn counts(&self, fleet: &Fleet) -> MessageCounts {
        let up = fleet.counts;
        let in_flight = fleet.held_reports().0.len() as u64;
        let delivered = up.delivered + in_flight + self.downlink_delivered;
        let dropped_injected = up.dropped_injected + self.downlink_dropped;
        MessageCounts {
            sent: delivered + dropped_injected + self.downlink_superseded,
            delivered,
            dropped_injected,
            superseded: self.downlink_superseded,
            ..MessageCounts::default()
        }
    }
}

/// The coordinator process's own count: `received` (the states it accepted, and those it
/// rejected), `published` body commands, and the uplink reports the link model dropped.
pub fn process_counts(received: MessageCounts, published: u64, fleet: &Fleet) -> MessageCounts {
    MessageCounts {
        sent: published,
        dropped_injected: fleet.counts.dropped_injected,
        ..received
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::Report;
    use vbap_math::Vec3;
    use vbap_mission::config::Mission;

    /// Every report sent is counted once: delivered (in time or still in flight at the
    /// end) or dropped, and the downlink adds its own.
    #[test]
    fn every_message_is_counted_once() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 3\n[links]\ndelay = 0.5\nloss = 0.3\n",
            "<test>",
        )
        .unwrap();
        let mut fleet = Fleet::new(&m, &[0, 1, 2]);
        let ticks = 40u64;
        for k in 0..ticks {
            let truth: Vec<Report> = fleet
                .alive()
                .map(|id| Report {
                    id,
                    tick: k,
                    position: Vec3::zeros(),
                    velocity: Vec3::zeros(),
                    measurement: 0.0,
                })
                .collect();
            fleet.receive(k, 0.05, &truth);
            fleet.track_body(k, Vec3::zeros());
            fleet.deliver(k as f64 * 0.05, 0.05);
            fleet.end_tick();
        }
        let mut tally = LinkTally::default();
        tally.add_downlink(50, 5, 0);
        tally.add_downlink(20, 1, 0);
        let c = tally.counts(&fleet);
        assert!(fleet.counts.dropped_injected > 0 && !fleet.held_reports().0.is_empty());
        assert_eq!(c.sent, 3 * ticks + 76);
        assert_eq!(c.delivered + c.dropped_injected, c.sent);
        assert_eq!(c.dropped_injected, fleet.counts.dropped_injected + 6);
        let own = process_counts(
            MessageCounts {
                delivered: 9,
                rejected: 2,
                ..MessageCounts::default()
            },
            40,
            &fleet,
        );
        assert_eq!((own.sent, own.delivered, own.rejected), (40, 9, 2));
        assert_eq!(own.dropped_injected, fleet.counts.dropped_injected);
    }
}
