//! Tests of the acoustic channel (`super`).

use super::*;

/// A 3-vehicle mission on metres with `[acoustic]` keys `extra` (dt 1 s).
fn model(extra: &str) -> Arc<AcousticModel> {
    let text = format!(
        "[mission]\nname = \"a\"\ndt = 1.0\nallow_unstable = true\nduration = 600.0\n[field]\ncenter = [20.0, 10.0]\n\
         amplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 3\n[links]\nposition_quantum = 0.01\n\
         [acoustic]\n{extra}\n"
    );
    let m = Mission::from_toml_str(&text, "<test>").unwrap();
    AcousticModel::new(&m).unwrap()
}

fn frame(m: &AcousticModel, sender: u32, n: u64, source: Vec3) -> Frame {
    let at = m.transmission_time(sender, n);
    let tick = (at / m.dt).floor() as u64;
    let mut f = m.frames(sender, tick, 0, source, source, Vec3::zeros());
    assert_eq!(f.len(), 1, "transmission {n} of {sender} is in its tick");
    f.remove(0)
}

/// An ear for vehicle `me` (it stands where [`settle`] says).
fn ear_of(m: &Arc<AcousticModel>, me: u32) -> Ear {
    Ear::new(m.clone(), me, 0).keeping_verdicts()
}

/// `ear` standing at `x`, tracked and deciding every tick from 0 to `until`.
fn settle(ear: &mut Ear, x: Vec3, until: u64) {
    for k in 0..=until {
        ear.track(k, x);
        ear.decide(k);
    }
}

#[test]
fn every_transmission_starts_in_exactly_one_tick_within_its_interval() {
    for schedule in ["random", "tdma"] {
        let m = model(&format!("interval = 20.0\nschedule = \"{schedule}\"\ninterference_range = 3000.0\ndetection_range = 3000.0"));
        for v in 0..3 {
            let mut seen = Vec::new();
            for k in 0..200 {
                seen.extend(m.transmissions(v, k).map(|(n, _)| n));
            }
            assert_eq!(
                seen,
                (0..10).collect::<Vec<u64>>(),
                "{schedule}, vehicle {v}"
            );
            for n in 0..10 {
                let at = m.transmission_time(v, n);
                assert!(at >= n as f64 * 20.0 && at + m.air_time() <= (n + 1) as f64 * 20.0);
            }
        }
        if schedule == "tdma" {
            assert_eq!(m.transmission_time(2, 3), 60.0 + 2.0 * 20.0 / 3.0);
        }
    }
}

#[test]
fn a_lone_frame_in_range_is_heard_after_propagation_and_air_time() {
    let m = model("decode_probability = 1.0");
    assert_eq!(m.frame_bytes(), 30);
    assert!((m.air_time() - 3.0).abs() < 1e-12); // 240 bits at 80 bit/s
    let f = frame(&m, 0, 2, Vec3::new(0.0, 0.0, 0.0));
    let mut ear = ear_of(&m, 1);
    ear.hear(f);
    let end = f.at + 1.0 + 3.0;
    let before = (end.ceil() as u64) - 1;
    let rx = Vec3::new(1500.0, 0.0, 0.0);
    settle(&mut ear, rx, before);
    assert_eq!(ear.counts.total(), 0, "not decided before it ends here");
    ear.track(before + 1, rx);
    ear.decide(before + 1);
    assert_eq!(ear.counts.heard, 1);
    let v = ear.take_verdicts();
    assert_eq!(v.len(), 1);
    match v[0].2 {
        Verdict::Heard { latency } => assert!((latency - 4.0).abs() < 1e-9),
        other => panic!("{other:?}"),
    }
    let h = ear.heard().next().unwrap();
    assert_eq!((h.sender, h.tick), (0, f.tick));
}

