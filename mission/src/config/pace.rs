//! [`Pace`]: how mission time is paced against wall time (`mission.pace`, `--pace`).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// How mission time is paced against wall time (docs/ARCHITECTURE.md §4).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Pace {
    /// As fast as possible, each tick released when every live participant has reported.
    #[default]
    Lockstep,
    /// Real time scaled by this factor (> 0): 1.0 = real time, 60.0 = a minute per second.
    Factor(f64),
}

impl fmt::Display for Pace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pace::Lockstep => f.write_str("lockstep"),
            Pace::Factor(x) => write!(f, "{x}"),
        }
    }
}

impl FromStr for Pace {
    type Err = String;

    /// `lockstep` or a real-time factor (a finite number > 0), as on the command line.
    fn from_str(s: &str) -> Result<Pace, String> {
        let s = s.trim();
        if s == "lockstep" {
            return Ok(Pace::Lockstep);
        }
        match s.parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => Ok(Pace::Factor(x)),
            _ => Err(format!(
                "pace {s:?}: must be \"lockstep\" or a real-time factor > 0 (1.0 = real time)"
            )),
        }
    }
}

impl Serialize for Pace {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Pace::Lockstep => s.serialize_str("lockstep"),
            Pace::Factor(x) => s.serialize_f64(*x),
        }
    }
}

impl<'de> Deserialize<'de> for Pace {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Pace, D::Error> {
        struct PaceVisitor;
        impl serde::de::Visitor<'_> for PaceVisitor {
            type Value = Pace;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("\"lockstep\" or a real-time factor > 0")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Pace, E> {
                if v == "lockstep" {
                    Ok(Pace::Lockstep)
                } else {
                    Err(E::invalid_value(serde::de::Unexpected::Str(v), &self))
                }
            }
            // Range checks belong to `validate`, which names the key.
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Pace, E> {
                Ok(Pace::Factor(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Pace, E> {
                Ok(Pace::Factor(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Pace, E> {
                Ok(Pace::Factor(v as f64))
            }
        }
        d.deserialize_any(PaceVisitor)
    }
}
