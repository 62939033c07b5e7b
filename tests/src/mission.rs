//! The small test mission the end-to-end tests share: a few vehicles climbing a noisy
//! Gaussian hill (peak 10 at (6, 3), width 6, σ = 0.1), with the keys a test varies set
//! by name and anything else appended as text:
//! `GaussianHill::new(name).count(5).pace("1.0").toml()` is such a mission's text.
//! [`GaussianHill::stiff`] is its variant of the fault and liveness tests: a stiff,
//! damped formation that settles within a few seconds.

/// A builder of the shared Gaussian-hill mission file (TOML text).
#[derive(Clone, Debug)]
pub struct GaussianHill {
    name: String,
    seed: u64,
    duration: f64,
    dt: f64,
    pace: Option<String>,
    objective: Objective,
    mission_keys: String,
    count: usize,
    start_at_origin: bool,
    start_spread: bool,
    tail: String,
}

/// Which objective keys `[mission]` states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Objective {
    /// `goal = "max"`, `dim = 2`, `tolerance = 1.0`.
    Full,
    /// `goal = "max"` alone.
    GoalOnly,
    /// None: the mission's defaults.
    Default,
}

impl GaussianHill {
    /// Mission `name`: seed 7, 20 s of mission at dt = 0.05 s, goal "max" in 2-D with
    /// tolerance 1.0, 4 vehicles started within 0.3 m of the origin, the default pace.
    pub fn new(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            seed: 7,
            duration: 20.0,
            dt: 0.05,
            pace: None,
            objective: Objective::Full,
            mission_keys: String::new(),
            count: 4,
            start_at_origin: true,
            start_spread: true,
            tail: String::new(),
        }
    }

    /// The fault and liveness tests' variant: `goal = "max"` alone, the default start and
    /// spread, `vehicles.damping = 5`, a stiff formation (`alpha = 60`, `radius = 1.2`: it
    /// settles fast) followed by `formation_keys`, then `[body] v_u = 10`. Seed 7 unless
    /// set; more sections go after it with [`GaussianHill::then`].
    pub fn stiff(name: &str, formation_keys: &str) -> Self {
        let mut m = Self::new(name);
        m.objective = Objective::GoalOnly;
        m.start_at_origin = false;
        m.start_spread = false;
        m.tail = format!(
            "damping = 5.0\n\n[formation]\nalpha = 60.0\nradius = 1.2\n{formation_keys}\n[body]\nv_u = 10.0\n"
        );
        m
    }

    /// `mission.dt`, s.
    pub fn dt(mut self, seconds: f64) -> Self {
        self.dt = seconds;
        self
    }

    /// More `[mission]` keys, as TOML lines.
    pub fn mission_keys(mut self, text: &str) -> Self {
        self.mission_keys.push_str(text);
        self
    }

    /// `mission.seed`.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// `mission.duration`, s.
    pub fn duration(mut self, seconds: f64) -> Self {
        self.duration = seconds;
        self
    }

    /// `mission.pace`, as TOML (`"\"lockstep\""` or a factor such as `"1.0"`).
    pub fn pace(mut self, toml_value: &str) -> Self {
        self.pace = Some(toml_value.to_owned());
        self
    }

    /// Leaves out `goal`, `dim` and `tolerance` (the mission's defaults apply).
    pub fn default_objective(mut self) -> Self {
        self.objective = Objective::Default;
        self
    }

    /// `vehicles.count`.
    pub fn count(mut self, count: usize) -> Self {
        self.count = count;
        self
    }

    /// Leaves out `vehicles.start` (the default start applies).
    pub fn default_start(mut self) -> Self {
        self.start_at_origin = false;
        self
    }

    /// Text appended right after `vehicles.start_spread`: more `[vehicles]` keys, then any
    /// further sections.
    pub fn then(mut self, text: &str) -> Self {
        self.tail.push_str(text);
        self
    }

    /// The mission file's text.
    pub fn toml(&self) -> String {
        let mut text = format!(
            "\n[mission]\nname = \"{}\"\nseed = {}\nduration = {:?}\ndt = {:?}\n",
            self.name, self.seed, self.duration, self.dt
        );
        if let Some(pace) = &self.pace {
            text.push_str(&format!("pace = {pace}\n"));
        }
        match self.objective {
            Objective::Full => text.push_str("goal = \"max\"\ndim = 2\ntolerance = 1.0\n"),
            Objective::GoalOnly => text.push_str("goal = \"max\"\n"),
            Objective::Default => {}
        }
        text.push_str(&self.mission_keys);
        text.push_str(
            "\n[field]\nkind = \"gaussian\"\ncenter = [6.0, 3.0]\namplitude = 10.0\n\
             width = 6.0\nnoise_std = 0.1\n\n[vehicles]\n",
        );
        text.push_str(&format!("count = {}\n", self.count));
        if self.start_at_origin {
            text.push_str("start = [0.0, 0.0]\n");
        }
        if self.start_spread {
            text.push_str("start_spread = 0.3\n");
        }
        text.push_str(&self.tail);
        text
    }
}

/// The text of the shipped mission `deploy/missions/<stem>.toml`, renamed `name` (so that
/// tests running at once never share an iceoryx2 domain).
pub fn shipped_renamed(stem: &str, name: &str) -> String {
    let file = crate::workspace().join(format!("deploy/missions/{stem}.toml"));
    let shipped = format!("name = \"{stem}\"");
    let text = crate::read(&file);
    assert!(
        text.contains(&shipped),
        "{} names itself {stem}",
        file.display()
    );
    text.replacen(&shipped, &format!("name = \"{name}\""), 1)
}
