//! Several frames rendered the way an engine would use the tracer: everything stays on the GPU.
//!
//! Each frame is one command encoder with three compute passes:
//!
//! 1. **rays** (this example's WGSL): a camera ray per pixel hits the room analytically (a
//!    stand-in for an engine's G-buffer), and the pass writes the mirror-reflection ray of
//!    each hit into a `TraceRay` buffer, and the wall's albedo into a G-buffer;
//! 2. **trace**: the tracer, recorded into the same encoder from a [`TraceBinding`] made once
//!    ([`GpuTracer::bind_trace`]), writes one `RayRecord` per ray into a results buffer;
//! 3. **composite** (this example's WGSL): reads the records and the G-buffer and writes
//!    `0.5 · albedo + 0.5 · reflected radiance` into the frame's slice of an image buffer.
//!
//! The camera moves between frames; frames are submitted one after another with no read-back
//! in between (each frame's rays and records are also copied into history buffers on the GPU,
//! so the test can check them). Only at the end are the images read back.
//!
//! The probes are eight analytic probes in a closed 4 m room whose walls each have their own
//! colour (the crate documentation's example room).
//!
//! `cargo run -p probe-trace-gpu --example engine_frames [-- OUT.ppm]` prints per-frame
//! figures and, given a path, writes the frames side by side as a binary PPM. The test
//! `tests/engine_frames.rs` runs the same code on lavapipe and checks it against the CPU twin.

use std::borrow::Cow;
use std::error::Error;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use probe_index::ProbeGrid;
use probe_octa::OctaLayout;
use probe_trace_gpu::{
    FieldOptions, GpuContext, GpuField, GpuTracer, LightField, ProbeSelection, RayRecord,
    TraceBinding, TraceBuffers, TraceOptions, TraceRay, Tracer,
};
use wgpu::util::DeviceExt;

/// Half the room's side: the room is `[-ROOM, ROOM]³`.
pub const ROOM: f32 = 2.0;

/// The first surface seen from `p` along unit `d` inside the room: distance, inward normal and
/// the wall's colour.
pub fn wall(p: Vec3, d: Vec3) -> (f32, Vec3, Vec3) {
    let t = (Vec3::splat(ROOM) * d.signum() - p) / d;
    let axis = if t.x <= t.y && t.x <= t.z {
        0
    } else if t.y <= t.z {
        1
    } else {
        2
    };
    let mut normal = Vec3::ZERO;
    normal[axis] = -d[axis].signum();
    (t[axis], normal, normal.abs() * 0.5 + Vec3::splat(0.25))
}

/// Eight probes of the room, their maps computed analytically.
pub struct RoomProbes {
    /// The 2×2×2 grid they stand on.
    pub grid: ProbeGrid,
    /// Probe centres.
    pub positions: Vec<Vec3>,
    /// Map resolution.
    pub resolution: u32,
    /// Padded maps, probes one after another.
    pub distance: Vec<f32>,
    /// Padded normal maps.
    pub normals: Vec<Vec3>,
    /// Padded radiance maps.
    pub radiance: Vec<Vec3>,
}

impl RoomProbes {
    /// Probes at `(±0.5, ±0.5, ±0.5)` with `resolution²` maps.
    pub fn new(resolution: u32) -> Result<Self, Box<dyn Error>> {
        let grid = ProbeGrid::new(Vec3::splat(-0.5), Vec3::ONE, [2, 2, 2])?;
        let positions = grid.positions();
        let layout = OctaLayout::new(resolution)?;
        let len = layout.padded_len();
        let (mut distance, mut normals, mut radiance) = (Vec::new(), Vec::new(), Vec::new());
        for &p in &positions {
            let (mut d, mut n, mut r) =
                (vec![0.0; len], vec![Vec3::ZERO; len], vec![Vec3::ZERO; len]);
            for iy in 0..resolution {
                for ix in 0..resolution {
                    let (t, normal, colour) = wall(p, layout.texel_direction(ix, iy));
                    let i = layout.interior_index(ix, iy);
                    (d[i], n[i], r[i]) = (t, normal, colour);
                }
            }
            distance.extend(d);
            normals.extend(n);
            radiance.extend(r);
        }
        Ok(Self {
            grid,
            positions,
            resolution,
            distance,
            normals,
            radiance,
        })
    }

