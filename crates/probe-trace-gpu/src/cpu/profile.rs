//! Where texel fetches go: a recorder the CPU twin's march can carry (the plain trace carries
//! `()`, which records nothing and compiles away), and the histograms of [`FetchProfile`].

use std::fmt;

use super::march::{HIT, MISS, UNKNOWN};

/// Fetches within this many full-resolution texels (along the probe's octahedral path) of where
/// a single-probe trace starts, or of where it ends with HIT or UNKNOWN, count as "start" or
/// "end" in [`FetchProfile`]; the rest as "flight".
pub const PHASE_WINDOW_TEXELS: f32 = 8.0;

/// What a texel fetch decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FetchKind {
    /// A pyramid texel the ray passed wholly in front of (a skip).
    PyramidPass,
    /// A pyramid texel the ray may meet a surface in: the march goes down a level (hi-Z) or
    /// into the fine march (two-level).
    PyramidDescend,
    /// A pyramid texel entered behind its farthest bound: UNKNOWN at once.
    PyramidUnknown,
    /// A fine test passed by the texel's depth bound (the ray nearer than `near`) or sky.
    FineNear,
    /// A fine test passed by the texel's plane (the ray in front of it).
    FinePlane,
    /// A fine test passed as "leaving the surface" (within the thickness, moving out).
    FineLeaving,
    /// A fine test that found the hit.
    FineHit,
    /// A fine test that ended the probe's trace with UNKNOWN (hidden, edge or back face).
    FineUnknown,
}

