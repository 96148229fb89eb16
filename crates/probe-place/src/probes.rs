//! The placement output: a set of probe positions, how it was made, and its JSON file.

use crate::candidate_error::CandidateError;
use crate::grid::RegularGrid;
use crate::provenance::PlacementMethod;
use glam::Vec3;
use probe_scene::Scene;
use serde_json::{Map, Value};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The `format` tag of probe-set files written by this version.
pub const PROBE_SET_FORMAT: &str = "probes/1";

/// A placement: world-space probe positions plus the method, with its parameters, that made
/// them ([`PlacementMethod`]).
///
/// # File format (`probes/1`)
///
/// A JSON object, written by [`ProbeSet::save`] as:
///
/// ```text
/// {
///   "format": "probes/1",
///   "method": "grid",
///   "parameters": {"bounds":[[-4.2,-0.2,-4.2],[4.2,3.2,4.2]],"dims":[4,2,4]},
///   "count": 32,
///   "positions": [
///     [-3.15, 0.65, -3.15],
///     ...
///   ]
/// }
/// ```
///
/// - `format` (required): `"probes/1"`; other values are refused.
/// - `positions` (required): `[x, y, z]` in metres, world space, `+Y` up; finite numbers. The
///   writer prints each `f32` in its shortest round-trip decimal form (`-3.15`, `1e-7`), so
///   positions survive a save and load bit for bit.
/// - `method` (optional, default `"manual"`): the placement method, e.g. `"grid"`,
///   `"grid-relocated"`, `"sdf"`, `"medial"` ([`PlacementMethod::name`]).
/// - `parameters` (optional, default `{}`): the method's parameters, any JSON object; keys are
///   written sorted, so the same set gives the same bytes. Both are read into a
///   [`PlacementMethod`] ([`PlacementMethod::from_recorded`]): typed for the methods this
///   version writes, kept as recorded otherwise.
/// - `count` (optional): the number of positions; checked against `positions` when present.
/// - Other keys are ignored when reading, so later versions may add fields.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeSet {
    /// World-space probe positions, metres.
    pub positions: Vec<Vec3>,
    /// The method that placed them, with its parameters ([`PlacementMethod::Manual`] for a
    /// set built by hand).
    pub method: PlacementMethod,
}

/// What went wrong reading, writing or parsing a probe set.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ProbeSetError {
    /// The file could not be read or written.
    ///
    /// Fix: check the path exists (for reading) or that its folder exists and is writable.
    #[error("probe set `{}`: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },

    /// The text is not JSON, or not an object with the fields of `probes/1`.
    ///
    /// Fix: the message gives the line and column; see [`ProbeSet`] for the format.
    #[error("probe set {origin}: not a valid probes/1 file: {source}")]
    Parse {
        /// The file (or `JSON text` when parsed from a string).
        origin: String,
        /// The parser's error, with line and column.
        source: serde_json::Error,
    },

    /// The `format` field is not `probes/1`.
    ///
    /// Fix: write the file with this version of `probe-place`, or convert it.
    #[error(
        "probe set {origin}: format `{found}` is not supported (expected `{PROBE_SET_FORMAT}`)"
    )]
    UnsupportedFormat {
        /// The file (or `JSON text`).
        origin: String,
        /// The `format` value found.
        found: String,
    },

    /// A position is not finite (only possible when building a set by hand and saving it).
    ///
    /// Fix: drop or repair the probe at that index.
    #[error("probe set {origin}: position {index} is not finite")]
    NonFinitePosition {
        /// The file (or `JSON text` / `probe set` for an in-memory set).
        origin: String,
        /// The index of the offending position.
        index: usize,
    },

    /// The `count` field disagrees with the number of positions.
    ///
    /// Fix: the file was truncated or edited by hand; regenerate it or correct `count`.
    #[error("probe set {origin}: `count` is {count} but {found} positions follow")]
    CountMismatch {
        /// The file (or `JSON text`).
        origin: String,
        /// The `count` field.
        count: usize,
        /// The number of positions present.
        found: usize,
    },

    /// A `grid:` specification could not be parsed.
    ///
    /// Fix: write it as `grid:NXxNYxNZ` with three positive integers, e.g. `grid:4x2x4`.
    #[error("probe spec `{spec}`: {reason}; write it as grid:NXxNYxNZ, e.g. grid:4x2x4")]
    InvalidSpec {
        /// The specification given.
        spec: String,
        /// What is wrong with it.
        reason: String,
    },

    /// The grid could not be made over the scene (empty scene or dimensions beyond the caps).
    ///
    /// Fix: see the wrapped [`CandidateError`].
    #[error(transparent)]
    Grid(#[from] CandidateError),
}

