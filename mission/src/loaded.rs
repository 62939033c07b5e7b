//! [`Loaded`]: a value loaded alongside a mission — a grid read from a file, the u and v
//! grids of a current, a land mask — kept inside structures that are cloned, compared and
//! serialised (the mission's sections, the planner's parameters). It takes no part in
//! equality (the keys it was loaded from do) and is never serialised (its field carries
//! `#[serde(skip)]`; a value restored from a checkpoint gets it again from its mission).

/// A loaded value, or none; equal to every other `Loaded` of its type.
#[derive(Clone)]
pub struct Loaded<T>(pub Option<T>);

impl<T> Default for Loaded<T> {
    fn default() -> Self {
        Loaded(None)
    }
}

impl<T> PartialEq for Loaded<T> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<T> std::fmt::Debug for Loaded<T> {
    /// Only whether a value is loaded and its type (a grid's values would fill the page).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some(_) => write!(f, "Loaded({})", std::any::type_name::<T>()),
            None => write!(f, "Loaded(none)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Loaded;

    #[test]
    fn a_loaded_value_takes_no_part_in_equality_and_debug_stays_short() {
        let a = Loaded(Some(vec![1.0; 1000]));
        assert_eq!(a, Loaded(None));
        assert_eq!(format!("{:?}", Loaded::<u8>(None)), "Loaded(none)");
        assert!(format!("{a:?}").len() < 60, "{a:?}");
    }
}
