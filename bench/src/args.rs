//! The arguments of `vbap bench`, the hidden helper roles included. A leaf: it uses no
//! other module of this crate.

use std::path::PathBuf;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Quick run: fewer samples, shorter missions, no N = 256 (a smoke run, < 1 min).
    #[arg(long)]
    pub quick: bool,
    /// Also run N = 1024 (lockstep scaling, real-time sweep, start-up and memory).
    #[arg(long)]
    pub large: bool,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep the run directories (missions, logs, summaries) in this directory (must be
    /// empty or absent). Default: a temporary directory, removed at the end except for
    /// the runs that failed, ran late, rejected states or lost vehicles.
    #[arg(long)]
    pub work_dir: Option<PathBuf>,
    /// Instead: the cost of a mission spread over 3 hosts (network namespaces: root)
    /// against raw Zenoh over the same links (bench/src/hosts.rs).
    #[arg(long)]
    pub hosts: bool,
    /// Instead: only section 7, the N = 4 state hop against the raw iceoryx2 floor and
    /// against the skeleton's hop, 5 interleaved repetitions (bench/src/overhead.rs).
    #[arg(long, conflicts_with = "hosts")]
    pub hop: bool,
    /// Helper role of a peer process (internal).
    #[arg(long, hide = true, value_enum)]
    pub role: Option<Role>,
    /// Helper: the private iceoryx2 domain (mission name) of the floor (internal).
    #[arg(long, hide = true)]
    pub domain: Option<String>,
    /// Helper: the agent id (internal).
    #[arg(long, hide = true)]
    pub id: Option<usize>,
    /// Helper: the number of agents of the wake-up floor (internal).
    #[arg(long, hide = true)]
    pub agents: Option<usize>,
    /// Helper: warm-up rounds of the fan-out (internal).
    #[arg(long, hide = true)]
    pub warmup: Option<u64>,
    /// Helper: measured rounds of the fan-out (internal).
    #[arg(long, hide = true)]
    pub rounds: Option<usize>,
    /// Helper: the hosts file of the skeleton over hosts (internal).
    #[arg(long, hide = true)]
    pub hosts_file: Option<PathBuf>,
    /// Helper: this host's name in `--hosts-file` (internal).
    #[arg(long, hide = true)]
    pub host: Option<String>,
    /// Helper: exit when this process is no longer our parent (internal).
    #[arg(long, hide = true)]
    pub parent: Option<u32>,
}

/// Helper roles (hidden from `--help`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Role {
    /// Answers iceoryx2 pings.
    IoxPong,
    /// Answers UDP pings.
    UdpPong,
    /// Answers iceoryx2 pings, busy polling (no event, no sleep).
    IoxPongPoll,
    /// Answers UDP pings, busy polling a non-blocking socket.
    UdpPongPoll,
    /// One agent of the wake-up floor.
    WakeAgent,
    /// Spins at the lowest priority, keeping a CPU out of idle (the warm floors).
    Spin,
    /// One agent of the skeleton floor (`skeleton`).
    SkeletonAgent,
    /// The field server of the skeleton floor.
    SkeletonField,
    /// One host's share of the skeleton over hosts (`skeleton_hosts`).
    SkeletonHost,
    /// One receiver of the fan-out through iceoryx2 (`fanout`).
    FanoutIox,
    /// One receiver of the fan-out over UDP.
    FanoutUdp,
}
