//! `[acoustic]`: acoustic modems between the vehicles (beyond the paper;
//! docs/guide/links-and-faults.md, the model in `crate::acoustic`).

use serde::{Deserialize, Serialize};

/// When the vehicles transmit on the acoustic channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum AcousticSchedule {
    /// Each vehicle once per `interval`, at a random (seeded) offset in it: frames of
    /// different vehicles may overlap at a receiver and collide.
    #[default]
    Random,
    /// Time-division: vehicle i transmits at i·interval/N of every interval, one slot
    /// each; validation makes a slot hold a frame and its propagation over the
    /// interference range, so frames never collide (half-duplex still applies).
    Tdma,
}

/// `[acoustic]`: every vehicle broadcasts its state (id, tick, position, velocity: one
/// frame) on a shared acoustic channel; the others hear it by range (a model like
/// UnetStack's: decoded within `communication_range` with probability
/// `decode_probability`, detected but not decoded up to `detection_range`, interfering
/// up to `interference_range`), `range / sound_speed` later, for the frame's air time
/// `8·bytes / bit_rate`; a modem does not hear while it transmits (half-duplex) and two
/// frames overlapping at a receiver are both lost (collision). Lengths in the mission's
/// length unit (metres for real modems), times in seconds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AcousticSection {
    /// Modem bit rate, bit/s, > 0 (WHOI Micro-Modem: 80 for FH-FSK up to 5400 for PSK).
    pub bit_rate: f64,
    /// Largest frame, bytes: a state frame must fit (30 bytes with a
    /// `links.position_quantum`, 54 without).
    pub frame_bytes: u64,
    /// Time between two transmissions of one vehicle, s, ≥ `mission.dt`.
    pub interval: f64,
    /// When in its interval a vehicle transmits.
    pub schedule: AcousticSchedule,
    /// Speed of sound, length unit/s, > 0 (≈ 1500 m/s in sea water).
    pub sound_speed: f64,
    /// A frame is decoded within this range (with `decode_probability`), length unit.
    pub communication_range: f64,
    /// A frame is detected (it occupies the receiver, not decoded) up to this range.
    pub detection_range: f64,
    /// A frame corrupts the frames it overlaps at a receiver up to this range.
    pub interference_range: f64,
    /// Probability that a frame within `communication_range`, alone on the channel, is
    /// decoded, (0, 1].
    pub decode_probability: f64,
}

impl Default for AcousticSection {
    /// A WHOI Micro-Modem in its robust FH-FSK mode (80 bit/s, 32-byte frames) between
    /// gliders a few kilometres apart: decoded within 3 km nine times in ten, detected to
    /// 4 km, interfering to 5 km; one frame a minute per vehicle.
    fn default() -> Self {
        Self {
            bit_rate: 80.0,
            frame_bytes: 32,
            interval: 60.0,
            schedule: AcousticSchedule::Random,
            sound_speed: 1500.0,
            communication_range: 3000.0,
            detection_range: 4000.0,
            interference_range: 5000.0,
            decode_probability: 0.9,
        }
    }
}

impl AcousticSection {
    /// Time one frame of `bytes` bytes occupies the channel, s.
    pub fn air_time(&self, bytes: u64) -> f64 {
        8.0 * bytes as f64 / self.bit_rate
    }

    /// Longest propagation that still matters (over the interference range), s.
    pub fn max_propagation(&self) -> f64 {
        self.interference_range / self.sound_speed
    }
}
