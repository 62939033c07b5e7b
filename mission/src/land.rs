//! Land: where no vehicle and no body centre may go (beyond the paper).
//!
//! [`LandMask`] is what the motion code asks of land; a mission's land comes from its
//! `[land]` section ([`AnalyticLand`]: a straight coast or a round island) or, with a
//! gridded field, from the data (`Mission::land`; it takes precedence). [`land_of`] builds the mission's.

use std::sync::Arc;

use vbap_math::Vec3;

use crate::config::{LandKind, LandSection, Mission};

/// Land, as the motion code sees it.
pub trait LandMask: Send + Sync + std::fmt::Debug {
    fn is_land(&self, p: &Vec3) -> bool;
    /// Distance to the nearest land (length unit) and the unit direction pointing AWAY
    /// from it; None when no land lies within the mask's search radius.
    fn clearance(&self, p: &Vec3) -> Option<(f64, Vec3)>;
}

/// A mission's land held where a value must be cloned, compared and serialised (the
/// planner's parameters): see [`Loaded`](crate::loaded::Loaded).
pub type LandRef = crate::loaded::Loaded<Arc<dyn LandMask>>;

/// Analytic land: a straight coast or a round island (in the xy plane; z is ignored).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum AnalyticLand {
    /// Land where (x − point)·normal < 0; `normal` is a unit vector pointing to the sea.
    Coast {
        point: Vec3,
        normal: Vec3,
        search: f64,
    },
    /// Land within `radius` of `center`.
    Island {
        center: Vec3,
        radius: f64,
        search: f64,
    },
}

fn flat(p: &Vec3) -> Vec3 {
    Vec3::new(p.x, p.y, 0.0)
}

impl LandMask for AnalyticLand {
    fn is_land(&self, p: &Vec3) -> bool {
        match self {
            AnalyticLand::Coast { point, normal, .. } => (flat(p) - point).dot(normal) < 0.0,
            AnalyticLand::Island { center, radius, .. } => (flat(p) - center).norm() < *radius,
        }
    }

    fn clearance(&self, p: &Vec3) -> Option<(f64, Vec3)> {
        let (d, away, search) = match self {
            AnalyticLand::Coast {
                point,
                normal,
                search,
            } => ((flat(p) - point).dot(normal).max(0.0), *normal, *search),
            AnalyticLand::Island {
                center,
                radius,
                search,
            } => {
                let r = flat(p) - center;
                let n = r.norm();
                let away = if n > 0.0 {
                    r / n
                } else {
                    Vec3::new(1.0, 0.0, 0.0)
                };
                ((n - radius).max(0.0), away, *search)
            }
        };
        (d <= search).then_some((d, away))
    }
}

/// The land of `mission`: a gridded field's land (its fill values, `land_above`, outside
/// its grid) when it has one, else `[land]`, searched within twice the avoidance distance
/// (None: no land).
pub fn land_of(mission: &Mission) -> Option<Arc<dyn LandMask>> {
    if let Some(grid_land) = mission.land() {
        return Some(grid_land);
    }
    analytic_land(&mission.land, 2.0 * avoid_distance(mission))
        .map(|l| Arc::new(l) as Arc<dyn LandMask>)
}

/// The analytic land of a `[land]` section, its clearance searched within `search` (length
/// unit); None without land.
pub fn analytic_land(l: &LandSection, search: f64) -> Option<AnalyticLand> {
    let v = |x: &[f64]| {
        Vec3::new(
            x.first().copied().unwrap_or(0.0),
            x.get(1).copied().unwrap_or(0.0),
            0.0,
        )
    };
    match l.kind {
        LandKind::None => None,
        LandKind::Coast => Some(AnalyticLand::Coast {
            point: v(&l.point),
            normal: v(&l.normal).normalize(),
            search,
        }),
        LandKind::Island => Some(AnalyticLand::Island {
            center: v(&l.center),
            radius: l.radius,
            search,
        }),
    }
}

/// `land.avoid_distance`, or its default formation.radius / 2 (length unit).
pub fn avoid_distance(mission: &Mission) -> f64 {
    mission
        .land
        .avoid_distance
        .unwrap_or(mission.formation.radius / 2.0)
}

/// `land.avoid_gain`, or its default 2·formation.alpha / formation.radius (length unit/s²).
pub fn avoid_gain(mission: &Mission) -> f64 {
    mission
        .land
        .avoid_gain
        .unwrap_or(2.0 * mission.formation.alpha / mission.formation.radius)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_coast_and_an_island_say_where_land_is_and_which_way_is_away() {
        let coast = AnalyticLand::Coast {
            point: Vec3::new(0.0, 10.0, 0.0),
            normal: Vec3::new(0.0, -1.0, 0.0),
            search: 5.0,
        };
        assert!(coast.is_land(&Vec3::new(3.0, 11.0, 0.0)));
        assert!(!coast.is_land(&Vec3::new(3.0, 9.0, 0.0)));
        let (d, n) = coast.clearance(&Vec3::new(3.0, 7.0, 0.0)).unwrap();
        assert!((d - 3.0).abs() < 1e-12 && n == Vec3::new(0.0, -1.0, 0.0));
        assert!(coast.clearance(&Vec3::new(3.0, 0.0, 0.0)).is_none());
        let island = AnalyticLand::Island {
            center: Vec3::zeros(),
            radius: 2.0,
            search: 10.0,
        };
        assert!(island.is_land(&Vec3::new(1.0, 1.0, 0.0)));
        let (d, n) = island.clearance(&Vec3::new(0.0, 5.0, 0.0)).unwrap();
        assert!((d - 3.0).abs() < 1e-12 && (n - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
    }
}