/// The JSON layout read from a file (fields beyond these are ignored).
#[derive(serde::Deserialize)]
struct ProbeFile {
    format: String,
    #[serde(default)]
    method: Option<String>,
    #[serde(default)]
    parameters: Option<Map<String, Value>>,
    #[serde(default)]
    count: Option<usize>,
    positions: Vec<[f32; 3]>,
}

impl ProbeSet {
    /// A set of hand-placed positions ([`PlacementMethod::Manual`]).
    pub fn new(positions: Vec<Vec3>) -> ProbeSet {
        ProbeSet {
            positions,
            method: PlacementMethod::Manual,
        }
    }

    /// The same positions, labelled with the method (and its parameters) that placed them.
    pub fn with_method(mut self, method: PlacementMethod) -> Self {
        self.method = method;
        self
    }

    /// The number of probes.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether the set holds no probe.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Opens a probe set from a command-line style specification:
    ///
    /// - `grid:NXxNYxNZ` (e.g. `grid:4x2x4`): a regular grid of `NX·NY·NZ` probes at the cell
    ///   centres of the division of the scene's bounds ([`RegularGrid::over_scene`]), x fastest,
    ///   then y, then z;
    /// - anything else: the path of a `probes/1` JSON file ([`ProbeSet::load`]).
    pub fn from_spec(spec: &str, scene: &Scene) -> Result<ProbeSet, ProbeSetError> {
        match spec.strip_prefix("grid:") {
            Some(dims) => {
                let dims = parse_grid_dims(dims).map_err(|reason| ProbeSetError::InvalidSpec {
                    spec: spec.to_owned(),
                    reason,
                })?;
                Ok(RegularGrid::over_scene(scene, dims)?.probe_set())
            }
            None => ProbeSet::load(spec),
        }
    }

    /// Reads a `probes/1` JSON file (see [`ProbeSet`] for the format).
    pub fn load(path: impl AsRef<Path>) -> Result<ProbeSet, ProbeSetError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ProbeSetError::Io {
            path: path.to_owned(),
            source,
        })?;
        parse(&text, &format!("`{}`", path.display()))
    }

    /// Parses `probes/1` JSON text (see [`ProbeSet`] for the format).
    pub fn from_json(text: &str) -> Result<ProbeSet, ProbeSetError> {
        parse(text, "JSON text")
    }

    /// The `probes/1` JSON text of this set, as [`ProbeSet::save`] writes it: the same set
    /// always gives the same bytes. Errors if a position is not finite (JSON has no NaN).
    pub fn to_json(&self) -> Result<String, ProbeSetError> {
        if let Some(index) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(ProbeSetError::NonFinitePosition {
                origin: "probe set".to_owned(),
                index,
            });
        }
        // Serialising strings and a `Map` of `Value`s cannot fail.
        let json = |value: &Value| serde_json::to_string(value).unwrap_or_default();
        let mut text = String::with_capacity(64 + 40 * self.positions.len());
        text.push_str("{\n");
        let _ = writeln!(
            text,
            "  \"format\": {},",
            json(&Value::from(PROBE_SET_FORMAT))
        );
        let _ = writeln!(
            text,
            "  \"method\": {},",
            json(&Value::from(self.method.name()))
        );
        let _ = writeln!(
            text,
            "  \"parameters\": {},",
            json(&Value::Object(self.method.parameters()))
        );
        let _ = writeln!(text, "  \"count\": {},", self.positions.len());
        text.push_str("  \"positions\": [");
        for (i, p) in self.positions.iter().enumerate() {
            let separator = if i == 0 { "\n" } else { ",\n" };
            // `f32`'s `Debug` prints the shortest decimal that reads back to the same value
            // (`1.0`, `0.1`, `1e-7`: valid JSON numbers), and `−0` becomes `+0` so that the
            // same set gives the same bytes.
            let _ = write!(
                text,
                "{separator}    [{:?}, {:?}, {:?}]",
                p.x + 0.0,
                p.y + 0.0,
                p.z + 0.0
            );
        }
        text.push_str(if self.positions.is_empty() {
            "]\n}\n"
        } else {
            "\n  ]\n}\n"
        });
        Ok(text)
    }

    /// Writes the set as `probes/1` JSON, atomically: to a temporary file in the same folder,
    /// flushed to disk, then renamed over `path`. A failure leaves any earlier file intact.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), ProbeSetError> {
        let path = path.as_ref();
        let text = self.to_json()?;
        write_atomically(path, text.as_bytes()).map_err(|source| ProbeSetError::Io {
            path: path.to_owned(),
            source,
        })
    }
}

