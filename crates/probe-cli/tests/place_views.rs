//! `probes place` with a view set: error-driven sets held by each view (the default) or over
//! all views together, and the argument errors around them.

mod support;

use support::{probes, stderr};

#[test]
fn an_error_driven_set_holds_its_target_for_each_view_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("probes.json");
    let out_text = out.to_str().unwrap();
    let base = [
        "place",
        "builtin:cornell",
        "--method",
        "minimal",
        "--views",
        "6",
        "--target-error",
        "0.1",
        "--texels",
        "2000",
        "--out",
        out_text,
    ];
    let each = probes(&base);
    assert!(each.status.success(), "{}", stderr(&each));
    let text = String::from_utf8_lossy(&each.stdout).into_owned();
    let worst: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("worst view "))
        .and_then(|l| l.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("no worst view line in {text}"));
    assert!(worst >= 90.0 - 0.005, "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(json["parameters"]["each_view"], serde_json::json!(true));

    let mut mean_args = base.to_vec();
    mean_args.push("--target-mean");
    let mean = probes(&mean_args);
    assert!(mean.status.success(), "{}", stderr(&mean));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(json["parameters"].get("each_view").is_none(), "{json}");
}

#[test]
fn a_target_without_views_or_a_mean_without_a_target_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("probes.json");
    let out_text = out.to_str().unwrap();
    let no_views = probes(&[
        "place",
        "builtin:cornell",
        "--method",
        "minimal",
        "--target-error",
        "0.1",
        "--out",
        out_text,
    ]);
    assert!(!no_views.status.success());
    assert!(
        stderr(&no_views).contains("--views"),
        "{}",
        stderr(&no_views)
    );
    let no_target = probes(&[
        "place",
        "builtin:cornell",
        "--method",
        "minimal",
        "--views",
        "4",
        "--target-mean",
        "--out",
        out_text,
    ]);
    assert!(!no_target.status.success());
    assert!(
        stderr(&no_target).contains("--target-error"),
        "{}",
        stderr(&no_target)
    );
    assert!(!out.exists());
}
