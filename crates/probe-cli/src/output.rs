//! Printing a command's result as text or as one JSON object.

/// What every command returns: a JSON value for `--json` and a human-readable text.
pub trait Report {
    /// The result as one JSON object.
    fn json(&self) -> serde_json::Value;
    /// The result as text for a terminal.
    fn text(&self) -> String;
}

/// Prints a report to stdout, as JSON (one line) or as text.
pub fn print(report: &dyn Report, json: bool) {
    if json {
        println!("{}", report.json());
    } else {
        print!("{}", report.text());
    }
}