/// A JSON number for an `f32` parameter, written as its shortest decimal (`0.1`, not the
/// `0.10000000149011612` of a plain widening to `f64`); `null` if not finite.
pub(crate) fn json_f32(value: f32) -> Value {
    format!("{value}")
        .parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// The `probes/1` layout for serde (borrowed).
#[derive(serde::Serialize)]
struct ProbeFileOut {
    format: &'static str,
    method: String,
    parameters: Map<String, Value>,
    count: usize,
    positions: Vec<[f32; 3]>,
}

impl serde::Serialize for ProbeSet {
    /// The `probes/1` layout ([`ProbeSet`]), so that a set can be embedded in a report.
    /// Non-finite positions fail (JSON has no NaN).
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        if let Some(index) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(serde::ser::Error::custom(format!(
                "probe set position {index} is not finite"
            )));
        }
        ProbeFileOut {
            format: PROBE_SET_FORMAT,
            method: self.method.name(),
            parameters: self.method.parameters(),
            count: self.positions.len(),
            positions: self
                .positions
                .iter()
                .map(|p| (*p + 0.0).to_array())
                .collect(),
        }
        .serialize(serializer)
    }
}

impl<'de> serde::Deserialize<'de> for ProbeSet {
    /// Reads the `probes/1` layout with the same checks as [`ProbeSet::load`].
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let file = ProbeFile::deserialize(deserializer)?;
        validate(file, "(deserialized)").map_err(serde::de::Error::custom)
    }
}

