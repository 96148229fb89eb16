//! How a probe set was made: [`PlacementMethod`], the method with its parameters, typed.

use crate::candidates::{MedialParams, SdfParams};
use crate::pipeline::{Method, Optimizer};
use crate::probes::json_f32;
use crate::region::Region;
use glam::Vec3;
use probe_scene::Aabb;
use serde_json::{Map, Value, json};
use std::fmt;

/// The placement method that made a [`ProbeSet`](crate::ProbeSet) or a
/// [`PlacementReport`](crate::atlas::PlacementReport), with its parameters.
///
/// In files and reports it is two fields, as in every `probes/1` file so far: `"method"`, a
/// name ([`PlacementMethod::name`], e.g. `"grid"`, `"sdf"`, `"grid-4x2x4+gibbs@12"`) and
/// `"parameters"`, a JSON object ([`PlacementMethod::parameters`], keys sorted).
/// Reading ([`PlacementMethod::from_recorded`]) gives back the typed variant for `manual`,
/// `grid`, `grid-relocated`, `grid-classified`, `sdf` and `medial` when the parameters are
/// exactly those this version writes; anything else (a [`pipeline::place`](crate::pipeline::place)
/// run, another tool's file) is kept as [`PlacementMethod::Recorded`], so it is written back
/// byte for byte.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum PlacementMethod {
    /// Placed by hand: `"manual"`, no parameters.
    Manual,
    /// [`RegularGrid::probe_set`](crate::candidates::RegularGrid::probe_set): `"grid"`.
    Grid {
        /// Cells per axis.
        dims: [u32; 3],
        /// The box divided.
        bounds: Aabb,
    },
    /// [`ClassifiedGrid::probe_set`](crate::candidates::ClassifiedGrid::probe_set):
    /// `"grid-relocated"`, or `"grid-classified"` without relocation.
    ClassifiedGrid {
        /// Cells per axis.
        dims: [u32; 3],
        /// The box divided.
        bounds: Aabb,
        /// Probes switched off.
        removed: usize,
        /// Whether kept probes were moved towards free space.
        relocated: bool,
    },
    /// [`sdf_candidates`](crate::candidates::sdf_candidates): `"sdf"`.
    Sdf {
        /// The parameters given.
        params: SdfParams,
        /// Skeleton voxels found.
        skeleton_voxels: usize,
    },
    /// [`medial_candidates`](crate::candidates::medial_candidates): `"medial"`.
    Medial {
        /// The parameters given.
        params: MedialParams,
        /// Medial balls kept.
        medial_balls: usize,
    },
    /// [`pipeline::place`](crate::pipeline::place): method, cut, optimiser and what they found.
    Placed(PlaceProvenance),
    /// Read from a file or report and not one of the typed forms above: kept as recorded.
    Recorded {
        /// The `"method"` field.
        name: String,
        /// The `"parameters"` field.
        parameters: Map<String, Value>,
    },
}

/// What a [`pipeline::place`](crate::pipeline::place) run did, for [`PlacementMethod::Placed`].
/// Fields a method does not produce are `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceProvenance {
    /// The method.
    pub method: Method,
    /// The optimiser run afterwards, with its step (metres) and iteration cap.
    pub optimizer: Option<(Optimizer, f32, usize)>,
    /// The probe budget.
    pub budget: Option<usize>,
    /// The coverage target, when below 1.
    pub coverage_target: Option<f32>,
    /// Whether the target held for each view ([`PlaceOptions::each_view`](crate::pipeline::PlaceOptions::each_view)).
    pub each_view: bool,
    /// The seed of every random choice.
    pub seed: u64,
    /// [`Method::GridRelocated`]: probes switched off.
    pub removed: Option<usize>,
    /// Seed 002's methods: the start spacing, metres.
    pub spacing: Option<f32>,
    /// Seed 002's methods: lit probes.
    pub lit: Option<usize>,
    /// Seed 002's methods: unlit probes (placed by k-means).
    pub unlit: Option<usize>,
    /// [`Method::Minimal`]: the candidate pool's size.
    pub candidates: Option<usize>,
    /// The region of interest the probes were placed in ([`PlaceOptions::region`](crate::pipeline::PlaceOptions::region)).
    pub region: Option<Region>,
    /// Probes added to complete the coverage ([`PlaceOptions::complete`](crate::pipeline::PlaceOptions::complete)).
    pub completed: Option<usize>,
    /// The views whose seen points were the atlas ([`PlaceOptions::viewers`](crate::pipeline::PlaceOptions::viewers)).
    pub viewers: Option<usize>,
}

