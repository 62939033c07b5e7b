//! The viewer's server over real HTTP: the page and its files, the JSON of a finished run
//! (read by column name, decimated), and the stream of a run whose files grow.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::time::Duration;

use serde_json::Value;
use vbap_wire::rundir::{BODY_HEADER, FORMATION_HEADER, TRUTH_HEADER, VEHICLES_HEADER};

const MISSION: &str =
    "[mission]\nname = \"synthetic\"\nduration = 10.0\ndt = 0.1\ngoal = \"min\"\n\
[field]\nkind = \"quadratic\"\ncenter = [20.0, 10.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\n\
[vehicles]\ncount = 3\n[formation]\nradius = 1.0\nalpha = 1.0\n";

/// Appends rows of ticks `ticks` to the run in `dir` (3 vehicles moving along x; vehicle
/// 2 dead from tick 20 on; reports of vehicle 0 delivered every 5 ticks), `extra`: a
/// column the viewer does not know, added at the end (as later columns will be).
fn append_ticks(dir: &Path, ticks: std::ops::Range<u64>) {
    let open = |name: &str, header: &str| {
        let path = dir.join(name);
        let new = !path.exists();
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .unwrap();
        if new {
            writeln!(f, "{header}").unwrap();
        }
        f
    };
    let mut veh = open("vehicles.csv", &format!("{VEHICLES_HEADER},extra"));
    let mut body = open("body.csv", BODY_HEADER);
    let mut form = open("formation.csv", FORMATION_HEADER);
    let mut truth = open("truth.csv", TRUTH_HEADER);
    let mut events = open("events.jsonl", "");
    let cols = |h: &str| h.split(',').count();
    for k in ticks {
        let t = k as f64 * 0.1;
        for id in 0..3u32 {
            let dead = id == 2 && k >= 20;
            if !dead {
                let x = t + id as f64;
                let mut row = vec![
                    format!("{t}"),
                    k.to_string(),
                    id.to_string(),
                    format!("{x}"),
                ];
                row.push(format!("{}", id as f64 * 0.5));
                row.resize(cols(VEHICLES_HEADER), "0".into());
                row.push("zz".into());
                writeln!(veh, "{}", row.join(",")).unwrap();
            }
            let age = if id == 0 { (k % 5) as f64 * 0.1 } else { t };
            let contact = if dead {
                "dead"
            } else if id == 1 {
                "submerged"
            } else {
                "contact"
            };
            let (age, err) = if dead {
                (String::new(), String::new())
            } else {
                (format!("{age}"), "0.1".into())
            };
            writeln!(form, "{t},{k},{id},{contact},{age},{err},1,1").unwrap();
        }
        let mut b: Vec<String> = vec!["0".into(); cols(BODY_HEADER)];
        let bh: Vec<&str> = BODY_HEADER.split(',').collect();
        let mut set = |name: &str, v: String| {
            let i = bh.iter().position(|c| *c == name).unwrap();
            b[i] = v;
        };
        set("t", format!("{t}"));
        set("k", k.to_string());
        set("rx", format!("{}", t + 1.0));
        set("ry", "0.25".into());
        set("scale", "1".into());
        set("n_vehicles", if k >= 20 { "2" } else { "3" }.into());
        set("grad_x", "1".into());
        set("true_grad_x", "0.5".into());
        writeln!(body, "{}", b.join(",")).unwrap();
        writeln!(
            truth,
            "{t},{k},0.5,{},1,0.1,3,3,0.9",
            if k == 7 { 40.0 } else { 0.4 }
        )
        .unwrap();
        writeln!(
            events,
            "{{\"t\":{t},\"k\":{k},\"kind\":\"link_drop\",\"vehicle\":1}}"
        )
        .unwrap();
        if k == 20 {
            writeln!(events, "{{\"t\":{t},\"k\":{k},\"kind\":\"lost\",\"vehicle\":2,\"detail\":{{\"cause\":\"scheduled kill\"}}}}").unwrap();
        }
    }
}

fn run_dir(ticks: u64, finished: bool) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mission.toml"), MISSION).unwrap();
    append_ticks(dir.path(), 0..ticks);
    if finished {
        std::fs::write(
            dir.path().join("summary.json"),
            "{\"verdict\":\"converged\"}",
        )
        .unwrap();
    }
    dir
}

/// GET `path`: (status, content type, body).
fn get(addr: SocketAddr, path: &str) -> (u16, String, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a response head");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let status = head.split(' ').nth(1).unwrap().parse().unwrap();
    let ctype = head
        .lines()
        .find_map(|l| {
            l.to_ascii_lowercase()
                .strip_prefix("content-type: ")
                .map(str::to_owned)
        })
        .unwrap_or_default();
    (status, ctype, raw[split + 4..].to_vec())
}

