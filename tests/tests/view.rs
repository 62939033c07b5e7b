//! The run viewer in a real browser: headless Chromium driven over WebDriver (Debian's
//! `chromium` and `chromium-driver`; .ci/run installs them). A replay: the page loads,
//! shows every vehicle, the slider moves them. A live `vbap run --view`: the page follows
//! the run's progress. Screenshots are kept under target/view-artifacts/. Without Chromium
//! these tests FAIL (they never pass by skipping).

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{json, Value};
use tests::{unique_name, vbap, wait_until, write_mission, ChildGuard, TempDir};

/// An executable found on PATH or in /usr/bin, or a loud failure naming the package.
fn executable(names: &[&str], package: &str) -> PathBuf {
    let path = std::env::var("PATH").unwrap_or_default();
    for name in names {
        for dir in path.split(':').chain(["/usr/bin", "/usr/lib/chromium"]) {
            let p = Path::new(dir).join(name);
            if p.is_file() {
                return p;
            }
        }
    }
    panic!("{names:?} not found: the browser tests need Debian's `{package}` (apt-get install chromium chromium-driver; .ci/run installs them)");
}

/// A free loopback port.
fn free_port() -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").expect("binding a free port");
    l.local_addr().expect("local addr").port()
}

/// chromedriver and a headless Chromium session; the browser is closed and the driver
/// killed when dropped.
struct Browser {
    client: Option<Client>,
    _driver: ChildGuard,
    _profile: TempDir,
}