impl FetchKind {
    /// Every kind, in the order of [`FetchProfile::by_kind`].
    pub const ALL: [FetchKind; 8] = [
        FetchKind::PyramidPass,
        FetchKind::PyramidDescend,
        FetchKind::PyramidUnknown,
        FetchKind::FineNear,
        FetchKind::FinePlane,
        FetchKind::FineLeaving,
        FetchKind::FineHit,
        FetchKind::FineUnknown,
    ];

    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            FetchKind::PyramidPass => "pyramid pass",
            FetchKind::PyramidDescend => "pyramid descend",
            FetchKind::PyramidUnknown => "pyramid unknown",
            FetchKind::FineNear => "fine near/sky",
            FetchKind::FinePlane => "fine plane",
            FetchKind::FineLeaving => "fine leaving",
            FetchKind::FineHit => "fine hit",
            FetchKind::FineUnknown => "fine unknown",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Where along a single-probe trace a fetch was made (see [`PHASE_WINDOW_TEXELS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FetchPhase {
    /// Near where the probe's trace started (the ray origin, or the hand-off point).
    Start,
    /// Far from both ends.
    Flight,
    /// Near where the probe's trace ended with HIT or UNKNOWN.
    End,
}

impl FetchPhase {
    /// Every phase, in the order of [`FetchProfile::by_phase`].
    pub const ALL: [FetchPhase; 3] = [FetchPhase::Start, FetchPhase::Flight, FetchPhase::End];

    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            FetchPhase::Start => "start",
            FetchPhase::Flight => "flight",
            FetchPhase::End => "end",
        }
    }
}

/// One recorded fetch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FetchEvent {
    kind: FetchKind,
    level: u32,
    position: f32,
}

/// Receives the fetches of a march.
pub(crate) trait FetchLog {
    /// Whether anything is recorded (lets the march skip position bookkeeping).
    const ENABLED: bool;
    /// One fetch of `kind` at pyramid `level` (0: full resolution), `position` texels along the
    /// probe's path.
    fn fetch(&mut self, kind: FetchKind, level: u32, position: f32);
}

impl FetchLog for () {
    const ENABLED: bool = false;
    #[inline(always)]
    fn fetch(&mut self, _: FetchKind, _: u32, _: f32) {}
}

impl FetchLog for &mut Vec<FetchEvent> {
    const ENABLED: bool = true;
    fn fetch(&mut self, kind: FetchKind, level: u32, position: f32) {
        self.push(FetchEvent {
            kind,
            level,
            position,
        });
    }
}

/// Watches a multi-probe trace (`()` watches nothing).
pub(crate) trait RayObserver {
    /// The event list of the probe trace about to run, or `None` to record nothing.
    fn fetch_log(&mut self) -> Option<&mut Vec<FetchEvent>>;
    /// A probe's trace ended with `code` (HIT, MISS or UNKNOWN), `progressed` past where it
    /// began, at `end_position` texels along its path; `order` counts probes tried before it.
    fn probe_done(&mut self, code: u32, progressed: bool, end_position: f32, order: u32);
    /// The ray ended with `status` after `fetches` fetches (radiance included).
    fn ray_done(&mut self, status: u32, fetches: u32);
}

impl RayObserver for () {
    #[inline(always)]
    fn fetch_log(&mut self) -> Option<&mut Vec<FetchEvent>> {
        None
    }
    #[inline(always)]
    fn probe_done(&mut self, _: u32, _: bool, _: f32, _: u32) {}
    #[inline(always)]
    fn ray_done(&mut self, _: u32, _: u32) {}
}

/// Most pyramid levels profiled (level 0 is the full-resolution fine test).
pub const PROFILE_LEVELS: usize = 16;

/// Histograms of the texel fetches of a ray set ([`crate::CpuTracer::profile_fetches`]): by
/// pyramid level, by what each fetch decided ([`FetchKind`]), by where along a probe's trace
/// it was made ([`FetchPhase`]), by the probe's place in the ray's hand-off order, and by how
/// the probe's trace and the ray ended. Every count is a number of fetches unless named
/// otherwise; the radiance fetch each answered or fallback ray makes is counted apart.
#[derive(Clone, Debug, Default)]
pub struct FetchProfile {
    /// Rays traced.
    pub rays: u64,
    /// All fetches, radiance included (equals the sum of the rays' `texel_fetches`).
    pub fetches: u64,
    /// Radiance fetches (one per ray that had a probe to read).
    pub radiance: u64,
    /// Geometry and pyramid fetches by level (0: fine tests).
    pub by_level: [u64; PROFILE_LEVELS],
    /// By kind, in [`FetchKind::ALL`] order.
    pub by_kind: [u64; 8],
    /// By phase ([`FetchPhase::ALL`] order) and kind.
    pub by_phase: [[u64; 8]; 3],
    /// By phase and level.
    pub by_phase_level: [[u64; PROFILE_LEVELS]; 3],
    /// Fetches of the first probe tried for a ray, and of every later probe (hand-offs).
    pub by_probe_order: [u64; 2],
    /// Fetches of single-probe traces by how they ended: HIT, MISS, UNKNOWN after progress
    /// (hand-off further along the ray), UNKNOWN without progress (the next candidate tries
    /// from the same point).
    pub by_probe_outcome: [u64; 4],
    /// Single-probe traces by how they ended (same order).
    pub probe_traces: [u64; 4],
    /// Fetches of rays by their final status: Hit, Miss, Unknown (radiance included).
    pub by_ray_status: [u64; 3],
    /// Rays by final status.
    pub rays_by_status: [u64; 3],
    /// Fine tests (level 0) per probe trace ending in HIT whose hit was found within that many
    /// fine tests of the trace's start: a histogram of how far (in fine tests, capped at 31)
    /// hits lie, for the "short ray" share.
    pub fine_tests_before_hit: [u64; 32],
    /// Single-probe traces that moved along their path (HIT, MISS, UNKNOWN after progress) by
    /// the length of that path in full-resolution texels, in power-of-two buckets: bucket `b`
    /// holds lengths in `[2^b − 1, 2^(b+1) − 1)`; `[traces, fetches]` (seed 003 §9 predicts
    /// fetches growing with the logarithm of the length for a hierarchical trace).
    pub by_path_length: [[u64; 2]; 16],
    current: Vec<FetchEvent>,
    current_start: usize,
    ray_events: u64,
}

impl FetchProfile {
    /// Adds `other`'s counts to these.
    pub fn merge(&mut self, other: &FetchProfile) {
        self.rays += other.rays;
        self.fetches += other.fetches;
        self.radiance += other.radiance;
        let add = |a: &mut [u64], b: &[u64]| a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        add(&mut self.by_level, &other.by_level);
        add(&mut self.by_kind, &other.by_kind);
        for p in 0..3 {
            add(&mut self.by_phase[p], &other.by_phase[p]);
            add(&mut self.by_phase_level[p], &other.by_phase_level[p]);
        }
        add(&mut self.by_probe_order, &other.by_probe_order);
        add(&mut self.by_probe_outcome, &other.by_probe_outcome);
        add(&mut self.probe_traces, &other.probe_traces);
        add(&mut self.by_ray_status, &other.by_ray_status);
        add(&mut self.rays_by_status, &other.rays_by_status);
        add(
            &mut self.fine_tests_before_hit,
            &other.fine_tests_before_hit,
        );
        for b in 0..16 {
            add(&mut self.by_path_length[b], &other.by_path_length[b]);
        }
    }

    /// Mean fetches per ray.
    pub fn per_ray(&self, count: u64) -> f64 {
        count as f64 / self.rays.max(1) as f64
    }
}

impl RayObserver for FetchProfile {
    fn fetch_log(&mut self) -> Option<&mut Vec<FetchEvent>> {
        self.current_start = self.current.len();
        Some(&mut self.current)
    }

    fn probe_done(&mut self, code: u32, progressed: bool, end_position: f32, order: u32) {
        let events = &self.current[self.current_start..];
        let ends_inside = code == HIT || code == UNKNOWN;
        let outcome = match code {
            HIT => 0,
            MISS => 1,
            _ if progressed => 2,
            _ => 3,
        };
        let mut fine = 0u64;
        for e in events {
            let phase = if e.position < PHASE_WINDOW_TEXELS {
                0
            } else if ends_inside && end_position - e.position < PHASE_WINDOW_TEXELS {
                2
            } else {
                1
            };
            let level = (e.level as usize).min(PROFILE_LEVELS - 1);
            let kind = e.kind.index();
            self.by_level[level] += 1;
            self.by_kind[kind] += 1;
            self.by_phase[phase][kind] += 1;
            self.by_phase_level[phase][level] += 1;
            fine += u64::from(e.level == 0);
        }
        let n = events.len() as u64;
        self.ray_events += n;
        self.by_probe_order[usize::from(order > 0)] += n;
        self.by_probe_outcome[outcome] += n;
        self.probe_traces[outcome] += 1;
        if code == HIT {
            self.fine_tests_before_hit[(fine as usize).min(31)] += 1;
        }
        if code == HIT || code == MISS || progressed {
            let bucket = ((end_position.max(0.0) + 1.0).log2().floor() as usize).min(15);
            self.by_path_length[bucket][0] += 1;
            self.by_path_length[bucket][1] += n;
        }
        self.current.truncate(self.current_start);
    }

    fn ray_done(&mut self, status: u32, fetches: u32) {
        self.rays += 1;
        self.fetches += u64::from(fetches);
        self.radiance += u64::from(fetches).saturating_sub(self.ray_events);
        self.ray_events = 0;
        let status = (status as usize).min(2);
        self.by_ray_status[status] += u64::from(fetches);
        self.rays_by_status[status] += 1;
        self.current.clear();
    }
}

impl fmt::Display for FetchProfile {
    /// Markdown tables: per ray, by level and phase, by kind and phase, and the hand-off and
    /// outcome splits.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = |x: u64| self.per_ray(x);
        writeln!(
            f,
            "rays {}, fetches/ray {:.2} (radiance {:.2})",
            self.rays,
            r(self.fetches),
            r(self.radiance)
        )?;
        let top = (0..PROFILE_LEVELS)
            .rev()
            .find(|&l| self.by_level[l] > 0)
            .unwrap_or(0);
        write!(f, "| per ray | all |")?;
        for l in 0..=top {
            write!(f, " L{l} |")?;
        }
        writeln!(f)?;
        write!(f, "|---|---|")?;
        for _ in 0..=top {
            write!(f, "---|")?;
        }
        writeln!(f)?;
        for (p, phase) in FetchPhase::ALL.iter().enumerate() {
            let all: u64 = self.by_phase_level[p].iter().sum();
            write!(f, "| {} | {:.2} |", phase.name(), r(all))?;
            for l in 0..=top {
                write!(f, " {:.2} |", r(self.by_phase_level[p][l]))?;
            }
            writeln!(f)?;
        }
        let all: u64 = self.by_level.iter().sum();
        write!(f, "| all | {:.2} |", r(all))?;
        for l in 0..=top {
            write!(f, " {:.2} |", r(self.by_level[l]))?;
        }
        writeln!(f)?;
        writeln!(f)?;
        writeln!(f, "| per ray | start | flight | end | all |")?;
        writeln!(f, "|---|---|---|---|---|")?;
        for (k, kind) in FetchKind::ALL.iter().enumerate() {
            writeln!(
                f,
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} |",
                kind.name(),
                r(self.by_phase[0][k]),
                r(self.by_phase[1][k]),
                r(self.by_phase[2][k]),
                r(self.by_kind[k])
            )?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "first probe {:.2}/ray, later probes {:.2}/ray",
            r(self.by_probe_order[0]),
            r(self.by_probe_order[1])
        )?;
        let names = [
            "hit",
            "miss",
            "unknown, handed on",
            "unknown, next candidate",
        ];
        for (i, name) in names.iter().enumerate() {
            writeln!(
                f,
                "probe traces ending {name}: {:.3}/ray, {:.2} fetches/ray ({:.1} per trace)",
                r(self.probe_traces[i]),
                r(self.by_probe_outcome[i]),
                self.by_probe_outcome[i] as f64 / self.probe_traces[i].max(1) as f64
            )?;
        }
        write!(f, "fetches per moving probe trace by path length (texels):")?;
        for (b, [traces, fetches]) in self.by_path_length.iter().enumerate() {
            if *traces > 0 {
                write!(
                    f,
                    " [{}, {}): {:.1} ({:.3}/ray);",
                    (1u32 << b) - 1,
                    (1u32 << (b + 1)) - 1,
                    *fetches as f64 / *traces as f64,
                    r(*traces)
                )?;
            }
        }
        writeln!(f)?;
        for (i, name) in ["Hit", "Miss", "Unknown"].iter().enumerate() {
            writeln!(
                f,
                "rays ending {name}: {:.1} % of rays, {:.2} fetches/ray of all rays ({:.1} each)",
                100.0 * self.rays_by_status[i] as f64 / self.rays.max(1) as f64,
                r(self.by_ray_status[i]),
                self.by_ray_status[i] as f64 / self.rays_by_status[i].max(1) as f64
            )?;
        }
        Ok(())
    }
}