fn json(addr: SocketAddr, path: &str) -> Value {
    let (status, ctype, body) = get(addr, path);
    assert_eq!(status, 200, "{path}");
    assert!(ctype.contains("json"), "{path}: {ctype}");
    serde_json::from_slice(&body).unwrap()
}

#[test]
fn a_finished_run_is_served_whole_and_decimated() {
    let dir = run_dir(60, true);
    let viewer = vbap_view::spawn(dir.path(), "127.0.0.1:0", false).unwrap();
    let addr = viewer.addr();
    assert!(addr.ip().is_loopback());

    let (status, ctype, page) = get(addr, "/");
    assert_eq!(status, 200);
    assert!(ctype.starts_with("text/html"));
    let page = String::from_utf8(page).unwrap();
    assert!(page.contains("/vendor/uPlot.iife.min.js") && !page.contains("https://"));
    for file in [
        "/app.js",
        "/map.js",
        "/style.css",
        "/vendor/uPlot.iife.min.js",
        "/vendor/uPlot.min.css",
    ] {
        let (status, _, body) = get(addr, file);
        assert_eq!(status, 200, "{file}");
        assert!(!body.is_empty(), "{file}");
    }
    assert_eq!(get(addr, "/nothing").0, 404);

    let meta = json(addr, "/api/meta");
    assert_eq!(meta["name"], "synthetic");
    assert_eq!(meta["ticks"], 60);
    assert_eq!(meta["vehicles"], 3);
    assert_eq!(meta["finished"], true);
    assert_eq!(meta["verdict"], "converged");
    assert_eq!(meta["link_drops"], 60);

    let all = json(addr, "/api/frames?max=100000")["frames"].clone();
    assert_eq!(all.as_array().unwrap().len(), 60);
    let f25 = &all[25];
    assert_eq!(f25["k"], 25);
    let v = f25["v"].as_array().unwrap();
    assert_eq!(v.len(), 3, "the dead vehicle is still drawn");
    // Vehicle 0 at x = t; the dead one where it was last seen (tick 19), contact "dead".
    assert!((v[0][1].as_f64().unwrap() - 2.5).abs() < 1e-5, "{}", v[0]);
    assert_eq!(v[2][3], 4);
    assert!((v[2][1].as_f64().unwrap() - 3.9).abs() < 1e-5, "{}", v[2]);
    assert!(v[2][4].is_null() && v[2][5].is_null());
    // Pulses: vehicle 0's report arrives every 5 ticks (its age drops), vehicle 1's never.
    assert_eq!(f25["v"][0][6], 1);
    assert_eq!(all[26]["v"][0][6], 0);
    assert_eq!(f25["v"][1][6], 0);
    // Slots: the design of the tick's members (2 after the loss), about the body.
    assert_eq!(all[10]["s"].as_array().unwrap().len(), 3);
    assert_eq!(f25["s"].as_array().unwrap().len(), 2);
    assert_eq!(f25["o"], serde_json::json!([20.0, 10.0]));

    let some = json(addr, "/api/frames?max=7")["frames"].clone();
    let ks: Vec<u64> = some
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["k"].as_u64().unwrap())
        .collect();
    assert_eq!(ks.len(), 7);
    assert_eq!((ks[0], ks[6]), (0, 59));
    // A skipped tick's delivery still pulses the next frame.
    assert!(some.as_array().unwrap()[1..]
        .iter()
        .all(|f| f["v"][0][6] == 1));

    let p = json(addr, "/api/panels?max=10");
    let n = p["t"].as_array().unwrap().len();
    assert!(n <= 10, "{n} points");
    // The spike of V seen at tick 7 survives the decimation.
    let seen: Vec<f64> = p["v_seen"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(seen.contains(&40.0), "{seen:?}");
    assert!((p["grad_err"][0].as_f64().unwrap() - 0.5).abs() < 1e-6);
    let dist = p["dist"][0].as_f64().unwrap();
    assert!(
        (dist - (19.0f64.powi(2) + 9.75f64.powi(2)).sqrt()).abs() < 1e-3,
        "{dist}"
    );

    let events = json(addr, "/api/events");
    assert_eq!(events["link_drops"], 60);
    assert_eq!(
        events["events"],
        serde_json::json!([{"t": 2.0, "k": 20, "kind": "lost", "vehicle": 2, "why": "scheduled kill"}])
    );

    let field = json(addr, "/api/field?n=16");
    assert_eq!(
        (field["nx"].as_u64(), field["ny"].as_u64()),
        (Some(16), Some(16))
    );
    assert_eq!(
        field["values"].as_array().unwrap().len(),
        1,
        "a still field: one grid"
    );
    assert_eq!(field["values"][0].as_array().unwrap().len(), 256);
    assert!(field["min"].as_f64().unwrap() >= 0.0);
}

