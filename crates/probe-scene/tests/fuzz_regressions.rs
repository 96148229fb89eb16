//! Inputs the fuzzer (`tests/examples/fuzz.rs`, `scripts/fuzz.sh`) found to crash or hang the
//! loader, minimised and kept under `tests/data/fuzz/CASE/`: each must now load or be refused
//! with an error, never panic. `EXPECT.txt` holds a piece of the error message expected (empty:
//! the file loads).

use probe_scene::Scene;
use std::path::Path;

#[test]
fn fuzz_findings_are_refused_with_errors() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz");
    let mut cases: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    cases.sort();
    assert!(!cases.is_empty());
    for case in cases {
        let input = ["input.gltf", "input.glb"]
            .iter()
            .map(|name| case.join(name))
            .find(|p| p.is_file())
            .unwrap_or_else(|| panic!("{} has no input file", case.display()));
        let expect = std::fs::read_to_string(case.join("EXPECT.txt")).unwrap();
        let expect = expect.trim();
        match Scene::load(&input) {
            Ok(scene) => assert!(
                expect.is_empty(),
                "{}: loaded ({} triangles) but {expect:?} was expected",
                case.display(),
                scene.triangles().len()
            ),
            Err(error) => {
                let text = error.to_string();
                assert!(
                    !expect.is_empty() && text.contains(expect),
                    "{}: {text}",
                    case.display()
                );
                assert!(!text.contains('\n'), "{text}");
            }
        }
    }
}
