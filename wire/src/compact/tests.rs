use super::*;

/// A small deterministic generator (xorshift), for varied messages.
struct Gen(u64);

impl Gen {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
    fn real(&mut self, scale: f64) -> f64 {
        (self.next() as f64 / u64::MAX as f64 - 0.5) * 2.0 * scale
    }
    fn vector(&mut self, scale: f64) -> [f64; 3] {
        [self.real(scale), self.real(scale), self.real(scale)]
    }
    fn entry(&mut self, id: u32) -> SnapshotEntry {
        let rejoining = u32::from(self.below(5) == 0);
        SnapshotEntry {
            id,
            alive: self.below(3) as u32,
            rejoining,
            incarnation: self.below(9) as u32,
            position: self.vector(500.0),
            velocity: self.vector(2.0),
            target: if rejoining == 1 {
                self.vector(500.0)
            } else {
                [0.0; 3]
            },
            slot: [0.0; 3],
            age: if self.below(2) == 0 {
                0.0
            } else {
                self.real(30.0).abs()
            },
            has_slot: 0,
            _pad2: 0,
        }
    }
}

/// A command of `n` neighbours, `leaders` leaders and `segments` path segments.
fn command(g: &mut Gen, n: usize, leaders: usize, segments: Option<usize>) -> AgentCommand {
    let mut own = g.entry(3);
    own.has_slot = 1;
    own.slot = g.vector(500.0);
    AgentCommand {
        tick: g.below(1 << 30),
        flags: (g.below(4)) as u8,
        r: g.vector(1000.0),
        scale: 0.5 + g.real(0.4).abs(),
        velocity: g.vector(1.0),
        inter: [50.0, 20.0, 30.0],
        leader: [50.0, 20.0, 30.0],
        damping: 1.5,
        plan: segments.map(|n| PlanPart {
            start: g.below(1 << 20),
            seg_ticks: 1 + g.below(400),
            segments: (0..n)
                .map(|_| [g.real(1.0), g.real(1.0), 0.0, g.real(0.01), g.real(0.1)])
                .collect(),
        }),
        leaders: (0..leaders).map(|_| g.vector(500.0)).collect(),
        own: (g.below(6) != 0).then_some(own),
        neighbours: (0..n).map(|i| g.entry(10 + i as u32)).collect(),
    }
}

/// Exact: every command reads back as it was sent, and its size is known before.
#[test]
fn an_exact_command_reads_back_as_sent_in_the_bytes_it_announced() {
    let mut g = Gen(0x9e37_79b9_7f4a_7c15);
    for case in 0..200 {
        let segs = [None, Some(0), Some(1), Some(16)][case % 4];
        let (n, l) = (g.below(40) as usize, g.below(20) as usize);
        let sent = command(&mut g, n, l, segs);
        let bytes = sent.encode(Precision::Exact).unwrap();
        assert_eq!(
            bytes.len(),
            sent.encoded_len(Precision::Exact),
            "case {case}"
        );
        let mut want = sent.clone();
        // What the encoding does not carry: a neighbour's slot and incarnation, the own
        // entry's id (it is the receiver's).
        for e in &mut want.neighbours {
            e.incarnation = 0;
        }
        if let Some(e) = &mut want.own {
            e.id = 0;
        }
        assert_eq!(AgentCommand::decode(&bytes).unwrap(), want, "case {case}");
    }
}