#[test]
fn ranges_decide_undecoded_and_out_of_range_and_interference_still_collides() {
    let m = model("decode_probability = 1.0\ncommunication_range = 1000.0\ndetection_range = 2000.0\ninterference_range = 3000.0\nschedule = \"tdma\"\ninterval = 30.0");
    let rx = Vec3::zeros();
    // Undecoded between 1 and 2 km, out of range beyond 2 km.
    for (x, expect) in [(1500.0, Verdict::Undecoded), (2500.0, Verdict::Range)] {
        let mut ear = ear_of(&m, 2);
        ear.hear(frame(&m, 0, 1, Vec3::new(x, 0.0, 0.0)));
        settle(&mut ear, rx, 600);
        assert_eq!(ear.take_verdicts()[0].2, expect, "at {x}");
    }
    // Beyond detection, within interference: not heard itself, it still ruins a frame it
    // overlaps (random schedule: the first transmissions of 0 and 1 that overlap).
    let m = model("decode_probability = 1.0\ncommunication_range = 1000.0\ndetection_range = 2000.0\ninterference_range = 3000.0\ninterval = 10.0");
    let n = (0..400)
        .find(|&n| (m.transmission_time(0, n) - m.transmission_time(1, n)).abs() < 0.5)
        .expect("an overlap in 400 draws");
    let mut ear = ear_of(&m, 2);
    ear.hear(frame(&m, 0, n, Vec3::new(100.0, 0.0, 0.0)));
    ear.hear(frame(&m, 1, n, Vec3::new(-2500.0, 0.0, 0.0)));
    settle(&mut ear, rx, 5000);
    assert_eq!(
        (ear.counts.collision, ear.counts.range),
        (1, 1),
        "{:?}",
        ear.counts
    );
}

#[test]
fn overlapping_frames_collide_and_a_transmitting_modem_is_deaf() {
    // Random schedule: find two transmissions of 0 and 1 that overlap in time.
    let m = model("decode_probability = 1.0\ninterval = 10.0");
    let air = m.air_time();
    let (mut a, mut b) = (None, None);
    for n in 0..200 {
        let (t0, t1) = (m.transmission_time(0, n), m.transmission_time(1, n));
        if (t0 - t1).abs() < air * 0.5 {
            a = Some(n);
        }
        if (t0 - t1).abs() > air * 1.5 + 0.1 && b.is_none() {
            b = Some(n);
        }
    }
    let (a, b) = (a.expect("an overlap in 200 draws"), b.unwrap());
    let rx = Vec3::zeros();
    let near = |x: f64| Vec3::new(x, 0.0, 0.0);
    let mut ear = ear_of(&m, 2);
    ear.hear(frame(&m, 0, a, near(10.0)));
    ear.hear(frame(&m, 1, a, near(-10.0)));
    ear.hear(frame(&m, 0, b, near(10.0)));
    ear.hear(frame(&m, 1, b, near(-10.0)));
    settle(&mut ear, rx, 3000);
    assert_eq!(ear.counts.collision, 2);
    assert_eq!(ear.counts.heard, 2);
    // Vehicle 1 transmitting while vehicle 0's frame arrives: deaf.
    let mut ear = ear_of(&m, 1);
    ear.transmitted(&frame(&m, 1, a, rx));
    ear.hear(frame(&m, 0, a, near(10.0)));
    settle(&mut ear, rx, 3000);
    assert_eq!(ear.counts.deaf, 1);
}

#[test]
fn verdicts_do_not_depend_on_the_order_frames_reach_the_process() {
    let m = model("interval = 10.0");
    let frames: Vec<Frame> = (0..60)
        .flat_map(|n| {
            [
                frame(&m, 0, n, Vec3::new(800.0, 0.0, 0.0)),
                frame(&m, 1, n, Vec3::new(0.0, 2900.0, 0.0)),
            ]
        })
        .collect();
    let run = |order: &mut dyn Iterator<Item = Frame>, step: u64| {
        let mut ear = Ear::new(m.clone(), 2, 0).keeping_verdicts();
        let mut feed: Vec<Frame> = order.collect();
        let mut out = Vec::new();
        for k in 0..=620u64 {
            ear.track(k, Vec3::zeros());
            // Every frame of the ticks before k is in before deciding k (the agents'
            // guarantee), in whatever order.
            let (now, later): (Vec<Frame>, Vec<Frame>) =
                feed.into_iter().partition(|f| f.tick + step <= k);
            feed = later;
            for f in now {
                ear.hear(f);
            }
            ear.decide(k);
            out.extend(ear.take_verdicts());
        }
        out.sort_by_key(|x| (x.0, x.1));
        (out, ear.counts)
    };
    let (a, ca) = run(&mut frames.clone().into_iter(), 1);
    let (b, cb) = run(&mut frames.clone().into_iter().rev(), 1);
    assert_eq!(ca, cb);
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    assert_eq!(ca.total(), 120);
    assert!(
        ca.heard > 0 && ca.collision + ca.noise + ca.undecoded > 0,
        "{ca:?}"
    );
}

