//! The `engine_frames` example as a test: rays made by a compute pass of the example, traced by
//! the tracer recorded into the same encoder, results consumed by another pass, several frames
//! with no read-back in between. On lavapipe here; any adapter elsewhere.
//!
//! Without an adapter the tests print a message and pass; with `PROBE_REQUIRE_GPU=1` they fail
//! instead (CI sets it).

#[path = "../examples/engine_frames.rs"]
#[allow(dead_code)]
mod engine_frames;

use engine_frames::{FrameSettings, RoomProbes, render};
use glam::Vec3;
use probe_trace_gpu::{
    AnyTracer, CpuTracer, FieldOptions, GpuContext, GpuTracer, RayResult, RayStatus, TraceBuffers,
    TraceError, TraceOptions, TraceRay, Tracer,
};

/// A context, or `None` (with a message) when no adapter exists; under `PROBE_REQUIRE_GPU=1` a
/// missing adapter fails the test instead.
fn context() -> Option<GpuContext> {
    match GpuContext::new() {
        Ok(context) => Some(context),
        Err(error) => {
            if std::env::var("PROBE_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("PROBE_REQUIRE_GPU=1 but no GPU is usable: {error}");
            }
            eprintln!("skipping GPU test: {error} (set PROBE_REQUIRE_GPU=1 to fail instead)");
            None
        }
    }
}

const SETTINGS: FrameSettings = FrameSettings {
    width: 48,
    height: 32,
    frames: 3,
};

#[test]
fn frames_rendered_on_the_gpu_match_the_cpu_twin() {
    let Some(context) = context() else { return };
    let tracer = GpuTracer::from_device(context.device().clone(), context.queue().clone()).unwrap();
    let probes = RoomProbes::new(32).unwrap();
    let field = tracer
        .upload(
            &probes.field(),
            &probes.selection(),
            &FieldOptions::default(),
        )
        .unwrap();
    let frames = render(&tracer, context.queue(), &field, SETTINGS).unwrap();
    let n = frames.pixels();
    assert_eq!(frames.images.len(), n * SETTINGS.frames as usize);

    let mut cpu = CpuTracer::new();
    let cpu_field = cpu
        .upload(
            &probes.field(),
            &probes.selection(),
            &FieldOptions::default(),
        )
        .unwrap();
    for frame in 0..SETTINGS.frames {
        let rays = frames.frame(&frames.rays, frame);
        // The GPU pass made sane rays: unit directions from just inside the walls.
        for ray in rays {
            let (o, d) = (Vec3::from(ray.origin), Vec3::from(ray.direction));
            assert!((d.length() - 1.0).abs() < 1e-5, "{ray:?}");
            assert!(
                o.abs().max_element() < 2.0 && o.abs().max_element() > 1.99,
                "{ray:?}"
            );
        }
        // The tracer recorded into the frame's encoder agrees with the CPU twin on the same
        // rays, ray by ray.
        let gpu: Vec<RayResult> = frames
            .frame(&frames.records, frame)
            .iter()
            .map(|&r| RayResult::from(r))
            .collect();
        let on_cpu = cpu
            .trace(&cpu_field, rays, &TraceOptions::default())
            .unwrap()
            .results;
        let same_status = gpu
            .iter()
            .zip(&on_cpu)
            .filter(|(g, c)| g.status == c.status)
            .count();
        let both_hit: Vec<f32> = gpu
            .iter()
            .zip(&on_cpu)
            .filter(|(g, c)| g.status == RayStatus::Hit && c.status == RayStatus::Hit)
            .map(|(g, c)| (g.position - c.position).length())
            .collect();
        let close = both_hit.iter().filter(|&&e| e <= 1e-4).count();
        eprintln!(
            "frame {frame}: status {same_status}/{n}, hit positions within 1e-4 m {close}/{}",
            both_hit.len()
        );
        assert!(same_status as f64 >= 0.999 * n as f64, "frame {frame}");
        assert!(
            close as f64 >= 0.999 * both_hit.len() as f64,
            "frame {frame}"
        );
        // In a closed room the reflection rays hit walls.
        assert!(both_hit.len() as f64 >= 0.8 * n as f64, "frame {frame}");
        // The composite pass consumed the records: pixel = half the wall's albedo (0.375 on
        // the wall's axis, 0.125 on the others) plus half the traced radiance.
        for (pixel, result) in frames.frame(&frames.images, frame).iter().zip(&gpu) {
            let albedo = 2.0 * (Vec3::from_slice(&pixel[..3]) - 0.5 * result.radiance);
            let mut sorted = albedo.to_array();
            sorted.sort_by(f32::total_cmp);
            assert!(
                (sorted[0] - 0.25).abs() < 1e-5
                    && (sorted[1] - 0.25).abs() < 1e-5
                    && (sorted[2] - 0.75).abs() < 1e-5,
                "{pixel:?} {result:?}"
            );
        }
    }
    // The camera moves, so frames differ.
    for frame in 1..SETTINGS.frames {
        let (a, b) = (
            frames.frame(&frames.images, frame - 1),
            frames.frame(&frames.images, frame),
        );
        let differing = a.iter().zip(b).filter(|(p, q)| p != q).count();
        assert!(
            differing as f64 > 0.2 * n as f64,
            "frames {} and {frame} differ in {differing} of {n} pixels",
            frame - 1
        );
    }
}

