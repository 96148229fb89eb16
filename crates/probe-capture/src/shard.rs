//! Sharded bakes: one machine (or one job of a scheduler's array) bakes shard `K/N` of the
//! probes into a partial bake; [`merge_shards`] joins the `N` partial bakes into the bake an
//! unsharded run gives, byte for byte once saved.
//!
//! That holds because every random number of a probe's samples is keyed by the probe's index
//! in the whole set (not in the shard), the adaptive pass and the derived maps look at one
//! probe only, and the scene-wide values (the default environment, the moments' clamping
//! distance) come from the scene and the settings alone.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::Vec3;
use probe_scene::Scene;
use probe_scene::memory::{MemoryExceeded, MemoryLimit};
use sha2::{Digest, Sha256};

use crate::bake::{BakeError, BakeSettings, ProbeBake, Progress, bake_memory_estimate};
use crate::bake_io::{BakeLoadError, BakeSaveError, hex, read_header};

/// One shard `K/N` of a sharded bake: the `K`-th (0-based) of `N` contiguous, nearly equal
/// runs of the probe set ([`Shard::probe_range`]). Parses from and prints as `K/N`.
///
/// ```
/// use probe_capture::Shard;
///
/// let shard: Shard = "1/3".parse()?;
/// assert_eq!((shard.index(), shard.count()), (1, 3));
/// assert_eq!(shard.probe_range(10), 3..6);
/// assert!("3/3".parse::<Shard>().is_err());
/// # Ok::<(), probe_capture::ShardError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Shard {
    index: u32,
    count: u32,
}

/// Why a shard specification was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ShardError {
    /// The text is not `K/N` with `0 <= K < N`. Fix: give the shard as `K/N`, e.g. `0/4`
    /// for the first of four shards (Slurm's `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`).
    #[error("shard {text:?}: {reason}")]
    Invalid {
        /// The shard given.
        text: String,
        /// What is accepted.
        reason: &'static str,
    },
}

impl Shard {
    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`ShardError::Invalid`] unless `count >= 1` and `index < count`.
    pub fn new(index: u32, count: u32) -> Result<Shard, ShardError> {
        let invalid = |reason| ShardError::Invalid {
            text: format!("{index}/{count}"),
            reason,
        };
        if count == 0 {
            return Err(invalid("the shard count N must be at least 1"));
        }
        if index >= count {
            return Err(invalid(
                "the shard index K counts from 0 and must be less than N",
            ));
        }
        Ok(Shard { index, count })
    }

    /// The shard's index `K` (0-based).
    pub fn index(&self) -> u32 {
        self.index
    }

    /// The shard count `N`.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The probes of this shard in a set of `probes`: `K·P/N .. (K+1)·P/N` (rounded down).
    /// Over `K = 0..N` the ranges are contiguous and cover `0..P`; none is empty when
    /// `N <= P`, and their lengths differ by at most one.
    pub fn probe_range(&self, probes: usize) -> Range<usize> {
        let at = |k: u32| (u128::from(k) * probes as u128 / u128::from(self.count)) as usize;
        at(self.index)..at(self.index + 1)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    fn from_str(text: &str) -> Result<Shard, ShardError> {
        let invalid = |reason| ShardError::Invalid {
            text: text.to_owned(),
            reason,
        };
        let (index, count) = text
            .trim()
            .split_once('/')
            .ok_or_else(|| invalid("expected K/N, e.g. 0/4 for the first of four shards"))?;
        let number = |s: &str| {
            s.trim()
                .parse::<u32>()
                .map_err(|_| invalid("K and N must be whole numbers, as in 0/4"))
        };
        Shard::new(number(index)?, number(count)?).map_err(|e| match e {
            ShardError::Invalid { reason, .. } => invalid(reason),
        })
    }
}

/// SHA-256 of a probe set's positions (their count and the bits of every coordinate), which
/// every shard records so that shards of different probe sets are not merged.
pub fn probe_set_hash(positions: &[Vec3]) -> [u8; 32] {
    let mut hasher = Sha256::new();
    hasher.update(b"probe-capture probe set v1");
    hasher.update((positions.len() as u64).to_le_bytes());
    for p in positions {
        for c in p.to_array() {
            hasher.update(c.to_bits().to_le_bytes());
        }
    }
    hasher.finalize().into()
}

/// Which part of a sharded bake a partial bake holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ShardRecord {
    pub(crate) shard: Shard,
    pub(crate) probe_range: Range<usize>,
    pub(crate) total_probes: usize,
    pub(crate) probe_set_hash: [u8; 32],
}