    /// The maps as the tracer takes them.
    pub fn field(&self) -> LightField<'_> {
        LightField {
            resolution: self.resolution,
            positions: &self.positions,
            radial_distance: &self.distance,
            normals: &self.normals,
            radiance: &self.radiance,
            distance_range: None,
            sky_distance: 1000.0,
            geometry_bounds: None,
        }
    }

    /// The selection the tracer uses: the grid's cage.
    pub fn selection(&self) -> ProbeSelection<'_> {
        ProbeSelection::Grid(self.grid)
    }
}

/// Image size and frame count.
#[derive(Clone, Copy, Debug)]
pub struct FrameSettings {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Frames rendered.
    pub frames: u32,
}

/// What the frames produced, read back after the last one.
pub struct Frames {
    /// The settings they were rendered with.
    pub settings: FrameSettings,
    /// Composited pixels (RGB, alpha 1), frame after frame, rows top to bottom.
    pub images: Vec<[f32; 4]>,
    /// The rays the GPU pass generated, frame after frame.
    pub rays: Vec<TraceRay>,
    /// The tracer's records of those rays, frame after frame.
    pub records: Vec<RayRecord>,
}

impl Frames {
    /// Pixels per frame.
    pub fn pixels(&self) -> usize {
        (self.settings.width * self.settings.height) as usize
    }

    /// One frame's slice of `items` (`images`, `rays` or `records`).
    pub fn frame<'a, T>(&self, items: &'a [T], frame: u32) -> &'a [T] {
        let n = self.pixels();
        &items[frame as usize * n..(frame as usize + 1) * n]
    }
}

/// The camera of frame `frame`: it orbits the room's centre, rising slowly.
pub fn camera(frame: u32) -> (Vec3, Vec3) {
    let angle = 0.4 + 0.35 * frame as f32;
    let eye = Vec3::new(
        1.3 * angle.cos(),
        -0.4 + 0.15 * frame as f32,
        1.3 * angle.sin(),
    );
    (eye, Vec3::new(0.0, -0.3, 0.0))
}

/// The per-frame uniform block of the example's two passes (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FrameUniform {
    eye: [f32; 3],
    width: u32,
    forward: [f32; 3],
    height: u32,
    right: [f32; 3],
    frame: u32,
    up: [f32; 3],
    pad: u32,
}

/// The example's ray-generation pass.
const RAYS_WGSL: &str = r"
struct Frame {
    eye: vec3<f32>, width: u32,
    forward: vec3<f32>, height: u32,
    right: vec3<f32>, frame: u32,
    up: vec3<f32>, pad: u32,
}
// probe_trace_gpu::TraceRay.
struct TraceRay { origin: vec3<f32>, t_min: f32, direction: vec3<f32>, t_max: f32 }

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read_write> rays: array<TraceRay>;
@group(0) @binding(2) var<storage, read_write> albedo: array<vec4<f32>>;

const ROOM: f32 = 2.0;

@compute @workgroup_size(64)
fn make_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= frame.width * frame.height) {
        return;
    }
    let u = (f32(i % frame.width) + 0.5) / f32(frame.width) * 2.0 - 1.0;
    let v = 1.0 - (f32(i / frame.width) + 0.5) / f32(frame.height) * 2.0;
    let d = normalize(frame.forward + u * frame.right + v * frame.up);
    // Where the camera ray leaves the room [-ROOM, ROOM]^3 (the G-buffer's hit).
    let safe = select(vec3<f32>(1e-12), d, abs(d) > vec3<f32>(1e-12));
    let t3 = (sign(safe) * ROOM - frame.eye) / safe;
    let t = min(t3.x, min(t3.y, t3.z));
    var n = vec3<f32>(0.0);
    if (t3.x <= t3.y && t3.x <= t3.z) {
        n.x = -sign(d.x);
    } else if (t3.y <= t3.z) {
        n.y = -sign(d.y);
    } else {
        n.z = -sign(d.z);
    }
    let p = frame.eye + d * t;
    let r = normalize(d - 2.0 * dot(d, n) * n);
    rays[i] = TraceRay(p + n * 0.005, 0.0, r, 3.0e38);
    albedo[i] = vec4<f32>(abs(n) * 0.5 + vec3<f32>(0.25), 1.0);
}
";

