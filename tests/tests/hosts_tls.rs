//! Hosts that trust only each other (network namespaces, root: see `tests::netns`): the
//! certificates of `vbap certs`, a three-host lockstep mission over mutual TLS equal to
//! `vbap sim`, a peer with a certificate of another CA and a plain-TCP peer refused at the
//! shore's handshake (counted and logged) while the mission runs on, a host with a
//! certificate of the mission that forges another host's states and commands held off by
//! the access control, and plain `tcp/` refused without `insecure = true`.

use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::time::Duration;

use tests::netns::*;
use tests::*;

/// `vbap certs HOSTS --out DIR`, which must succeed; its standard output.
fn certs(hosts: &Path, out: &Path) -> String {
    let o = run_ok(vbap().arg("certs").arg(hosts).arg("--out").arg(out));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The last line of JSON log `log` that holds `text`, parsed.
fn last_line_with(log: &str, text: &str) -> serde_json::Value {
    let line = log
        .lines()
        .rfind(|l| l.contains(text))
        .unwrap_or_else(|| panic!("no line with {text:?}"));
    serde_json::from_str(line).unwrap()
}

/// The lines of the shore bridge's log that say it refused a peer at the TLS handshake.
fn refusals(shore: &Path) -> Vec<String> {
    std::fs::read_to_string(shore.join("logs/vbap_bridge.jsonl"))
        .unwrap_or_default()
        .lines()
        .filter(|l| l.contains("refused a peer at the TLS handshake"))
        .map(str::to_string)
        .collect()
}

#[test]
fn three_hosts_over_mutual_tls_equal_the_simulator_and_refuse_strangers() {
    let tmp = TempDir::new("hoststls");
    let net = Net::new();
    let name = unique_name("hoststls");
    let file = write(&tmp, "m.toml", &hosts_mission(&name, 6.0));
    // The mission's certificates, made from the hosts file's endpoints.
    let text = net.hosts_file_tls("certs");
    let printed = certs(&write(&tmp, "hosts.toml", &text), &tmp.join("certs"));
    assert!(
        printed.contains("[tls]") && printed.contains("shore.pem"),
        "{printed}"
    );
    for h in HOSTS {
        let mode = std::fs::metadata(tmp.join(&format!("certs/{h}.key")))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o077, 0, "{h}.key is owner-only: {mode:o}");
    }
    let hosts = tmp.join("hosts.toml");
    // Strangers in glider_b's namespace, on ports of their own: one with certificates of
    // another CA (its own `vbap certs`), one speaking plain TCP.
    let rogue_dir = tmp.join("rogue");
    std::fs::create_dir_all(&rogue_dir).unwrap();
    let rogue_text = text.replace(":7447\"\nvehicles = [2, 3]", ":7448\"\nvehicles = [2, 3]");
    let rogue_hosts = rogue_dir.join("hosts.toml");
    std::fs::write(&rogue_hosts, &rogue_text).unwrap();
    certs(&rogue_hosts, &rogue_dir.join("certs"));
    let plain = format!(
        "insecure = true\n[hosts.shore]\nendpoint = \"tcp/{}:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
         [hosts.glider_a]\nendpoint = \"tcp/{}:7449\"\nvehicles = [0, 1]\n\
         [hosts.glider_b]\nendpoint = \"tcp/{}:7449\"\nvehicles = [2, 3]\n",
        net.addr(0),
        net.addr(1),
        net.addr(2)
    );
    let plain_hosts = write(&tmp, "plain.toml", &plain);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    // Everything that crosses the network between the hosts, from before the first host.
    let pcap = tmp.join("hosts.pcap");
    let capture = net.capture(&pcap, &tmp.join("tcpdump.log"));
    // The shore first: it waits for the glider hosts, and meanwhile the strangers knock.
    let mut shore = start_host(&net, &tmp, &file, &hosts, "shore");
    let ping = bin_dir().join("vbap_zenoh_ping");
    let stranger = |hosts: &Path, log: &str| {
        net.spawn_in(
            "glider_b",
            &ping,
            &[
                "--hosts",
                &hosts.to_string_lossy(),
                "--host",
                "glider_b",
                "--vehicles",
                "4",
                "--samples",
                "1",
            ],
            &tmp.join(log),
        )
    };
    let rogue = stranger(&rogue_hosts, "rogue.log");
    let plain_peer = stranger(&plain_hosts, "plain.log");
    let shore_dir = tmp.join("shore");
    wait_until(
        || refusals(&shore_dir).len() >= 2,
        Duration::from_secs(60),
        "the shore refusing both strangers at the handshake",
    );
    // A host with a certificate of the mission that breaks its rules: on glider_a's
    // certificate, states of glider_b's vehicle 2 on glider_b's key and body commands, all
    // through the mission, while reading every host's states. The shore's access control
    // takes none of it (else the coordinator would read vehicle 2 at the origin with a
    // sequence number far ahead, and reject the real one's next state as a replay).
    let forger = net.spawn_in(
        "glider_a",
        &ping,
        &[
            "--hosts",
            &hosts.to_string_lossy(),
            "--host",
            "glider_a",
            "--vehicles",
            "4",
            "--forge",
            &name,
            "--victim",
            "glider_b",
            "--vehicle",
            "2",
            "--samples",
            "5000",
        ],
        &tmp.join("forger.log"),
    );
    let mut a = start_host(&net, &tmp, &file, &hosts, "glider_a");
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    wait_hosts_ok(&tmp, &mut shore, &mut a, &mut b);
    // Still knocking all along: neither ever got an answer from the mission.
    drop(rogue);
    drop(plain_peer);
    for log in ["rogue.log", "plain.log"] {
        let text = read(&tmp.join(log));
        assert!(
            !text.lines().any(|l| l.parse::<f64>().is_ok()),
            "{log}: {text}"
        );
    }
    // The capture holds the whole mission, and neither its name nor a payload in clear
    // (the frames' magic, the payloads' type names): hosts.rs's plain-TCP run holds both.
    drop(capture);
    let captured = std::fs::read(&pcap).unwrap();
    assert!(
        captured.len() > 100_000,
        "captured {} bytes",
        captured.len()
    );
    for clear in [
        name.as_bytes(),
        b"VBAPW3",
        b"vbap.VehicleState",
        b"vbap.BodyCommand",
    ] {
        assert!(
            !holds(&captured, clear),
            "{:?} in clear in {}",
            String::from_utf8_lossy(clear),
            pcap.display()
        );
    }
    println!(
        "captured between the hosts: {} bytes, nothing in clear",
        captured.len()
    );
    // The forger was still at it when the mission ended (5000 puts take 100 s).
    let forged = read(&tmp.join("forger.log"));
    assert!(
        !forged.contains("read "),
        "the forger ended before the mission: {forged}"
    );
    drop(forger);
    assert_same_tracks(&tmp.join("sim"), &shore_dir);
    let s = summary(&shore_dir);
    assert_eq!(s["mode"], "multi-process");
    assert_eq!(s["messages"]["rejected"], 0);
    assert_eq!(s["vehicles_lost"], 0, "{s}");
    let log = read(&shore_dir.join("logs/vbap_bridge.jsonl"));
    let v = last_line_with(&log, "bridge done");
    let done = v.to_string();
    let counted = v["fields"]["refused_handshakes"].as_u64().unwrap_or(0);
    assert!(counted >= 2, "refusals counted: {done}");
    println!(
        "refused at the shore's handshake: {counted}; first: {:?}",
        refusals(&shore_dir).first()
    );
    // The forger's subscription to every host's states and its puts of vehicle 2's states
    // were denied by the shore's access control, counted and named. (Its body commands
    // never leave it: the only host it reaches, the shore, subscribes to none.)
    let denied = v["fields"]["denied"].as_u64().unwrap_or(0);
    let named: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("denied a peer's message by the access control"))
        .collect();
    let victim = format!("is unauthorized to Put (ingress) on vbap/{name}/states/glider_b");
    assert!(
        denied > 0 && named.iter().any(|l| l.contains(&victim)),
        "the shore's access control denied {denied}; named: {named:?}"
    );
    // Only the forger's messages: the decisions Zenoh makes ahead when it caches a key
    // expression's permissions (a query on `exits`, …) are not denials of a message.
    let forged = format!("is unauthorized to Declare Subscriber (ingress) on vbap/{name}/states/*");
    assert!(
        named
            .iter()
            .all(|l| l.contains(&victim) || l.contains(&forged)),
        "a denial that is no message of the forger's: {named:?}"
    );
    println!(
        "denied by the shore's access control: {denied}; first: {:?}",
        named.first()
    );
    assert_clean(net, &tmp);
}