/// Quantised: every position within half a quantum of the one sent, and the message
/// smaller; a 16-vehicle command with a full path and a leader per slot fits Iridium's
/// 1890 bytes to a glider quantised, and not exactly.
#[test]
fn a_quantised_command_is_within_half_a_quantum_and_smaller() {
    let mut g = Gen(12345);
    let q = 0.01;
    for case in 0..100 {
        let (n, l) = (g.below(30) as usize, g.below(10) as usize);
        let sent = command(&mut g, n, l, Some(4));
        let bytes = sent.encode(Precision::Quantised(q)).unwrap();
        assert_eq!(bytes.len(), sent.encoded_len(Precision::Quantised(q)));
        assert!(bytes.len() <= sent.encoded_len(Precision::Exact));
        let got = AgentCommand::decode(&bytes).unwrap();
        let close = |a: &[f64; 3], b: &[f64; 3]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 0.5 * q * (1.0 + 1e-9) + 1e-9)
        };
        for (a, b) in sent.leaders.iter().zip(&got.leaders) {
            assert!(close(a, b), "case {case}: leader {a:?} read {b:?}");
        }
        for (a, b) in sent.neighbours.iter().zip(&got.neighbours) {
            assert!(close(&a.position, &b.position) && close(&a.velocity, &b.velocity));
            assert_eq!(
                (a.id, a.alive, a.rejoining, a.age),
                (b.id, b.alive, b.rejoining, b.age)
            );
        }
        assert_eq!(
            (got.tick, got.r, got.inter),
            (sent.tick, sent.r, sent.inter)
        );
    }
    let mut sixteen = command(&mut g, 15, 16, Some(16));
    for e in &mut sixteen.neighbours {
        e.age = 1.0;
        e.rejoining = 0;
    }
    let exact = sixteen.encoded_len(Precision::Exact);
    let quantised = sixteen.encoded_len(Precision::Quantised(q));
    assert!(
        exact > 1890 && quantised <= 1890,
        "{exact} B exact, {quantised} B quantised"
    );
}

/// Truncated, trailing, another version, a bad quantum: refused with the reason, never a
/// panic; a value the quantum cannot hold is not encoded.
#[test]
fn malformed_bytes_are_refused_and_out_of_range_values_are_not_sent() {
    let mut g = Gen(7);
    let sent = command(&mut g, 5, 3, Some(2));
    for precision in [Precision::Exact, Precision::Quantised(0.5)] {
        let bytes = sent.encode(precision).unwrap();
        for cut in 0..bytes.len() {
            assert!(
                matches!(
                    AgentCommand::decode(&bytes[..cut]),
                    Err(DecodeError::Truncated(_))
                ),
                "cut at {cut}"
            );
        }
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(AgentCommand::decode(&long), Err(DecodeError::Trailing(1)));
        let mut other = bytes.clone();
        other[0] = 2;
        assert_eq!(AgentCommand::decode(&other), Err(DecodeError::Version(2)));
    }
    let bytes = sent.encode(Precision::Quantised(0.5)).unwrap();
    let mut zero_q = bytes.clone();
    zero_q[6..14].copy_from_slice(&0.0f64.to_le_bytes());
    assert_eq!(
        AgentCommand::decode(&zero_q),
        Err(DecodeError::Invalid("quantum"))
    );
    let mut far = sent.clone();
    far.leaders[0] = [1e12, 0.0, 0.0];
    assert!(matches!(
        far.encode(Precision::Quantised(1e-3)),
        Err(EncodeError::OutOfRange { what: "leader", .. })
    ));
    assert_eq!(
        sent.encode(Precision::Quantised(-1.0)),
        Err(EncodeError::Quantum(-1.0))
    );
}

#[test]
fn a_report_reads_back_in_its_fixed_size() {
    let report = StateReport {
        flags: 2,
        incarnation: 4,
        tick: 77,
        commands_read: 78,
        position: [1.0, -2.0, 3.5],
        velocity: [0.1, 0.2, -0.3],
        reading: 12.25,
    };
    let bytes = report.encode().unwrap();
    assert_eq!(bytes.len(), StateReport::LEN);
    assert_eq!(StateReport::decode(&bytes), Ok(report));
    assert!(matches!(
        StateReport::decode(&bytes[..10]),
        Err(DecodeError::Truncated(_))
    ));
    let late = StateReport {
        tick: u64::MAX,
        ..report
    };
    assert!(matches!(
        late.encode(),
        Err(EncodeError::TooMany { what: "tick", .. })
    ));
}