impl PlaceProvenance {
    /// A run of `method` with `seed`, nothing else recorded yet.
    pub fn new(method: Method, seed: u64) -> PlaceProvenance {
        PlaceProvenance {
            method,
            optimizer: None,
            budget: None,
            coverage_target: None,
            each_view: false,
            seed,
            removed: None,
            spacing: None,
            lit: None,
            unlit: None,
            candidates: None,
            region: None,
            completed: None,
            viewers: None,
        }
    }
}

impl PlacementMethod {
    /// The name written as `"method"` (`"manual"`, `"grid"`, `"sdf"`, `"grid-4x2x4+gibbs@12"`).
    pub fn name(&self) -> String {
        match self {
            PlacementMethod::Manual => "manual".to_owned(),
            PlacementMethod::Grid { .. } => "grid".to_owned(),
            PlacementMethod::ClassifiedGrid { relocated, .. } => if *relocated {
                "grid-relocated"
            } else {
                "grid-classified"
            }
            .to_owned(),
            PlacementMethod::Sdf { .. } => "sdf".to_owned(),
            PlacementMethod::Medial { .. } => "medial".to_owned(),
            PlacementMethod::Placed(run) => {
                let mut name = run.method.name();
                match run.optimizer {
                    Some((Optimizer::Gibbs, ..)) => name.push_str("+gibbs"),
                    Some((Optimizer::Descent, ..)) => name.push_str("+descent"),
                    None => {}
                }
                if run.viewers.is_some() {
                    name.push_str("+views");
                }
                if run.completed.is_some() {
                    name.push_str("+complete");
                }
                if let Some(budget) = run.budget {
                    name.push_str(&format!("@{budget}"));
                }
                name
            }
            PlacementMethod::Recorded { name, .. } => name.clone(),
        }
    }

    /// The parameters written as `"parameters"` (a JSON object; keys sorted).
    pub fn parameters(&self) -> Map<String, Value> {
        match self {
            PlacementMethod::Manual => Map::new(),
            PlacementMethod::Grid { dims, bounds } => grid_parameters(*dims, bounds),
            PlacementMethod::ClassifiedGrid {
                dims,
                bounds,
                removed,
                ..
            } => {
                let mut parameters = grid_parameters(*dims, bounds);
                parameters.insert("removed".to_owned(), Value::from(*removed));
                parameters
            }
            PlacementMethod::Sdf {
                params,
                skeleton_voxels,
            } => {
                let mut parameters = params.to_json();
                parameters.insert("skeleton_voxels".to_owned(), Value::from(*skeleton_voxels));
                parameters
            }
            PlacementMethod::Medial {
                params,
                medial_balls,
            } => {
                let mut parameters = params.to_json();
                parameters.insert("medial_balls".to_owned(), Value::from(*medial_balls));
                parameters
            }
            PlacementMethod::Placed(run) => {
                let mut parameters = Map::new();
                let mut put = |key: &str, value: Value| {
                    parameters.insert(key.to_owned(), value);
                };
                if let Method::Grid(dims) | Method::GridRelocated(dims) = run.method {
                    put("dims", json!(dims));
                }
                let counts = [
                    ("removed", run.removed),
                    ("lit", run.lit),
                    ("unlit", run.unlit),
                    ("candidates", run.candidates),
                    ("budget", run.budget),
                    ("completed", run.completed),
                    ("viewers", run.viewers),
                ];
                for (key, value) in counts {
                    if let Some(value) = value {
                        put(key, json!(value));
                    }
                }
                if let Some(spacing) = run.spacing {
                    put("spacing", json!(spacing));
                }
                if let Some((_, step, iterations)) = run.optimizer {
                    put("step", json!(step));
                    put("iterations", json!(iterations));
                }
                if let Some(target) = run.coverage_target {
                    put("coverage_target", json!(target));
                }
                if run.each_view {
                    put("each_view", json!(true));
                }
                put("seed", json!(run.seed));
                if let Some(region) = &run.region {
                    put("region", region.to_json());
                }
                parameters
            }
            PlacementMethod::Recorded { parameters, .. } => parameters.clone(),
        }
    }

