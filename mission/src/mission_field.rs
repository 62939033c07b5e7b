//! The environment a mission describes, [`Mission::field`]. It lives apart from `config`
//! so that the mission file's parsing and validation do not depend on the fields (which
//! are built from their `[field]` section): `field` uses `config`, this module uses both.

use std::path::Path;
use std::sync::Arc;

use crate::config::{ConfigError, FieldKind, Mission};
use crate::field::Field;
use crate::grid::{AxisNames, GridField, GridSpec};

impl Mission {
    /// The environment this mission describes.
    pub fn field(&self) -> Field {
        Field::from_config(&self.field, self.mission.dim)
    }

    /// The land of this mission's field, for keeping vehicles and the body centre in water:
    /// a gridded field's land and missing data, and everything outside its grid; `None` for
    /// the analytic fields (no land).
    pub fn land(&self) -> Option<Arc<dyn crate::land::LandMask>> {
        let grid = self.field.grid.0.as_ref()?;
        Some(Arc::clone(grid) as Arc<dyn crate::land::LandMask>)
    }

    /// True when the mission's field kind lets the field move with time: an `eddy` (it
    /// drifts at `field.velocity`), a `front` (it moves at `field.speed`) or a gridded field
    /// with more than one time. Decided from the kind alone (a still eddy, velocity zero,
    /// still counts): the planner's drift estimate (`body.track_drift`) runs on these only,
    /// so on every other field it is the paper's planner bit for bit.
    pub fn field_may_move(&self) -> bool {
        match self.field.kind {
            FieldKind::Eddy | FieldKind::Front => true,
            FieldKind::Grid => self.grid().is_some_and(|g| g.times.len() > 1),
            _ => false,
        }
    }

    /// The grid of a `kind = "grid"` field, if loaded.
    pub fn grid(&self) -> Option<&Arc<GridField>> {
        self.field.grid.0.as_ref()
    }

    /// Reads the grid of a `kind = "grid"` field (nothing for other kinds): `field.file`
    /// relative to `base` (the mission file's directory), made absolute in the mission so the
    /// resolved mission names it wherever it is written. An error names the mission, the key,
    /// the file, the variable and what is wrong.
    pub(crate) fn load_grid(&mut self, base: Option<&Path>) -> Result<(), ConfigError> {
        self.load_field_grid(base)?;
        self.load_current_grid(base)
    }

    /// A file named by the mission, relative to `base`, made absolute.
    fn mission_path(given: &str, base: Option<&Path>) -> std::path::PathBuf {
        let mut file = Path::new(given).to_path_buf();
        if file.is_relative() {
            if let Some(b) = base {
                file = b.join(file);
            }
        }
        std::path::absolute(&file).unwrap_or(file)
    }

    /// Reads the u and v grids of a `current.kind = "grid"`: `current.file`, variables
    /// `current.u` / `current.v` (default "u", "v"), axes found and projected as the
    /// field's (`field.geographic`, `field.origin`, coordinate names `field.x` ...).
    fn load_current_grid(&mut self, base: Option<&Path>) -> Result<(), ConfigError> {
        use crate::config::CurrentKind;
        if self.current.kind != CurrentKind::Grid || self.current.grid.0.is_some() {
            return Ok(());
        }
        let given = self.current.file.clone().unwrap_or_default();
        let file = Self::mission_path(&given, base);
        let f = &self.field;
        let load = |variable: &str| {
            let spec = GridSpec {
                file: file.clone(),
                variable: Some(variable.to_string()),
                names: AxisNames {
                    x: f.x.clone(),
                    y: f.y.clone(),
                    z: f.z.clone(),
                    time: f.time.clone(),
                },
                geographic: f.geographic,
                origin: f.origin.as_ref().map(|o| [o[0], o[1]]),
                land_above: None,
                extent: f.extent.clone(),
                dim: self.mission.dim,
            };
            GridField::load(&spec)
                .map(Arc::new)
                .map_err(|e| ConfigError::Invalid {
                    origin: self.origin.clone(),
                    key: "current.file".into(),
                    value: format!("{given:?}"),
                    reason: e.to_string(),
                })
        };
        let u = load(self.current.u.as_deref().unwrap_or("u"))?;
        let v = load(self.current.v.as_deref().unwrap_or("v"))?;
        self.current.file = Some(file.display().to_string());
        self.current.grid = crate::loaded::Loaded(Some([u, v]));
        Ok(())
    }

    /// Reads the grid of a `kind = "grid"` field (see [`Mission::load_grid`]).
    fn load_field_grid(&mut self, base: Option<&Path>) -> Result<(), ConfigError> {
        if self.field.kind != FieldKind::Grid || self.field.grid.0.is_some() {
            return Ok(());
        }
        let f = &self.field;
        let given = f.file.clone().unwrap_or_default();
        let file = Self::mission_path(&given, base);
        let spec = GridSpec {
            file: file.clone(),
            variable: f.variable.clone(),
            names: AxisNames {
                x: f.x.clone(),
                y: f.y.clone(),
                z: f.z.clone(),
                time: f.time.clone(),
            },
            geographic: f.geographic,
            origin: f.origin.as_ref().map(|o| [o[0], o[1]]),
            land_above: f.land_above,
            extent: f.extent.clone(),
            dim: self.mission.dim,
        };
        let grid = GridField::load(&spec).map_err(|e| ConfigError::Invalid {
            origin: self.origin.clone(),
            key: "field.file".into(),
            value: format!("{given:?}"),
            reason: e.to_string(),
        })?;
        self.field.file = Some(file.display().to_string());
        self.field.grid = crate::loaded::Loaded(Some(Arc::new(grid)));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Goal;
    use std::path::Path;
    use vbap_math::Vec3;

    fn parse(text: &str) -> Mission {
        Mission::from_toml_str(text, "missions/x.toml").unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn mission_field_is_built_from_the_config() {
        let m = parse("[mission]\nname = \"a\"\ngoal = \"max\"\n[field]\ncenter = [3.0, 4.0]\namplitude = 10.0\nwidth = 15.0\n");
        assert_eq!(
            m.field().optimum(0.0, Goal::Max),
            Some(Vec3::new(3.0, 4.0, 0.0))
        );
        let front = parse("[mission]\nname = \"f\"\ndim = 3\n[field]\nkind = \"front\"\nnormal = [0.0, 1.0, 1.0]\namplitude = -1.5\nwidth = 0.3\n[vehicles]\ncount = 6\nstart = [0.1, 0.2, 0.3]\n");
        assert!(matches!(front.field(), Field::MovingFront { dim: 3, .. }));
        assert!(front.land().is_none(), "an analytic field has no land");
    }

    #[test]
    fn the_fields_of_the_shipped_missions_have_an_optimum() {
        let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions"));
        let mut n = 0;
        for entry in std::fs::read_dir(dir).expect("deploy/missions exists") {
            let path = entry.expect("dir entry").path();
            if path.extension().is_none_or(|e| e != "toml") {
                continue;
            }
            let m = Mission::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                m.field().optimum(0.0, m.mission.goal).is_some(),
                "{}: the field has no optimum for the goal",
                path.display()
            );
            n += 1;
        }
        assert!(n >= 3, "{n} missions");
    }
}