impl Browser {
    async fn start() -> Self {
        let chromium = executable(&["chromium", "chromium-browser"], "chromium");
        let driver_bin = executable(&["chromedriver"], "chromium-driver");
        let port = free_port();
        let driver = ChildGuard(Some(
            Command::new(driver_bin)
                .arg(format!("--port={port}"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("starting chromedriver"),
        ));
        wait_until(
            || std::net::TcpStream::connect(("127.0.0.1", port)).is_ok(),
            Duration::from_secs(30),
            "chromedriver to listen",
        );
        let profile = TempDir::new("chromium");
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=1400,800",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([format!("--user-data-dir={}", profile.path.display())])
        .collect::<Vec<_>>();
        let mut caps = serde_json::Map::new();
        caps.insert(
            "goog:chromeOptions".into(),
            json!({ "binary": chromium, "args": args }),
        );
        let client = ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
            .capabilities(caps)
            .connect(&format!("http://127.0.0.1:{port}"))
            .await
            .expect("a WebDriver session with headless Chromium");
        Self {
            client: Some(client),
            _driver: driver,
            _profile: profile,
        }
    }

    fn c(&self) -> &Client {
        self.client.as_ref().expect("session open")
    }

    /// Evaluates `expr` in the page.
    async fn eval(&self, expr: &str) -> Value {
        self.c()
            .execute(&format!("return ({expr});"), vec![])
            .await
            .unwrap_or_else(|e| panic!("evaluating {expr}: {e}"))
    }

    /// Waits until `expr` is true in the page (checked every 50 ms; fails after `limit`).
    async fn until(&self, expr: &str, limit: Duration) {
        let start = Instant::now();
        loop {
            if self.eval(expr).await == Value::Bool(true) {
                return;
            }
            let error = self.eval("window.vbap && window.vbap.error").await;
            assert!(error.is_null(), "the page failed: {error}");
            assert!(start.elapsed() < limit, "timed out waiting for {expr}");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// The vehicles drawn: (id, x px, y px).
    async fn drawn(&self) -> Vec<(u64, f64, f64)> {
        let v = self
            .eval("window.vbap.map.drawn.map(d => [d.id, d.px, d.py])")
            .await;
        v.as_array()
            .expect("an array")
            .iter()
            .map(|d| {
                (
                    d[0].as_u64().unwrap(),
                    d[1].as_f64().unwrap(),
                    d[2].as_f64().unwrap(),
                )
            })
            .collect()
    }

    async fn screenshot(&self, name: &str) {
        let png = self.c().screenshot().await.expect("a screenshot");
        let dir = tests::workspace().join("target/view-artifacts");
        std::fs::create_dir_all(&dir).expect("creating target/view-artifacts");
        std::fs::write(dir.join(name), png).expect("writing the screenshot");
        eprintln!("screenshot: {}", dir.join(name).display());
    }

    async fn close(mut self) {
        if let Some(c) = self.client.take() {
            c.close().await.expect("closing the browser");
        }
    }
}

/// Starts `cmd` and returns the first URL it prints (on stdout or stderr) and the child.
fn start_printing_url(mut cmd: Command) -> (String, ChildGuard) {
    let mut child: Child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawning");
    let (tx, rx) = mpsc::channel::<String>();
    for out in [
        Box::new(child.stdout.take().expect("stdout")) as Box<dyn std::io::Read + Send>,
        Box::new(child.stderr.take().expect("stderr")),
    ] {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                eprintln!("| {line}");
                let _ = tx.send(line);
            }
        });
    }
    drop(tx);
    let guard = ChildGuard(Some(child));
    let start = Instant::now();
    loop {
        let line = rx
            .recv_timeout(Duration::from_secs(60).saturating_sub(start.elapsed()))
            .expect("the command printed its URL (it ended, or printed none in 60 s)");
        if let Some(at) = line.find("http://") {
            let url = line[at..]
                .split_whitespace()
                .next()
                .expect("a URL")
                .to_owned();
            return (url, guard);
        }
    }
}

#[tokio::test(flavor = "current_thread")]
async fn a_replay_shows_every_vehicle_and_the_slider_moves_them() {
    let tmp = TempDir::new("view-replay");
    let run = tmp.join("run");
    // Three days of six gliders surfacing every 2 h (25 920 ticks).
    let mission = tests::workspace().join("deploy/missions/glider_surfacing.toml");
    tests::run_ok(
        vbap()
            .arg("sim")
            .arg(&mission)
            .arg("--out")
            .arg(&run)
            .arg("--quiet"),
    );

    let mut view = vbap();
    view.arg("view").arg(&run).args(["--addr", "127.0.0.1:0"]);
    let (url, _server) = start_printing_url(view);
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");

    let b = Browser::start().await;
    let opened = Instant::now();
    b.c().goto(&url).await.expect("opening the page");
    b.until(
        "window.vbap && window.vbap.ready === true",
        Duration::from_secs(60),
    )
    .await;
    eprintln!(
        "replay of a 3-day glider run opened in {:.2} s (navigation to ready; the server read the run before)",
        opened.elapsed().as_secs_f64()
    );
    let first = b.drawn().await;
    assert_eq!(
        first.iter().map(|d| d.0).collect::<Vec<_>>(),
        vec![0, 1, 2, 3, 4, 5]
    );
    assert_eq!(b.eval("window.vbap.charts.length").await, json!(4));
    let t0 = b.eval("document.getElementById('time').textContent").await;

    // The slider, moved by the keyboard as a user would: End goes to the last frame.
    let slider = b.c().find(Locator::Id("slider")).await.expect("the slider");
    slider.send_keys("\u{e010}").await.expect("pressing End");
    b.until(
        "window.vbap.i === window.vbap.frames.length - 1",
        Duration::from_secs(10),
    )
    .await;
    let last = b.drawn().await;
    assert_eq!(last.len(), 6);
    let moved = first
        .iter()
        .zip(&last)
        .filter(|(a, b)| (a.1 - b.1).hypot(a.2 - b.2) > 20.0)
        .count();
    assert_eq!(
        moved, 6,
        "every vehicle moved on the map: {first:?} -> {last:?}"
    );
    let t1 = b.eval("document.getElementById('time').textContent").await;
    assert_ne!(t0, t1);
    // A 3-day mission reads in hours, as the report's axes do.
    assert!(t1.as_str().unwrap().contains("72 h"), "{t1}");

    // Axes read at a glance: time at round steps of the clock with its unit, values with
    // distinct labels (the gradient error of a glider run is a small range), units on the
    // value axes; the map has a scale bar and the field's colour bar.
    let labels = b
        .eval("window.vbap.charts.map((c) => c.vbapLabels || {})")
        .await;
    let charts = labels.as_array().expect("labels of every chart");
    for (j, c) in charts.iter().enumerate() {
        let x: Vec<&str> = c["x"]
            .as_array()
            .expect("time labels")
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        assert!(x.len() >= 2, "chart {j}: {x:?}");
        let hours: Vec<f64> = x
            .iter()
            .map(|l| {
                l.strip_suffix(" h")
                    .unwrap_or_else(|| panic!("chart {j}: {l:?} is not in h"))
                    .parse()
                    .unwrap()
            })
            .collect();
        assert!(
            hours.iter().all(|h| h % 1.0 == 0.0)
                && hours
                    .windows(2)
                    .all(|w| [1.0, 2.0, 3.0, 6.0, 12.0, 24.0].contains(&(w[1] - w[0]))),
            "chart {j}: time ticks at a step of the clock: {x:?}"
        );
        if let Some(y) = c["y"].as_array() {
            let mut seen: Vec<&str> = y.iter().map(|v| v.as_str().unwrap()).collect();
            let n = seen.len();
            seen.dedup();
            assert_eq!(
                seen.len(),
                n,
                "chart {j}: two value ticks read the same: {y:?}"
            );
        }
    }
    let units = b
        .eval("window.vbap.charts.map((c) => c.axes[1].label)")
        .await;
    assert_eq!(units, json!(["V/V_U", "m", "°C/m", "ṡ/v0"]));
    let bar = b.eval("window.vbap.map.overlay").await;
    let scale = bar["scaleBar"]["label"].as_str().expect("a scale bar");
    assert!(
        scale.ends_with(" km") || scale.ends_with(" m"),
        "scale bar {scale:?}"
    );
    assert_eq!(bar["colourBar"]["label"], json!("T (°C)"), "{bar}");
    assert!(
        bar["colourBar"]["ticks"].as_array().unwrap().len() >= 2,
        "{bar}"
    );
    // The status tells the verdict of summary.json.
    let status = b
        .eval("document.getElementById('status').textContent")
        .await;
    let verdict = serde_json::from_str::<Value>(&tests::read(&run.join("summary.json"))).unwrap()
        ["verdict"]
        .clone();
    assert!(
        status.as_str().unwrap().contains(verdict.as_str().unwrap()),
        "{status}"
    );

    // Hovering a vehicle tells its id, age of information and slot error.
    let (id, x, y) = last[0];
    b.eval(&format!(
        "(() => {{ const r = window.vbap.map.canvas.getBoundingClientRect(); window.vbap.map.canvas.dispatchEvent(new MouseEvent('mousemove', {{clientX: r.left + {x}, clientY: r.top + {y}}})); return true; }})()"
    ))
    .await;
    let tip = b.eval("document.getElementById('tip').textContent").await;
    let tip = tip.as_str().unwrap();
    assert!(
        tip.contains(&format!("vehicle {id}"))
            && tip.contains("age of information")
            && tip.contains("slot error"),
        "{tip}"
    );
    b.screenshot("replay.png").await;
    b.close().await;
}

#[tokio::test(flavor = "current_thread")]
async fn a_live_run_is_followed_as_it_progresses() {
    let tmp = TempDir::new("view-live");
    let name = unique_name("viewlive");
    let text = tests::mission::shipped_renamed("lossy_kill", &name);
    let mission = write_mission(&tmp, "live.toml", &text);
    let run = tmp.join("run");
    let mut cmd = vbap();
    cmd.arg("run").arg(&mission).arg("--out").arg(&run).args([
        "--quiet",
        "--pace",
        "4",
        "--duration",
        "80",
        "--view",
        "127.0.0.1:0",
    ]);
    let (url, mut child) = start_printing_url(cmd);

    let b = Browser::start().await;
    b.c().goto(&url).await.expect("opening the page");
    b.until(
        "window.vbap && window.vbap.ready === true",
        Duration::from_secs(60),
    )
    .await;
    // The run's progress: the newest tick whose rows are in truth.csv (written last of a
    // tick's rows). The page must show it (or later) soon after.
    let mut lags = Vec::new();
    let mut positions = Vec::new();
    for _ in 0..5 {
        let truth = tests::read(&run.join("truth.csv"));
        // Complete lines only: the text after the last newline is a row being written.
        let whole = &truth[..truth.rfind('\n').unwrap_or(0)];
        let tick: i64 = whole
            .lines()
            .next_back()
            .and_then(|l| l.split(',').nth(1))
            .and_then(|k| k.parse().ok())
            .unwrap_or(-1);
        let seen = Instant::now();
        b.until(
            &format!("window.vbap.lastTick >= {tick}"),
            Duration::from_secs(20),
        )
        .await;
        lags.push(seen.elapsed().as_secs_f64());
        positions.push(b.drawn().await);
        tokio::time::sleep(Duration::from_millis(1500)).await;
    }
    eprintln!("live view: the page showed the run's newest tick within {lags:.3?} s");
    assert_eq!(positions[0].len(), 6);
    let first = &positions[0];
    let last = &positions[positions.len() - 1];
    assert!(
        first
            .iter()
            .zip(last)
            .any(|(a, b)| (a.1 - b.1).hypot(a.2 - b.2) > 1.0),
        "the vehicles moved on the page while the run went on: {first:?} -> {last:?}"
    );
    b.screenshot("live.png").await;
    let status = child.wait();
    assert!(status.success(), "vbap run: {status}");
    b.close().await;
    assert!(
        tests::leftover_files(&name).is_empty(),
        "leftovers of {name}"
    );
}

/// CPU time (s) of the thread named `name` of process `pid`, if it is there.
fn thread_cpu_s(pid: u32, name: &str) -> Option<f64> {
    let ticks_per_s = 100.0; // USER_HZ, fixed at 100 on Linux for /proc
    for task in std::fs::read_dir(format!("/proc/{pid}/task")).ok()? {
        let task = task.ok()?.path();
        let comm = std::fs::read_to_string(task.join("comm")).unwrap_or_default();
        if comm.trim() != name {
            continue;
        }
        let stat = std::fs::read_to_string(task.join("stat")).ok()?;
        // Fields after the command's closing parenthesis: utime and stime are the 12th and 13th.
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split(' ').collect();
        let (u, s): (f64, f64) = (f.get(11)?.parse().ok()?, f.get(12)?.parse().ok()?);
        return Some((u + s) / ticks_per_s);
    }
    None
}

/// One paced run of the paper's mission with 64 vehicles; with `browser`, served with
/// `--view` and watched by headless Chromium. (late ticks, viewer CPU s, wall s).
async fn paced_64(browser: bool) -> (u64, Option<f64>, f64) {
    let tmp = TempDir::new("view-bench");
    let name = unique_name("viewbench");
    let text = tests::mission::shipped_renamed("paper", &name);
    let mission = write_mission(&tmp, "bench.toml", &text);
    let run = tmp.join("run");
    let mut cmd = vbap();
    cmd.arg("run").arg(&mission).arg("--out").arg(&run).args([
        "--quiet",
        "--pace",
        "1",
        "--duration",
        "20",
        "--set",
        "vehicles.count=64",
        "--set",
        "formation.radius=17.7",
    ]);
    let started = Instant::now();
    let mut cpu = None;
    if browser {
        cmd.args(["--view", "127.0.0.1:0"]);
        let (url, mut child) = start_printing_url(cmd);
        let b = Browser::start().await;
        b.c().goto(&url).await.expect("opening the page");
        b.until(
            "window.vbap && window.vbap.ready === true",
            Duration::from_secs(60),
        )
        .await;
        let pid = child.pid();
        // The viewer's thread lives as long as the run: its last reading is its total.
        while let Some(s) = thread_cpu_s(pid, "vbap-view") {
            cpu = Some(s);
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        assert!(child.wait().success());
        b.close().await;
    } else {
        let mut child = ChildGuard(Some(cmd.stdout(Stdio::null()).spawn().expect("vbap run")));
        assert!(child.wait().success());
    }
    let wall = started.elapsed().as_secs_f64();
    let summary: Value = serde_json::from_str(&tests::read(&run.join("summary.json"))).unwrap();
    (summary["late_ticks"].as_u64().unwrap_or(0), cpu, wall)
}

/// Bench (not a test of speed: prints, asserts nothing about it): a live view of N = 64 at
/// pace 1, the viewer's CPU share and the mission's late ticks with and without a browser.
/// `cargo test --release -p tests --test view -- --ignored --nocapture bench`
#[tokio::test(flavor = "current_thread")]
#[ignore = "a bench: run it on purpose"]
async fn bench_live_view_of_64_vehicles_at_pace_1() {
    let (late_without, _, wall_without) = paced_64(false).await;
    let (late_with, cpu, wall_with) = paced_64(true).await;
    let cpu = cpu.expect("the viewer's thread was seen");
    println!("live view, N = 64, pace 1, 20 s of mission (400 ticks):");
    println!("  without a viewer: {late_without} late ticks ({wall_without:.1} s wall)");
    println!(
        "  with --view and a headless Chromium watching: {late_with} late ticks ({wall_with:.1} s wall)"
    );
    println!(
        "  the viewer's thread: {cpu:.2} s CPU = {:.1} % of one core over the 20 s the mission runs",
        100.0 * cpu / 20.0
    );
}

#[test]
fn bad_view_arguments_exit_2_naming_them() {
    let tmp = TempDir::new("view-args");
    let out = vbap()
        .arg("view")
        .arg(tmp.join("nothing"))
        .output()
        .expect("vbap view");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a run directory"));

    let run = tmp.join("run");
    let paper = tests::workspace().join("deploy/missions/paper.toml");
    let out = vbap()
        .arg("sim")
        .arg(&paper)
        .arg("--out")
        .arg(&run)
        .arg("--view")
        .output()
        .expect("vbap sim");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--view"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    tests::run_ok(vbap().arg("sim").arg(&paper).arg("--out").arg(&run).args([
        "--quiet",
        "--duration",
        "1",
    ]));
    let out = vbap()
        .arg("view")
        .arg(&run)
        .args(["--addr", "127.0.0.1:99999"])
        .output()
        .expect("vbap view");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("cannot listen on 127.0.0.1:99999"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