    /// The method read from a file's or report's `"method"` and `"parameters"` fields: the
    /// typed variant when `name` is one this version writes and `parameters` are exactly what
    /// it would write for it, [`PlacementMethod::Recorded`] otherwise. Either way, writing it
    /// back gives the same two fields.
    pub fn from_recorded(name: &str, parameters: Map<String, Value>) -> PlacementMethod {
        let typed = parse_typed(name, &parameters);
        match typed {
            Some(typed) if typed.name() == name && typed.parameters() == parameters => typed,
            _ => PlacementMethod::Recorded {
                name: name.to_owned(),
                parameters,
            },
        }
    }
}

impl fmt::Display for PlacementMethod {
    /// The [name](PlacementMethod::name).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// The two fields as they are written: `"method"` and `"parameters"`.
#[derive(serde::Serialize, serde::Deserialize)]
struct RecordedFields {
    method: String,
    #[serde(default)]
    parameters: Map<String, Value>,
}

impl serde::Serialize for PlacementMethod {
    /// `{"method": name, "parameters": {...}}`; flattened into reports.
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        RecordedFields {
            method: self.name(),
            parameters: self.parameters(),
        }
        .serialize(serializer)
    }
}

impl<'de> serde::Deserialize<'de> for PlacementMethod {
    /// Reads `{"method": name, "parameters": {...}}` ([`PlacementMethod::from_recorded`]).
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = RecordedFields::deserialize(deserializer)?;
        Ok(PlacementMethod::from_recorded(
            &fields.method,
            fields.parameters,
        ))
    }
}

pub(crate) fn grid_parameters(dims: [u32; 3], bounds: &Aabb) -> Map<String, Value> {
    let mut parameters = Map::new();
    parameters.insert("dims".to_owned(), Value::from(dims.to_vec()));
    parameters.insert(
        "bounds".to_owned(),
        Value::Array(
            [bounds.min, bounds.max]
                .iter()
                .map(|corner| Value::Array(corner.to_array().map(json_f32).to_vec()))
                .collect(),
        ),
    );
    parameters
}