/// The example's composite pass.
const COMPOSITE_WGSL: &str = r"
struct Frame {
    eye: vec3<f32>, width: u32,
    forward: vec3<f32>, height: u32,
    right: vec3<f32>, frame: u32,
    up: vec3<f32>, pad: u32,
}
// probe_trace_gpu::RayRecord.
struct RayRecord {
    position: vec3<f32>, t: f32,
    normal: vec3<f32>, status: u32,
    radiance: vec3<f32>, probe: u32,
    probes_tried: u32, texel_fetches: u32, pad0: u32, pad1: u32,
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> records: array<RayRecord>;
@group(0) @binding(2) var<storage, read> albedo: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> image: array<vec4<f32>>;

@compute @workgroup_size(64)
fn composite(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = frame.width * frame.height;
    let i = id.x;
    if (i >= n) {
        return;
    }
    let glossy = records[i].radiance;
    image[frame.frame * n + i] = vec4<f32>(0.5 * albedo[i].rgb + 0.5 * glossy, 1.0);
}
";

fn storage(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | extra,
        mapped_at_creation: false,
    })
}

fn pipeline(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    entry: &str,
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(source)),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    })
}

fn bind(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<_> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// Copies `buffer` to the CPU (the one blocking step, after all frames).
fn read_back<T: Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
) -> Result<Vec<T>, Box<dyn Error>> {
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read back"),
        size: buffer.size(),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
    queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    receiver.recv()??;
    let data = bytemuck::pod_collect_to_vec::<u8, T>(&slice.get_mapped_range()?);
    staging.unmap();
    Ok(data)
}

