//! The failure suite (issue 7): every method on the inputs where probe systems are known to
//! fail. Each case must end without panic, with every figure and image finite, and with its
//! error within its bound or its input refused clearly.
//!
//! With `PROBE_REQUIRE_GPU` set (CI), the tracer must run on a GPU adapter (lavapipe there);
//! otherwise the CPU twin stands in when none exists. `PROBE_FAILURE_CASES=a,b` runs only the
//! named cases (names in `probe_eval::failures::FAILURE_CASES`).

use probe_eval::failures::{
    FAILURE_CASES, FailureOptions, Outcome, SharedScenes, run_failure_suite,
};

fn options() -> FailureOptions {
    let mut options = FailureOptions::new(std::env::var_os("PROBE_REQUIRE_GPU").is_some());
    options.shared_scenes = Some(SharedScenes::in_dir(&probe_testdata::scenes_dir()));
    if let Ok(cases) = std::env::var("PROBE_FAILURE_CASES") {
        options.cases = cases
            .split(',')
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(String::from)
            .collect();
    }
    options
}

#[test]
fn every_failure_case_is_survived_bounded_or_refused() {
    assert!(
        probe_testdata::scenes_available(),
        "the shared scenes are missing from {}",
        probe_testdata::scenes_dir().display()
    );
    let options = options();
    let report = run_failure_suite(&options).expect("the suite runs");
    eprintln!("{}", report.markdown());
    if options.cases.is_empty() {
        assert_eq!(report.cases.len(), FAILURE_CASES.len());
    }
    let mut problems = Vec::new();
    for case in &report.cases {
        assert!(
            !case.figures.is_empty() || !case.checks.is_empty(),
            "{} measured nothing",
            case.name
        );
        let non_finite: Vec<&str> = case
            .figures
            .iter()
            .filter(|f| !f.value.is_finite())
            .map(|f| f.name.as_str())
            .collect();
        if !non_finite.is_empty() {
            problems.push(format!("{}: non-finite figures {non_finite:?}", case.name));
        }
        match &case.outcome {
            Outcome::Passed | Outcome::Refused { .. } => {}
            Outcome::Failed { failed } if case.known_failure.is_some() => eprintln!(
                "{}: known failure ({}): {failed:?}",
                case.name,
                case.known_failure.as_deref().unwrap_or_default()
            ),
            other => {
                let failed: Vec<String> = case
                    .checks
                    .iter()
                    .filter(|c| !c.held)
                    .map(|c| format!("{} [{}; measured {}]", c.name, c.bound, c.measured))
                    .collect();
                problems.push(format!("{}: {other:?}: {failed:?}", case.name));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "failure cases not handled:\n{}",
        problems.join("\n")
    );
    // The report section names every case and serialises.
    let markdown = report.markdown();
    for case in &report.cases {
        assert!(markdown.contains(&format!("`{}`", case.name)));
    }
    let json = serde_json::to_string(&report).expect("the report serialises");
    assert!(json.contains("\"cases\"") && json.contains("\"outcome\""));
}