/// The typed form of a recorded method, if `name` is one this version writes and the
/// parameters it needs are there (the caller checks that writing it back is exact).
fn parse_typed(name: &str, parameters: &Map<String, Value>) -> Option<PlacementMethod> {
    let count = |key: &str| parameters.get(key)?.as_u64().map(|v| v as usize);
    let float = |key: &str| parameters.get(key)?.as_f64().map(|v| v as f32);
    let dims = || -> Option<[u32; 3]> {
        let dims = parameters.get("dims")?.as_array()?;
        let dims: Vec<u32> = dims
            .iter()
            .map(|d| d.as_u64().and_then(|d| u32::try_from(d).ok()))
            .collect::<Option<_>>()?;
        dims.try_into().ok()
    };
    let bounds = || -> Option<Aabb> {
        let corners = parameters.get("bounds")?.as_array()?;
        let corner = |value: &Value| -> Option<Vec3> {
            let xyz: Vec<f32> = value
                .as_array()?
                .iter()
                .map(|c| c.as_f64().map(|c| c as f32))
                .collect::<Option<_>>()?;
            Some(Vec3::from_slice(xyz.get(..3)?))
        };
        match corners.as_slice() {
            [min, max] => Some(Aabb {
                min: corner(min)?,
                max: corner(max)?,
            }),
            _ => None,
        }
    };
    match name {
        "manual" => Some(PlacementMethod::Manual),
        "grid" => Some(PlacementMethod::Grid {
            dims: dims()?,
            bounds: bounds()?,
        }),
        "grid-relocated" | "grid-classified" => Some(PlacementMethod::ClassifiedGrid {
            dims: dims()?,
            bounds: bounds()?,
            removed: count("removed")?,
            relocated: name == "grid-relocated",
        }),
        "sdf" => Some(PlacementMethod::Sdf {
            params: SdfParams {
                voxel_size: float("voxel_size")?,
                min_clearance: float("min_clearance")?,
                min_cluster_voxels: count("min_cluster_voxels")?,
                coverage_factor: float("coverage_factor")?,
                max_cluster_radius: float("max_cluster_radius")?,
            },
            skeleton_voxels: count("skeleton_voxels")?,
        }),
        "medial" => Some(PlacementMethod::Medial {
            params: MedialParams {
                sample_count: count("sample_count")?,
                seed: parameters.get("seed")?.as_u64()?,
                initial_radius: float("initial_radius")?,
                convergence: float("convergence")?,
                iteration_limit: count("iteration_limit")?,
                denoise_preserve_degrees: float("denoise_preserve_degrees")?,
                denoise_planar_degrees: float("denoise_planar_degrees")?,
                voxel_size: float("voxel_size")?,
                min_radius: float("min_radius")?,
                coverage_factor: float("coverage_factor")?,
                max_cluster_radius: float("max_cluster_radius")?,
                min_cluster_balls: count("min_cluster_balls")?,
            },
            medial_balls: count("medial_balls")?,
        }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_methods_read_back_typed_and_others_stay_as_recorded() {
        let grid = PlacementMethod::Grid {
            dims: [4, 2, 4],
            bounds: Aabb {
                min: Vec3::new(-4.2, -0.2, -4.2),
                max: Vec3::new(4.2, 3.2, 4.2),
            },
        };
        let back = PlacementMethod::from_recorded(&grid.name(), grid.parameters());
        assert_eq!(back, grid);
        let text = serde_json::to_string(&grid).unwrap();
        assert_eq!(
            text,
            r#"{"method":"grid","parameters":{"bounds":[[-4.2,-0.2,-4.2],[4.2,3.2,4.2]],"dims":[4,2,4]}}"#
        );
        // An extra key makes it a method this version does not write: kept as recorded.
        let mut extra = grid.parameters();
        extra.insert("note".to_owned(), Value::from("hand-edited"));
        let kept = PlacementMethod::from_recorded("grid", extra.clone());
        assert!(matches!(kept, PlacementMethod::Recorded { .. }));
        assert_eq!(kept.parameters(), extra);
        assert_eq!(
            PlacementMethod::from_recorded("manual", Map::new()),
            PlacementMethod::Manual
        );
    }

    #[test]
    fn a_placement_run_is_named_and_recorded_as_before() {
        let mut run = PlaceProvenance::new(Method::Grid([3, 3, 3]), 7);
        run.optimizer = Some((Optimizer::Gibbs, 0.25, 4));
        run.budget = Some(3);
        let method = PlacementMethod::Placed(run);
        assert_eq!(method.name(), "grid-3x3x3+gibbs@3");
        assert_eq!(
            Value::Object(method.parameters()),
            json!({"dims": [3, 3, 3], "step": 0.25, "iterations": 4, "budget": 3, "seed": 7})
        );
    }
}