/// One shard of a sharded bake: the [`ProbeBake`] of the shard's probes, baked as they are in
/// the whole bake, and which shard of which probe set it is. Saved like a bake, with a
/// `shard` record in the manifest (index, count, probe range, whole set's size and
/// [`probe_set_hash`]); [`ProbeBake::load`] refuses it, [`merge_shards`] joins them.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialBake {
    record: ShardRecord,
    bake: ProbeBake,
}

impl PartialBake {
    /// Which shard this is.
    pub fn shard(&self) -> Shard {
        self.record.shard
    }

    /// The shard's probes, as indices in the whole set.
    pub fn probe_range(&self) -> Range<usize> {
        self.record.probe_range.clone()
    }

    /// Probes in the whole set.
    pub fn total_probes(&self) -> usize {
        self.record.total_probes
    }

    /// [`probe_set_hash`] of the whole set.
    pub fn probe_set_hash(&self) -> [u8; 32] {
        self.record.probe_set_hash
    }

    /// The shard's probes, baked.
    pub fn bake(&self) -> &ProbeBake {
        &self.bake
    }

    /// The shard's probes, baked, without the shard record.
    pub fn into_bake(self) -> ProbeBake {
        self.bake
    }

    /// Writes the partial bake to `dir` as [`ProbeBake::save`] does (atomically: a shard that
    /// dies while saving leaves no half-written directory, and a re-run replaces a previous
    /// result whole), with the shard record in the manifest.
    ///
    /// # Errors
    /// [`BakeSaveError`]; on error `dir` is unchanged.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<(), BakeSaveError> {
        self.bake.save_with_shard(dir.as_ref(), Some(&self.record))
    }

    /// Reads a partial bake written by [`PartialBake::save`]; with `scene`, it must have been
    /// baked from that scene.
    ///
    /// # Errors
    /// [`BakeLoadError::NotAShard`] for a whole bake, and the errors of [`ProbeBake::load`].
    pub fn load(
        dir: impl AsRef<Path>,
        scene: Option<&Scene>,
    ) -> Result<PartialBake, BakeLoadError> {
        let (bake, record) =
            ProbeBake::load_part(dir.as_ref(), scene, MemoryLimit::machine(), true)?;
        match record {
            Some(record) => Ok(PartialBake { record, bake }),
            None => Err(BakeLoadError::NotAShard {
                path: dir.as_ref().join(crate::MANIFEST_FILE),
            }),
        }
    }
}

