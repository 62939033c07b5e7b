//! The summary a supervised coordinator hands to its supervisor, so `summary.json` is
//! written once: the coordinator prints one line, `summary <JSON>`, on its standard output
//! when the mission is over; the supervisor (`vbap run`) adds what only it knows once
//! every process has ended (wall time, the analysis of the message records, the agents'
//! rejections, an interruption) and writes the file. A coordinator without a live
//! supervisor writes `summary.json` itself.

use vbap_mission::rundir::Summary;

/// The prefix of the summary line.
const PREFIX: &str = "summary ";

/// The line (without its newline) that hands `summary` over: exact, f64 included.
pub fn summary_line(summary: &Summary) -> serde_json::Result<String> {
    Ok(format!("{PREFIX}{}", serde_json::to_string(summary)?))
}

/// The summary a line of the coordinator's output hands over; None for any other line.
pub fn parse_summary_line(line: &str) -> Option<serde_json::Result<Summary>> {
    line.strip_prefix(PREFIX).map(serde_json::from_str)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A summary goes through the line unchanged, down to the last bit of every float, and
    /// so writes the same `summary.json` as the coordinator would have.
    #[test]
    fn a_summary_survives_its_line_exactly() {
        let s = Summary {
            mission: "m".into(),
            final_grad_norm: 0.1 + 0.2,
            final_distance_to_optimum: Some(1e-25),
            time_to_converge_s: None,
            final_body_position: [1.0 / 3.0, -2.5e17, 0.0],
            detection_latency_ms: vec![12.345_678_9, 1e-4],
            verdict: "converged".into(),
            reasons: vec!["a \"quoted\" reason\nover two lines".into()],
            ..Summary::default()
        };
        let line = summary_line(&s).unwrap();
        assert!(!line.contains('\n'), "one line");
        let back = parse_summary_line(&line).unwrap().unwrap();
        assert_eq!(back, s);
        assert_eq!(
            serde_json::to_string_pretty(&back).unwrap(),
            serde_json::to_string_pretty(&s).unwrap()
        );
        assert!(parse_summary_line("ready").is_none());
        assert!(parse_summary_line("summary {").unwrap().is_err());
    }
}