/// Renders `settings.frames` frames through `field` on `tracer`'s device: per frame, one
/// encoder with the ray pass, the tracer and the composite pass, submitted without waiting.
///
/// # Errors
/// Binding the tracer ([`probe_trace_gpu::TraceError`]) or reading back at the end.
pub fn render(
    tracer: &GpuTracer,
    queue: &wgpu::Queue,
    field: &GpuField,
    settings: FrameSettings,
) -> Result<Frames, Box<dyn Error>> {
    let device = tracer.device();
    let n = u64::from(settings.width * settings.height);
    let frames = u64::from(settings.frames);
    let ray_size = size_of::<TraceRay>() as u64;
    let record_size = size_of::<RayRecord>() as u64;
    let copy = wgpu::BufferUsages::COPY_SRC;
    // The rays the ray pass writes and the tracer reads; the records the tracer writes and the
    // composite pass reads. STORAGE is all the tracer needs; COPY_SRC is for the history.
    let rays = storage(device, "rays", n * ray_size, copy);
    let results = storage(device, "results", n * record_size, copy);
    let albedo = storage(device, "albedo", n * 16, wgpu::BufferUsages::empty());
    let image = storage(device, "image", frames * n * 16, copy);
    let dst = wgpu::BufferUsages::COPY_DST | copy;
    let ray_history = storage(device, "ray history", frames * n * ray_size, dst);
    let record_history = storage(device, "record history", frames * n * record_size, dst);

    let rays_pipeline = pipeline(device, "rays", RAYS_WGSL, "make_rays");
    let composite_pipeline = pipeline(device, "composite", COMPOSITE_WGSL, "composite");
    // Bound once: the same buffers, count and options every frame.
    let trace: TraceBinding = tracer.bind_trace(
        field,
        &TraceBuffers {
            rays: &rays,
            results: &results,
            count: n as u32,
        },
        &TraceOptions::default(),
    )?;
    let groups = (n as u32).div_ceil(64);
    let aspect = settings.width as f32 / settings.height as f32;
    let tan_half_fov = 0.6f32;
    for frame in 0..settings.frames {
        let (eye, target) = camera(frame);
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize() * tan_half_fov * aspect;
        let up = right.cross(forward).normalize() * tan_half_fov;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("frame"),
            contents: bytemuck::bytes_of(&FrameUniform {
                eye: eye.to_array(),
                width: settings.width,
                forward: forward.to_array(),
                height: settings.height,
                right: right.to_array(),
                frame,
                up: up.to_array(),
                pad: 0,
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let rays_group = bind(device, &rays_pipeline, &[&uniform, &rays, &albedo]);
        let composite_group = bind(
            device,
            &composite_pipeline,
            &[&uniform, &results, &albedo, &image],
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            pass.set_pipeline(&rays_pipeline);
            pass.set_bind_group(0, &rays_group, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        trace.record(&mut encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            pass.set_pipeline(&composite_pipeline);
            pass.set_bind_group(0, &composite_group, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        let f = u64::from(frame);
        encoder.copy_buffer_to_buffer(&rays, 0, &ray_history, f * n * ray_size, n * ray_size);
        encoder.copy_buffer_to_buffer(
            &results,
            0,
            &record_history,
            f * n * record_size,
            n * record_size,
        );
        queue.submit([encoder.finish()]);
    }
    Ok(Frames {
        settings,
        images: read_back(device, queue, &image)?,
        rays: read_back(device, queue, &ray_history)?,
        records: read_back(device, queue, &record_history)?,
    })
}

/// Writes the frames side by side as a binary PPM (`x / (1 + x)` tone mapping, then sRGB-ish
/// gamma), through a temporary file renamed over `path`.
fn write_ppm(frames: &Frames, path: &std::path::Path) -> std::io::Result<()> {
    let FrameSettings {
        width,
        height,
        frames: count,
    } = frames.settings;
    let mut bytes = format!("P6\n{} {height}\n255\n", width * count).into_bytes();
    for y in 0..height {
        for f in 0..count {
            let image = frames.frame(&frames.images, f);
            for x in 0..width {
                let p = image[(y * width + x) as usize];
                for c in &p[..3] {
                    let mapped = (c / (1.0 + c)).clamp(0.0, 1.0).powf(1.0 / 2.2);
                    bytes.push((mapped * 255.0).round() as u8);
                }
            }
        }
    }
    let temporary = path.with_extension("ppm.tmp");
    std::fs::write(&temporary, bytes)?;
    std::fs::rename(&temporary, path)
}

fn main() -> Result<(), Box<dyn Error>> {
    let context = GpuContext::new()?;
    // An engine owns its device: the tracer is made on it.
    let tracer = GpuTracer::from_device(context.device().clone(), context.queue().clone())?;
    let probes = RoomProbes::new(32)?;
    let field = tracer.upload(
        &probes.field(),
        &probes.selection(),
        &FieldOptions::default(),
    )?;
    let settings = FrameSettings {
        width: 96,
        height: 64,
        frames: 4,
    };
    let frames = render(&tracer, context.queue(), &field, settings)?;
    for frame in 0..settings.frames {
        let records = frames.frame(&frames.records, frame);
        let hits = records.iter().filter(|r| r.status == 0).count();
        let fetches: u64 = records.iter().map(|r| u64::from(r.texel_fetches)).sum();
        println!(
            "frame {frame}: {} rays, {hits} hits, {:.1} texel fetches per ray",
            records.len(),
            fetches as f64 / records.len() as f64
        );
    }
    if let Some(path) = std::env::args_os().nth(1) {
        write_ppm(&frames, std::path::Path::new(&path))?;
        println!("wrote {}", path.to_string_lossy());
    }
    Ok(())
}