/// Bakes shard `shard` of the probes at `positions` (the whole set, the same on every shard):
/// the probes [`Shard::probe_range`] gives, each baked exactly as [`bake`](crate::bake) of the
/// whole set bakes it. `progress` and the memory limit cover the shard's probes only.
///
/// # Errors
/// [`BakeError::TooManyShards`] when the shard count exceeds the probes, and the errors of
/// [`bake_with_limit`](crate::bake_with_limit) (probe indices in them are indices in the
/// whole set).
///
/// # Example
/// ```
/// use probe_capture::{BakeSettings, Sampling, Shard, bake, bake_shard, merge_shards, no_progress};
/// use probe_scene::{Scene, glam::Vec3, memory::MemoryLimit};
///
/// let scene = Scene::builtin("cornell")?;
/// let positions = [Vec3::new(0.28, 0.27, 0.28), Vec3::new(0.1, 0.4, 0.2), Vec3::new(0.4, 0.1, 0.1)];
/// let settings = BakeSettings { resolution: 8, sampling: Sampling::fixed(2), ..Default::default() };
/// let dir = std::env::temp_dir().join(format!("probe-capture-shard-doc-{}", std::process::id()));
/// let mut shard_dirs = Vec::new();
/// for k in 0..2 {
///     let shard = Shard::new(k, 2)?;
///     let part = bake_shard(&scene, &positions, shard, &settings, MemoryLimit::machine(), &no_progress)?;
///     let shard_dir = dir.join(format!("shard-{k}"));
///     part.save(&shard_dir)?;
///     shard_dirs.push(shard_dir);
/// }
/// let merged = merge_shards(&shard_dirs, Some(&scene), MemoryLimit::machine(), &no_progress)?;
/// assert_eq!(merged, bake(&scene, &positions, &settings, &no_progress)?);
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn bake_shard(
    scene: &Scene,
    positions: &[Vec3],
    shard: Shard,
    settings: &BakeSettings,
    limit: MemoryLimit,
    progress: Progress<'_>,
) -> Result<PartialBake, BakeError> {
    if positions.is_empty() {
        return Err(BakeError::NoProbes);
    }
    if let Some((probe, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(BakeError::InvalidPosition {
            probe,
            position: p.to_array(),
        });
    }
    if shard.count() as usize > positions.len() {
        return Err(BakeError::TooManyShards {
            shards: shard.count(),
            probes: positions.len(),
        });
    }
    let range = shard.probe_range(positions.len());
    let bake = crate::bake::bake_probes(
        scene,
        &positions[range.clone()],
        range.start,
        settings,
        limit,
        progress,
    )?;
    Ok(PartialBake {
        record: ShardRecord {
            shard,
            probe_range: range,
            total_probes: positions.len(),
            probe_set_hash: probe_set_hash(positions),
        },
        bake,
    })
}

/// Why partial bakes could not be merged. Every variant names the shard directories at
/// fault; nothing is written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MergeError {
    /// No shard directory was given. Fix: pass the `N` directories written by
    /// `probes bake --shard K/N`.
    #[error("no shard directories were given: pass the N directories of `probes bake --shard K/N`")]
    NoShards,
    /// A shard could not be read, or a directory holds a whole bake rather than a shard
    /// ([`BakeLoadError::NotAShard`]). Fix: see the inner error.
    #[error(transparent)]
    Load(#[from] BakeLoadError),
    /// Two shards come from splits into different numbers of shards. Fix: merge the shards of
    /// one run (all `K/N` with the same `N`).
    #[error(
        "{} is shard {shard} but {} is shard {first_shard}: shards of a split into {} and of a \
         split into {} cannot be merged",
        path.display(), first.display(), first_shard.count(), shard.count()
    )]
    OtherShardCount {
        /// The shard directory that differs.
        path: PathBuf,
        /// Its shard.
        shard: Shard,
        /// The first shard directory given.
        first: PathBuf,
        /// The first directory's shard.
        first_shard: Shard,
    },
    /// Two shards were baked from different scenes (content hashes differ). Fix: re-bake the
    /// shard from the same scene as the others.
    #[error(
        "{} was baked from scene {scene} but {} from {first_scene}: re-bake it from the same \
         scene",
        path.display(), first.display()
    )]
    OtherScene {
        /// The shard directory that differs.
        path: PathBuf,
        /// Its scene: name and content hash (hex).
        scene: String,
        /// The first shard directory given.
        first: PathBuf,
        /// The first directory's scene: name and content hash (hex).
        first_scene: String,
    },
    /// Two shards were baked with different settings (or lit differently). Fix: re-bake the
    /// shard with the same options as the others.
    #[error(
        "{} was baked with other settings than {}: {difference}; re-bake it with the same options",
        path.display(), first.display()
    )]
    OtherSettings {
        /// The shard directory that differs.
        path: PathBuf,
        /// The first shard directory given.
        first: PathBuf,
        /// Which setting differs and its two values.
        difference: String,
    },
    /// Two shards are parts of different probe sets (another size or other positions). Fix:
    /// re-bake the shard with the same `--probes` as the others.
    #[error(
        "{} is a shard of another probe set than {} ({total} probes, set hash {hash}, against \
         {first_total} probes, set hash {first_hash}): re-bake it with the same probes",
        path.display(), first.display()
    )]
    OtherProbeSet {
        /// The shard directory that differs.
        path: PathBuf,
        /// Probes in its whole set.
        total: usize,
        /// Its [`probe_set_hash`] (hex).
        hash: String,
        /// The first shard directory given.
        first: PathBuf,
        /// Probes in the first directory's whole set.
        first_total: usize,
        /// The first directory's set hash (hex).
        first_hash: String,
    },
    /// The same shard was given twice. Fix: pass each shard's directory once.
    #[error(
        "shard {shard} was given twice: {} and {}; pass each shard once",
        path.display(), other.display()
    )]
    DuplicateShard {
        /// The shard.
        shard: Shard,
        /// The first directory holding it.
        path: PathBuf,
        /// The second.
        other: PathBuf,
    },
    /// Shards are missing. Fix: bake them (`probes bake --shard K/N`) and merge again.
    #[error(
        "shard(s) {} of {count} missing (found {found} of {count}); bake them with `probes bake \
         --shard K/{count}` and merge again",
        missing.iter().map(|k| format!("{k}/{count}")).collect::<Vec<_>>().join(", ")
    )]
    MissingShards {
        /// The missing shard indices.
        missing: Vec<u32>,
        /// The shard count.
        count: u32,
        /// Shards found.
        found: usize,
    },
    /// The shards' positions, joined, are not the probe set their manifests record (a shard
    /// was edited or damaged). Fix: re-bake the shards.
    #[error(
        "the positions of the shards in {} … joined do not hash to the probe set hash {expected} \
         their manifests record (got {found}); a shard was edited or damaged: re-bake them",
        first.display()
    )]
    PositionsDiffer {
        /// The first shard directory given.
        first: PathBuf,
        /// The hash recorded (hex).
        expected: String,
        /// The hash of the joined positions (hex).
        found: String,
    },
    /// The merged bake would exceed the memory limit. Fix: raise the limit (`--max-memory`)
    /// on a machine with the memory.
    #[error(transparent)]
    OverMemory(#[from] MemoryExceeded),
}

