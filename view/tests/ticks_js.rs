//! The page's axis ticks (`view/assets/ticks.js`) under node: the same ticks and labels as
//! the report's on the shared cases (`report/src/plot/chart/ticks_cases.json`), distinct
//! labels on a small range, round time steps, the map's scale bar. Needs `node` (Debian:
//! `nodejs`; `deploy/test.sh` installs it).

use std::path::Path;
use std::process::Command;

#[test]
fn the_pages_ticks_match_the_reports_cases() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ticks_cases.js");
    let out = Command::new("node").arg(&script).output().unwrap_or_else(|e| {
        panic!("running node: {e}: this test needs node (Debian: nodejs; deploy/test.sh installs it)")
    });
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("shared cases"), "{stdout}");
}