/// Reads SSE messages from `s` until one `update` arrives; its data.
fn next_update(s: &mut BufReader<TcpStream>) -> Value {
    let mut event = String::new();
    loop {
        let mut line = String::new();
        assert!(s.read_line(&mut line).unwrap() > 0, "the stream ended");
        let line = line.trim_end();
        if let Some(e) = line.strip_prefix("event: ") {
            event = e.to_owned();
        } else if let Some(d) = line.strip_prefix("data: ") {
            if event == "update" {
                return serde_json::from_str(d).unwrap();
            }
        }
    }
}

fn open_stream(addr: SocketAddr, query: &str) -> BufReader<TcpStream> {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(s, "GET /api/stream{query} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
    let mut r = BufReader::new(s);
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    assert!(line.starts_with("HTTP/1.1 200"), "{line}");
    r
}

#[test]
fn a_growing_run_is_streamed_newest_frame_first_and_a_stalled_browser_holds_nothing() {
    let dir = run_dir(5, false);
    let viewer = vbap_view::spawn(dir.path(), "127.0.0.1:0", true).unwrap();
    let addr = viewer.addr();
    let meta = json(addr, "/api/meta");
    assert_eq!(
        (meta["ticks"].as_u64(), meta["finished"].as_bool()),
        (Some(5), Some(false))
    );

    // A browser that connects and then never reads.
    let _stalled = open_stream(addr, "?from=0");
    let mut s = open_stream(addr, "?from=5&events=0");
    let u = next_update(&mut s);
    assert_eq!(u["ticks"], 5);
    assert_eq!(u["frame"]["k"], 4);
    assert_eq!(
        u["panels"]["t"].as_array().unwrap().len(),
        0,
        "the page has ticks 0..5"
    );

    // The run writes on, the last row of truth.csv cut in the middle: it waits for its end.
    append_ticks(dir.path(), 5..30);
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(dir.path().join("truth.csv"))
        .unwrap();
    write!(f, "3.0,30,0.5").unwrap();
    let (mut panels, mut events) = (0, Vec::new());
    let u = loop {
        let u = next_update(&mut s);
        panels += u["panels"]["t"].as_array().unwrap().len();
        events.extend(
            u["events"]
                .as_array()
                .unwrap()
                .iter()
                .map(|e| e["kind"].clone()),
        );
        if u["ticks"] == 30 {
            break u;
        }
    };
    assert_eq!(u["frame"]["k"], 29, "the newest frame");
    assert_eq!(panels, 25, "every tick's panel point, once");
    assert_eq!(events, vec![Value::from("lost")]);
    // The cut line ends short (as an interrupted run's may): skipped.
    writeln!(f).unwrap();

    // Many more ticks at once: still one message with the newest frame, decimated panels.
    append_ticks(dir.path(), 30..5000);
    let u = loop {
        let u = next_update(&mut s);
        if u["ticks"] == 5000 {
            break u;
        }
    };
    assert_eq!(u["frame"]["k"], 4999);
    assert!(u["panels"]["t"].as_array().unwrap().len() <= vbap_view::server::STREAM_POINTS);

    std::fs::write(dir.path().join("summary.json"), "{\"verdict\":\"stalled\"}").unwrap();
    let u = loop {
        let u = next_update(&mut s);
        if u["finished"] == true {
            break u;
        }
    };
    assert_eq!(u["verdict"], "stalled");
    assert_eq!(json(addr, "/api/meta")["ticks"], 5000);
}

#[test]
fn files_cut_back_by_a_resumed_coordinator_are_read_again() {
    let dir = run_dir(30, false);
    let viewer = vbap_view::spawn(dir.path(), "127.0.0.1:0", true).unwrap();
    let addr = viewer.addr();
    assert_eq!(json(addr, "/api/meta")["ticks"], 30);
    let mut s = open_stream(addr, "?from=30");
    assert_eq!(next_update(&mut s)["ticks"], 30);
    // The run files cut back to tick 12 (as to a checkpoint), then written on to 20.
    for f in [
        "vehicles.csv",
        "body.csv",
        "formation.csv",
        "truth.csv",
        "events.jsonl",
    ] {
        std::fs::remove_file(dir.path().join(f)).unwrap();
    }
    append_ticks(dir.path(), 0..12);
    let u = loop {
        let u = next_update(&mut s);
        if u["ticks"] == 12 {
            break u;
        }
    };
    assert_eq!(u["frame"]["k"], 11);
    append_ticks(dir.path(), 12..20);
    while next_update(&mut s)["ticks"] != 20 {}
    let frames = json(addr, "/api/frames?max=100")["frames"].clone();
    let ks: Vec<u64> = frames
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["k"].as_u64().unwrap())
        .collect();
    assert_eq!(ks, (0..20).collect::<Vec<u64>>());
    assert_eq!(frames[15]["v"].as_array().unwrap().len(), 3);
}
