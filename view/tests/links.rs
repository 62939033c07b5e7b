//! The links a frame shows (`frames::FrameVehicle`'s `links` bits): every Iridium session
//! and every acoustic frame of the shipped `glider_acoustic` mission lands in exactly one
//! window between consecutive frames, as the mission's models schedule them.

use vbap_mission::acoustic::AcousticModel;
use vbap_mission::config::Mission;
use vbap_mission::link::LinkModel;
use vbap_view::frames::{LINK_ACOUSTIC, LINK_SESSION, LINK_SESSION_FAILED};
use vbap_view::model::Model;

#[test]
fn every_session_and_acoustic_frame_shows_in_one_frame() {
    let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../deploy/missions/glider_acoustic.toml");
    let mission = Mission::load(&shipped).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mission.toml"), mission.to_toml_string()).unwrap();
    let model = Model::open(dir.path()).unwrap();
    let (dt, until) = (mission.mission.dt, 6.0 * 3600.0);
    let links = LinkModel::new(&mission);
    let channel = AcousticModel::new(&mission).unwrap();
    for id in 0..6u32 {
        let (mut opened, mut failed, mut frames) = (0, 0, 0);
        let mut t = 0.0;
        while t < until {
            let bits = model.links_between(id, t, t + dt);
            opened += (bits & LINK_SESSION != 0) as usize;
            failed += (bits & LINK_SESSION_FAILED != 0) as usize;
            frames += (bits & LINK_ACOUSTIC != 0) as usize;
            t += dt;
        }
        let sessions = links.sessions(id, 0.0, until);
        let ok = sessions.iter().filter(|s| s.ok).count();
        let bad = sessions.len() - ok;
        // Sessions are a minute apart and ticks 10 s: one per window at most.
        assert_eq!((opened, failed), (ok, bad), "vehicle {id}");
        assert!(ok > 0, "vehicle {id} opened sessions");
        let sent = (0..(until / dt) as u64)
            .flat_map(|k| channel.expected(id, k).collect::<Vec<_>>())
            .count();
        assert_eq!(frames, sent, "vehicle {id}");
        assert!(sent >= 350, "a frame a minute for 6 h: {sent}");
    }
}