/// The recording path refuses buffers it cannot bind, naming the buffer, and the convenience
/// path is the recording path: its results equal a recorded trace of the same rays.
#[test]
fn recording_checks_buffers_and_matches_the_convenience_call() {
    let Some(context) = context() else { return };
    let device = context.device();
    let mut tracer = GpuTracer::new(&context).unwrap();
    let probes = RoomProbes::new(16).unwrap();
    let field = tracer
        .upload(
            &probes.field(),
            &probes.selection(),
            &FieldOptions::default(),
        )
        .unwrap();
    // Not unit length: the convenience call normalises them on the CPU; the buffer gets them
    // normalised the same way (the recording path takes unit directions).
    let rays: Vec<TraceRay> = (0..100)
        .map(|i| {
            let a = i as f32 * 0.37;
            TraceRay::new(
                Vec3::new(0.1 * a.sin(), 0.2, 0.1 * a.cos()),
                Vec3::new(a.cos(), (a * 0.7).sin(), a.sin()) * 3.0,
            )
        })
        .collect();
    let unit: Vec<TraceRay> = rays
        .iter()
        .map(|r| TraceRay {
            direction: Vec3::from(r.direction).normalize_or_zero().to_array(),
            ..*r
        })
        .collect();
    let buffer = |size: u64, usage: wgpu::BufferUsages| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    use wgpu::BufferUsages as U;
    let ray_buffer = buffer(100 * 32, U::STORAGE | U::COPY_DST);
    context
        .queue()
        .write_buffer(&ray_buffer, 0, bytemuck::cast_slice(&unit));
    let results = buffer(100 * 64, U::STORAGE | U::COPY_SRC);
    let options = TraceOptions::default();
    let bind = |rays: &wgpu::Buffer, results: &wgpu::Buffer, count: u32| {
        tracer.bind_trace(
            &field,
            &TraceBuffers {
                rays,
                results,
                count,
            },
            &options,
        )
    };
    let small = buffer(99 * 64, U::STORAGE);
    let no_storage = buffer(100 * 64, U::COPY_SRC);
    match bind(&ray_buffer, &small, 100) {
        Err(TraceError::BadBuffer {
            buffer: "results", ..
        }) => {}
        other => panic!("a short results buffer: {other:?}"),
    }
    match bind(&no_storage, &results, 100) {
        Err(e @ TraceError::BadBuffer { buffer: "rays", .. }) => {
            assert!(e.to_string().contains("STORAGE"), "{e}");
        }
        other => panic!("rays without STORAGE: {other:?}"),
    }
    match bind(&results, &results, 100) {
        Err(TraceError::BadBuffer { .. }) => {}
        other => panic!("one buffer for both: {other:?}"),
    }
    let bad_options = TraceOptions {
        max_probes: 0,
        ..options
    };
    assert!(matches!(
        tracer.record_trace(
            &mut device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default()),
            &field,
            &TraceBuffers {
                rays: &ray_buffer,
                results: &results,
                count: 100
            },
            &bad_options
        ),
        Err(TraceError::BadOption {
            option: "max_probes",
            ..
        })
    ));
    // A field of another device is refused.
    let other = GpuContext::new().unwrap();
    let other_tracer = GpuTracer::new(&other).unwrap();
    let foreign = other_tracer
        .upload(
            &probes.field(),
            &probes.selection(),
            &FieldOptions::default(),
        )
        .unwrap();
    assert!(matches!(
        tracer.trace(&foreign, &rays, &options),
        Err(TraceError::ForeignField { .. })
    ));

    // Recorded, then read back by hand.
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    tracer
        .record_trace(
            &mut encoder,
            &field,
            &TraceBuffers {
                rays: &ray_buffer,
                results: &results,
                count: 100,
            },
            &options,
        )
        .unwrap();
    let staging = buffer(100 * 64, U::MAP_READ | U::COPY_DST);
    encoder.copy_buffer_to_buffer(&results, 0, &staging, 0, 100 * 64);
    context.queue().submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let recorded: Vec<probe_trace_gpu::RayRecord> =
        bytemuck::pod_collect_to_vec::<u8, probe_trace_gpu::RayRecord>(
            &staging.slice(..).get_mapped_range().unwrap(),
        );
    let convenient = tracer.trace(&field, &rays, &options).unwrap().results;
    let recorded: Vec<RayResult> = recorded.into_iter().map(RayResult::from).collect();
    assert_eq!(recorded, convenient);
    assert!(
        recorded
            .iter()
            .filter(|r| r.status == RayStatus::Hit)
            .count()
            > 80
    );

    // One type over both: the boxed GPU tracer gives the same answers, and a field uploaded
    // by the boxed GPU tracer is refused by the boxed CPU twin.
    let mut any_gpu = AnyTracer::new(tracer);
    let mut any_cpu = AnyTracer::new(CpuTracer::new());
    assert!(
        any_gpu.describe().starts_with("gpu: "),
        "{}",
        any_gpu.describe()
    );
    assert_eq!(any_cpu.describe(), "cpu twin");
    let gpu_field = any_gpu
        .upload(
            &probes.field(),
            &probes.selection(),
            &FieldOptions::default(),
        )
        .unwrap();
    assert_eq!(
        any_gpu.trace(&gpu_field, &rays, &options).unwrap().results,
        convenient
    );
    match any_cpu.trace(&gpu_field, &rays, &options) {
        Err(e @ TraceError::ForeignField { .. }) => {
            assert!(e.to_string().contains("gpu: "), "{e}");
        }
        other => panic!("a GPU field traced on the CPU: {other:?}"),
    }
}
