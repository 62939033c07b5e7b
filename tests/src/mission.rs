//! The small test mission the end-to-end tests share: a few vehicles climbing a noisy
//! Gaussian hill (peak 10 at (6, 3), width 6, σ = 0.1), with the keys a test varies set
//! by name and anything else appended as text:
//! `GaussianHill::new(name).count(5).pace("1.0").toml()` is such a mission's text.

/// A builder of the shared Gaussian-hill mission file (TOML text).
#[derive(Clone, Debug)]
pub struct GaussianHill {
    name: String,
    seed: u64,
    duration: f64,
    pace: Option<String>,
    objective: bool,
    count: usize,
    start_at_origin: bool,
    tail: String,
}

impl GaussianHill {
    /// Mission `name`: seed 7, 20 s of mission at dt = 0.05 s, goal "max" in 2-D with
    /// tolerance 1.0, 4 vehicles started within 0.3 m of the origin, the default pace.
    pub fn new(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            seed: 7,
            duration: 20.0,
            pace: None,
            objective: true,
            count: 4,
            start_at_origin: true,
            tail: String::new(),
        }
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
        self.objective = false;
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
            "\n[mission]\nname = \"{}\"\nseed = {}\nduration = {:?}\ndt = 0.05\n",
            self.name, self.seed, self.duration
        );
        if let Some(pace) = &self.pace {
            text.push_str(&format!("pace = {pace}\n"));
        }
        if self.objective {
            text.push_str("goal = \"max\"\ndim = 2\ntolerance = 1.0\n");
        }
        text.push_str(
            "\n[field]\nkind = \"gaussian\"\ncenter = [6.0, 3.0]\namplitude = 10.0\n\
             width = 6.0\nnoise_std = 0.1\n\n[vehicles]\n",
        );
        text.push_str(&format!("count = {}\n", self.count));
        if self.start_at_origin {
            text.push_str("start = [0.0, 0.0]\n");
        }
        text.push_str("start_spread = 0.3\n");
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