#[test]
fn the_decoding_draw_holds_its_probability() {
    let m = model("decode_probability = 0.7\ninterval = 30.0\nschedule = \"tdma\"");
    let mut ear = Ear::new(m.clone(), 2, 0);
    for k in 0..=60_000u64 {
        ear.track(k, Vec3::zeros());
        for f in m.frames(
            0,
            k,
            0,
            Vec3::new(100.0, 0.0, 0.0),
            Vec3::zeros(),
            Vec3::zeros(),
        ) {
            ear.hear(f);
        }
        ear.decide(k);
    }
    let share = ear.counts.heard as f64 / ear.counts.total() as f64;
    assert!(ear.counts.total() > 1900, "{:?}", ear.counts);
    assert!((share - 0.7).abs() < 0.035, "{share}");
}

#[test]
fn a_killed_vehicle_is_silent_until_the_state_after_its_restart() {
    let text = "[mission]\nname = \"a\"\ndt = 1.0\nallow_unstable = true\nduration = 600.0\n[field]\ncenter = [20.0, 10.0]\n\
        amplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 3\n[links]\nposition_quantum = 0.01\n\
        [restart]\nvehicles = \"on-failure\"\n[acoustic]\ninterval = 10.0\n\
        [[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 100.0\nuntil = 200.0\n";
    let m = AcousticModel::new(&Mission::from_toml_str(text, "<t>").unwrap()).unwrap();
    assert!(m.sends(1, 99) && !m.sends(1, 100) && !m.sends(1, 200) && m.sends(1, 201));
    assert!(m.sends(0, 150));
    let x = Vec3::zeros();
    assert!(
        m.frames(0, 0, 0, x, x, x).is_empty(),
        "nothing at the first tick"
    );
    // A receiver ignores a silenced vehicle's frames (an agent that ran ahead of its kill).
    let mut f = frame(&m, 0, 12, x);
    f.sender = 1;
    f.at = m.transmission_time(1, 12);
    f.tick = (f.at / 1.0).floor() as u64;
    let mut ear = ear_of(&m, 2);
    ear.hear(f);
    settle(&mut ear, x, 600);
    assert_eq!(ear.counts.total(), 0);
}

#[test]
fn implausible_frames_are_refused_and_counted() {
    let m = model("");
    let good = frame(&m, 0, 3, Vec3::zeros());
    let mut ear = ear_of(&m, 2);
    for bad in [
        Frame { sender: 9, ..good },
        Frame {
            at: good.at + 0.5,
            ..good
        },
        Frame {
            position: Vec3::new(f64::NAN, 0.0, 0.0),
            ..good
        },
        Frame {
            tick: good.tick + 1,
            ..good
        },
    ] {
        ear.hear(bad);
    }
    ear.hear(good);
    ear.hear(good);
    assert_eq!(ear.rejected, 4);
    settle(&mut ear, Vec3::zeros(), 600);
    assert_eq!(ear.counts.total(), 1, "duplicates are one frame");
}

#[test]
fn a_given_up_sender_is_not_awaited_again_until_it_speaks() {
    // TDMA, 30-s interval: vehicle s sends its frame n at 30 n + 10 s (dt 1 s).
    let m = model("interval = 30.0\nschedule = \"tdma\"");
    let x = Vec3::zeros();
    let mut ear = ear_of(&m, 0);
    for sender in [1, 2] {
        for n in 0..4 {
            ear.hear(frame(&m, sender, n, x));
        }
    }
    assert_eq!(ear.missing(111), None);
    // Vehicle 2's process dies: its frame 4 (t = 140 s) never comes.
    ear.hear(frame(&m, 1, 4, x));
    assert_eq!(ear.missing(141), Some(2));
    ear.give_up(2, 141);
    assert_eq!(ear.missing(141), None);
    for n in 5..9 {
        ear.hear(frame(&m, 1, n, x));
    }
    assert_eq!(
        ear.missing(251),
        None,
        "a dead sender is given up once, not at each of its frames"
    );
    assert_eq!(ear.missing(281), Some(1), "the others stay awaited");
    // Vehicle 2 restarted: awaited again from the first frame heard of it.
    ear.hear(frame(&m, 2, 9, x));
    ear.hear(frame(&m, 1, 9, x));
    assert_eq!(ear.missing(291), None);
    assert_eq!(ear.missing(311), Some(1));
    ear.hear(frame(&m, 1, 10, x));
    assert_eq!(ear.missing(321), Some(2), "awaited again after it spoke");
}