/// The first setting that differs between two bakes' settings, as `name a vs b`.
fn settings_difference(a: &BakeSettings, b: &BakeSettings) -> Option<String> {
    let BakeSettings {
        resolution,
        sampling,
        bounces,
        seed,
        environment,
        pyramid_levels,
        moments_resolution,
        moments_lobe_power,
        moments_max_distance,
        irradiance_resolution,
        filter_source_resolution,
        surfel_resolution,
        denoise,
        radiance,
    } = a;
    let fields: [(&str, String, String); 14] = [
        (
            "resolution",
            format!("{resolution}"),
            format!("{}", b.resolution),
        ),
        (
            "sampling",
            format!("{sampling:?}"),
            format!("{:?}", b.sampling),
        ),
        ("bounces", format!("{bounces}"), format!("{}", b.bounces)),
        ("seed", format!("{seed}"), format!("{}", b.seed)),
        (
            "environment",
            format!("{environment:?}"),
            format!("{:?}", b.environment),
        ),
        (
            "pyramid_levels",
            format!("{pyramid_levels}"),
            format!("{}", b.pyramid_levels),
        ),
        (
            "moments_resolution",
            format!("{moments_resolution}"),
            format!("{}", b.moments_resolution),
        ),
        (
            "moments_lobe_power",
            format!("{:?}", moments_lobe_power.to_bits()),
            format!("{:?}", b.moments_lobe_power.to_bits()),
        ),
        (
            "moments_max_distance",
            format!("{:?}", moments_max_distance.map(f32::to_bits)),
            format!("{:?}", b.moments_max_distance.map(f32::to_bits)),
        ),
        (
            "irradiance_resolution",
            format!("{irradiance_resolution}"),
            format!("{}", b.irradiance_resolution),
        ),
        (
            "filter_source_resolution",
            format!("{filter_source_resolution}"),
            format!("{}", b.filter_source_resolution),
        ),
        (
            "surfel_resolution",
            format!("{surfel_resolution}"),
            format!("{}", b.surfel_resolution),
        ),
        (
            "denoise",
            format!("{:?}", denoise.to_bits()),
            format!("{:?}", b.denoise.to_bits()),
        ),
        (
            "radiance",
            format!("{radiance:?}"),
            format!("{:?}", b.radiance),
        ),
    ];
    fields
        .into_iter()
        .find(|(_, x, y)| x != y)
        .map(|(name, x, y)| format!("{name} {x} vs {y}"))
}