/// Writes `bytes` to `path` through a temporary sibling file and a rename.
fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file")
    })?;
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent.to_owned(),
        _ => PathBuf::from("."),
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".tmp{}", std::process::id()));
    let temp = folder.join(temp_name);
    let result = (|| {
        let mut file = std::fs::File::create(&temp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&temp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    result
}

fn parse(text: &str, origin: &str) -> Result<ProbeSet, ProbeSetError> {
    let file: ProbeFile = serde_json::from_str(text).map_err(|source| ProbeSetError::Parse {
        origin: origin.to_owned(),
        source,
    })?;
    validate(file, origin)
}

/// Checks a file's fields and builds the set.
fn validate(file: ProbeFile, origin: &str) -> Result<ProbeSet, ProbeSetError> {
    if file.format != PROBE_SET_FORMAT {
        return Err(ProbeSetError::UnsupportedFormat {
            origin: origin.to_owned(),
            found: file.format,
        });
    }
    if let Some(count) = file.count
        && count != file.positions.len()
    {
        return Err(ProbeSetError::CountMismatch {
            origin: origin.to_owned(),
            count,
            found: file.positions.len(),
        });
    }
    let positions: Vec<Vec3> = file.positions.iter().map(|&p| Vec3::from(p)).collect();
    // JSON numbers beyond f32's range read as infinities.
    if let Some(index) = positions.iter().position(|p| !p.is_finite()) {
        return Err(ProbeSetError::NonFinitePosition {
            origin: origin.to_owned(),
            index,
        });
    }
    Ok(ProbeSet {
        positions,
        method: PlacementMethod::from_recorded(
            file.method.as_deref().unwrap_or("manual"),
            file.parameters.unwrap_or_default(),
        ),
    })
}

/// Parses `NXxNYxNZ` into three positive integers (range caps are checked by the grid).
fn parse_grid_dims(text: &str) -> Result<[u32; 3], String> {
    let parts: Vec<&str> = text.split('x').collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected three dimensions separated by `x`, found {}",
            parts.len()
        ));
    }
    let mut dims = [0u32; 3];
    for (axis, (dim, part)) in dims.iter_mut().zip(&parts).enumerate() {
        let name = ["x", "y", "z"][axis];
        *dim = part.trim().parse::<u32>().map_err(|_| {
            format!("the {name} dimension `{part}` is not a non-negative integer below 2^32")
        })?;
    }
    Ok(dims)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_dims_parse() {
        assert_eq!(parse_grid_dims("4x2x4"), Ok([4, 2, 4]));
        assert_eq!(parse_grid_dims("10x1x300"), Ok([10, 1, 300]));
        assert!(parse_grid_dims("4x2").is_err());
        assert!(parse_grid_dims("4x2x4x1").is_err());
        assert!(parse_grid_dims("4x-2x4").is_err());
        assert!(parse_grid_dims("4xax4").is_err());
        assert!(parse_grid_dims("").is_err());
    }

    #[test]
    fn json_round_trip_is_exact_and_deterministic() {
        let positions = vec![
            Vec3::new(0.1, -0.0, 1e-7),
            Vec3::new(-26.84, 23.62, 14.9),
            Vec3::new(f32::MAX, f32::MIN_POSITIVE, 1.0 / 3.0),
        ];
        let mut parameters = Map::new();
        parameters.insert("z".to_owned(), Value::from(1));
        parameters.insert("a".to_owned(), Value::from("b\"q"));
        let set = ProbeSet::new(positions).with_method(PlacementMethod::Recorded {
            name: "sdf".to_owned(),
            parameters,
        });
        let text = set.to_json().unwrap();
        let back = ProbeSet::from_json(&text).unwrap();
        // Not the parameters `sdf_candidates` writes, so kept as recorded.
        assert_eq!(back.method, set.method);
        for (a, b) in set.positions.iter().zip(&back.positions) {
            // Bit-exact, except that −0 is written as +0.
            assert_eq!(
                (*a + 0.0).to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
        assert_eq!(back.to_json().unwrap(), text);
        assert!(text.find("\"a\"").unwrap() < text.find("\"z\"").unwrap());
    }

    #[test]
    fn bad_json_is_refused_with_a_reason() {
        let err = ProbeSet::from_json("{\"format\": \"probes/2\", \"positions\": []}").unwrap_err();
        assert!(
            matches!(err, ProbeSetError::UnsupportedFormat { ref found, .. } if found == "probes/2")
        );
        let err = ProbeSet::from_json("{\"format\": \"probes/1\"}").unwrap_err();
        assert!(matches!(err, ProbeSetError::Parse { .. }), "{err}");
        assert!(err.to_string().contains("positions"), "{err}");
        let err =
            ProbeSet::from_json("{\"format\": \"probes/1\", \"positions\": [[1,2]]}").unwrap_err();
        assert!(matches!(err, ProbeSetError::Parse { .. }), "{err}");
        let err = ProbeSet::from_json(
            "{\"format\": \"probes/1\", \"count\": 2, \"positions\": [[1,2,3]]}",
        )
        .unwrap_err();
        assert!(matches!(
            err,
            ProbeSetError::CountMismatch {
                count: 2,
                found: 1,
                ..
            }
        ));
        let err = ProbeSet::from_json("{\"format\": \"probes/1\", \"positions\": [[1e60,2,3]]}")
            .unwrap_err();
        assert!(
            matches!(err, ProbeSetError::NonFinitePosition { index: 0, .. }),
            "{err}"
        );
        let ok = ProbeSet::from_json(
            "{\"format\": \"probes/1\", \"positions\": [[1,2,3]], \"future\": true}",
        )
        .unwrap();
        assert_eq!(ok.positions, vec![Vec3::new(1.0, 2.0, 3.0)]);
        assert_eq!(ok.method, PlacementMethod::Manual);
        let nan = ProbeSet::new(vec![Vec3::ONE, Vec3::NAN]);
        assert!(matches!(
            nan.to_json(),
            Err(ProbeSetError::NonFinitePosition { index: 1, .. })
        ));
    }

    #[test]
    fn serde_uses_the_file_layout() {
        let set = ProbeSet::new(vec![Vec3::new(1.5, -2.0, 0.25)]);
        let value = serde_json::to_value(&set).unwrap();
        assert_eq!(
            value,
            serde_json::json!({
                "format": "probes/1", "method": "manual", "parameters": {}, "count": 1,
                "positions": [[1.5, -2.0, 0.25]]
            })
        );
        let back: ProbeSet = serde_json::from_value(value).unwrap();
        assert_eq!(back, set);
        // The text writer and serde agree.
        let from_text: Value = serde_json::from_str(&set.to_json().unwrap()).unwrap();
        assert_eq!(from_text, serde_json::to_value(&set).unwrap());
        let bad = serde_json::json!({"format": "probes/9", "positions": []});
        assert!(serde_json::from_value::<ProbeSet>(bad).is_err());
        assert!(serde_json::to_value(ProbeSet::new(vec![Vec3::NAN])).is_err());
    }

    #[test]
    fn empty_set_round_trips() {
        let set = ProbeSet::new(Vec::new());
        let text = set.to_json().unwrap();
        assert_eq!(ProbeSet::from_json(&text).unwrap(), set);
    }
}
