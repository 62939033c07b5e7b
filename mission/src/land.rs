//! Land as data: where a vehicle or the virtual body centre may not go.
//!
//! The paper's fields have no land (its vehicles move in open water); a gridded field from a
//! file may (its fill values, NaN, or `land_above`), so the motion side asks a [`LandMask`]
//! whether a position is land and how far the nearest land is. `Mission::land` gives the
//! mask of a mission (`None` for the analytic fields).

use vbap_math::Vec3;

/// Where the land is, for the motion side (keeping vehicles and the body centre in water).
pub trait LandMask: Send + Sync + std::fmt::Debug {
    /// Whether position `p` (length unit) is land (or outside the data, which counts as land).
    fn is_land(&self, p: &Vec3) -> bool;
    /// The distance (length unit) from `p` to the nearest land and the unit direction pointing
    /// AWAY from it, or `None` when no land lies within the mask's search radius.
    fn clearance(&self, p: &Vec3) -> Option<(f64, Vec3)>;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Land is the half plane x > 10.
    #[derive(Debug)]
    struct Coast;

    impl LandMask for Coast {
        fn is_land(&self, p: &Vec3) -> bool {
            p.x > 10.0
        }
        fn clearance(&self, p: &Vec3) -> Option<(f64, Vec3)> {
            let d = 10.0 - p.x;
            (d < 5.0).then(|| (d.max(0.0), Vec3::new(-1.0, 0.0, 0.0)))
        }
    }

    #[test]
    fn a_mask_is_usable_as_a_shared_trait_object() {
        let mask: std::sync::Arc<dyn LandMask> = std::sync::Arc::new(Coast);
        assert!(mask.is_land(&Vec3::new(11.0, 0.0, 0.0)));
        assert!(!mask.is_land(&Vec3::new(9.0, 0.0, 0.0)));
        let (d, away) = mask
            .clearance(&Vec3::new(8.0, 3.0, 0.0))
            .expect("land within 5");
        assert_eq!(d, 2.0);
        assert_eq!(away, Vec3::new(-1.0, 0.0, 0.0));
        assert!(mask.clearance(&Vec3::new(0.0, 0.0, 0.0)).is_none());
    }
}
