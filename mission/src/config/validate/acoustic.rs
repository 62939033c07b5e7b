//! `[acoustic]`.

use super::super::toml_text::num;
use super::super::{AcousticSchedule, Mission};
use super::{Check, Checked};
use vbap_wire::compact::{acoustic_frame_len, Precision};

pub use vbap_wire::msg::MAX_ACOUSTIC_VEHICLES;

/// Checks `[acoustic]` of `m` (when present).
pub(super) fn check(c: &Check, m: &Mission) -> Checked {
    let Some(a) = &m.acoustic else {
        return Ok(());
    };
    c.positive("acoustic.bit_rate", a.bit_rate)?;
    c.positive("acoustic.sound_speed", a.sound_speed)?;
    c.positive("acoustic.communication_range", a.communication_range)?;
    c.at_least(
        "acoustic.detection_range",
        a.detection_range,
        "acoustic.communication_range",
        a.communication_range,
    )?;
    c.at_least(
        "acoustic.interference_range",
        a.interference_range,
        "acoustic.detection_range",
        a.detection_range,
    )?;
    c.finite("acoustic.decode_probability", a.decode_probability)?;
    c.ensure(
        a.decode_probability > 0.0 && a.decode_probability <= 1.0,
        "acoustic.decode_probability",
        num(a.decode_probability),
        "must be in (0, 1]",
    )?;
    let precision = Precision::of_quantum(m.links.position_quantum);
    let frame = acoustic_frame_len(precision) as u64;
    c.ensure(
        a.frame_bytes >= frame,
        "acoustic.frame_bytes",
        a.frame_bytes,
        &format!(
            "must be ≥ {frame} bytes (one state frame{}): set links.position_quantum to send \
             30-byte frames",
            if precision == Precision::Exact {
                " with exact positions"
            } else {
                ""
            }
        ),
    )?;
    c.finite("acoustic.interval", a.interval)?;
    c.ensure(
        a.interval >= m.mission.dt,
        "acoustic.interval",
        num(a.interval),
        &format!(
            "must be ≥ mission.dt = {} (one frame per vehicle and tick at most)",
            num(m.mission.dt)
        ),
    )?;
    let air = a.air_time(frame);
    c.ensure(
        air < a.interval,
        "acoustic.interval",
        num(a.interval),
        &format!(
            "must be longer than a frame's air time ({} s at acoustic.bit_rate = {})",
            num(air),
            num(a.bit_rate)
        ),
    )?;
    let n = m.vehicles.count;
    c.ensure(
        n <= MAX_ACOUSTIC_VEHICLES,
        "vehicles.count",
        n,
        &format!("must be ≤ {MAX_ACOUSTIC_VEHICLES} with [acoustic] (one shared channel)"),
    )?;
    if a.schedule == AcousticSchedule::Tdma {
        let slot = a.interval / n as f64;
        let need = air + a.max_propagation();
        c.ensure(
            slot >= need,
            "acoustic.interval",
            num(a.interval),
            &format!(
                "a TDMA slot (interval / vehicles.count = {} s) must hold a frame's air time \
                 and its propagation over acoustic.interference_range ({} s): interval ≥ {}",
                num(slot),
                num(need),
                num(need * n as f64)
            ),
        )?;
    }
    Ok(())
}