#[test]
fn plain_tcp_without_insecure_and_missing_certificates_exit_2_naming_the_key() {
    let tmp = TempDir::new("hoststlsbad");
    let name = unique_name("hoststlsbad");
    let file = write(&tmp, "m.toml", &hosts_mission(&name, 1.0));
    let tcp = "[hosts.shore]\nendpoint = \"tcp/10.1.0.1:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
               [hosts.g]\nendpoint = \"tcp/10.1.0.2:7447\"\nvehicles = [0, 1, 2, 3]\n";
    let tls = "[tls]\nca = \"nowhere/ca.pem\"\n\
               [hosts.shore]\nendpoint = \"tls/10.1.0.1:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
               cert = \"nowhere/shore.pem\"\nkey = \"nowhere/shore.key\"\n\
               [hosts.g]\nendpoint = \"tls/10.1.0.2:7447\"\nvehicles = [0, 1, 2, 3]\n\
               cert = \"nowhere/g.pem\"\nkey = \"nowhere/g.key\"\n";
    let no_key = tls.replace("key = \"nowhere/g.key\"\n", "");
    for (i, (text, want)) in [
        (tcp, "hosts.g.endpoint"),
        (tls, "tls.ca"),
        (no_key.as_str(), "hosts.g.key"),
    ]
    .iter()
    .enumerate()
    {
        let hosts = write(&tmp, &format!("h{i}.toml"), text);
        refused_hosts_file(&file, &hosts, &tmp.join(&format!("run{i}")), want);
    }
    // `vbap certs` never overwrites: a second run into the same folder exits 2.
    let hosts = write(&tmp, "ok.toml", tcp);
    certs(&hosts, &tmp.join("c"));
    let again = vbap()
        .arg("certs")
        .arg(&hosts)
        .arg("--out")
        .arg(tmp.join("c"))
        .output()
        .unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert_nothing_left(&name, &tmp);
}