/// Merges the partial bakes in `dirs` (the `N` shards of one sharded bake, in any order) into
/// the whole bake, equal to the bake of the whole set and byte-identical to it once saved.
/// With `scene`, the shards must have been baked from it.
///
/// Every shard's manifest is read and checked against the first's before any map is loaded:
/// the same shard count, scene, settings, lighting and probe set, no shard twice, none
/// missing. Then the shards are loaded one after another (`progress` receives
/// `(shards loaded, N)`) and appended, and the joined positions are checked against the
/// probe set's hash. The whole bake plus the largest shard must fit `limit`.
///
/// # Errors
/// [`MergeError`], naming the directories at fault.
pub fn merge_shards(
    dirs: &[impl AsRef<Path>],
    scene: Option<&Scene>,
    limit: MemoryLimit,
    progress: Progress<'_>,
) -> Result<ProbeBake, MergeError> {
    let Some(first_dir) = dirs.first() else {
        return Err(MergeError::NoShards);
    };
    let first_dir = first_dir.as_ref();
    let first = read_header(first_dir)?;
    let not_a_shard = |dir: &Path| BakeLoadError::NotAShard {
        path: dir.join(crate::MANIFEST_FILE),
    };
    let Some(first_record) = first.shard.clone() else {
        return Err(not_a_shard(first_dir).into());
    };
    let count = first_record.shard.count();
    let mut by_index: BTreeMap<u32, PathBuf> = BTreeMap::new();
    let mut largest = 0usize;
    for dir in dirs {
        let dir = dir.as_ref();
        let header = read_header(dir)?;
        let Some(record) = &header.shard else {
            return Err(not_a_shard(dir).into());
        };
        if record.shard.count() != count {
            return Err(MergeError::OtherShardCount {
                path: dir.to_owned(),
                shard: record.shard,
                first: first_dir.to_owned(),
                first_shard: first_record.shard,
            });
        }
        if header.scene_hash != first.scene_hash {
            let describe =
                |name: &str, hash: &[u8; 32]| format!("{name:?} (content hash {})", hex(hash));
            return Err(MergeError::OtherScene {
                path: dir.to_owned(),
                scene: describe(&header.scene_name, &header.scene_hash),
                first: first_dir.to_owned(),
                first_scene: describe(&first.scene_name, &first.scene_hash),
            });
        }
        let difference = settings_difference(&header.settings, &first.settings)
            .or_else(|| {
                (header.environment != first.environment).then(|| {
                    format!(
                        "environment {:?} vs {:?}",
                        header.environment, first.environment
                    )
                })
            })
            .or_else(|| {
                (header.moments_max_distance.to_bits() != first.moments_max_distance.to_bits())
                    .then(|| {
                        format!(
                            "moments clamped at {} vs {}",
                            header.moments_max_distance, first.moments_max_distance
                        )
                    })
            });
        if let Some(difference) = difference {
            return Err(MergeError::OtherSettings {
                path: dir.to_owned(),
                first: first_dir.to_owned(),
                difference,
            });
        }
        if record.total_probes != first_record.total_probes
            || record.probe_set_hash != first_record.probe_set_hash
        {
            return Err(MergeError::OtherProbeSet {
                path: dir.to_owned(),
                total: record.total_probes,
                hash: hex(&record.probe_set_hash),
                first: first_dir.to_owned(),
                first_total: first_record.total_probes,
                first_hash: hex(&first_record.probe_set_hash),
            });
        }
        if let Some(other) = by_index.insert(record.shard.index(), dir.to_owned()) {
            return Err(MergeError::DuplicateShard {
                shard: record.shard,
                path: other,
                other: dir.to_owned(),
            });
        }
        largest = largest.max(header.probe_count);
    }
    let missing: Vec<u32> = (0..count).filter(|k| !by_index.contains_key(k)).collect();
    if !missing.is_empty() {
        return Err(MergeError::MissingShards {
            missing,
            count,
            found: by_index.len(),
        });
    }
    let total = first_record.total_probes;
    limit.check(
        format_args!(
            "merging {count} shards of {total} probes at {}²",
            first.settings.resolution
        ),
        bake_memory_estimate(total, &first.settings)
            .saturating_add(bake_memory_estimate(largest, &first.settings)),
    )?;
    let mut merged: Option<ProbeBake> = None;
    for (done, dir) in by_index.values().enumerate() {
        let (part, _) = ProbeBake::load_part(dir, scene, MemoryLimit::bytes(u64::MAX), true)?;
        match &mut merged {
            None => merged = Some(part),
            Some(whole) => append(whole, part),
        }
        progress(done + 1, count as usize);
    }
    let Some(merged) = merged else {
        return Err(MergeError::NoShards);
    };
    let found = probe_set_hash(merged.positions());
    if found != first_record.probe_set_hash {
        return Err(MergeError::PositionsDiffer {
            first: first_dir.to_owned(),
            expected: hex(&first_record.probe_set_hash),
            found: hex(&found),
        });
    }
    Ok(merged)
}

/// Appends the probes of `part` (checked to share `whole`'s scene and settings) to `whole`.
/// Every per-probe array is named, so that a new one cannot be forgotten here.
fn append(whole: &mut ProbeBake, part: ProbeBake) {
    let ProbeBake {
        scene_name: _,
        scene_source: _,
        scene_content_hash: _,
        scene_bounds: _,
        settings: _,
        environment: _,
        moments_max_distance: _,
        positions,
        layout: _,
        radiance,
        normals,
        distances,
        distance_ranges,
        pyramid_levels: _,
        pyramid,
        moments,
        irradiance,
        sh,
        surfels,
        stats,
        sampling,
    } = part;
    whole.positions.extend(positions);
    whole.radiance.extend(radiance);
    whole.normals.extend(normals);
    whole.distances.extend(distances);
    whole.distance_ranges.extend(distance_ranges);
    whole.pyramid.extend(pyramid);
    whole.moments.extend(moments);
    whole.irradiance.extend(irradiance);
    whole.sh.extend(sh);
    whole.surfels.extend(surfels);
    whole.stats.extend(stats);
    whole.sampling.extend(sampling);
}
