//! shaders/common/metaballs.glsl on the device against its f32 twin (`metaballs_f32::cast_f32`)
//! and the f64 reference: a probe compute shader (below) casts rays given in a buffer through
//! `metaball_cast`, for random groups (several per dispatch, each with its own ball range and
//! index list). The GLSL and the twin share every operation, so away from the tangency band they
//! agree to rounding (the device may fuse multiply-adds); validation must stay silent.

mod common;

use glam::DVec3;
use gpu_allocator::MemoryLocation;
use hadou::effects::metaballs::{cast, Ball, Kernel, MetaballGroupParams};
use hadou::effects::metaballs_f32::{
    cast_f32, gpu_balls, gpu_group, tangency, GpuMetaBall, GpuMetaGroup, BAND_C, MB_HIT, MB_NOT_CONVERGED,
    MB_STREAMED,
};
use hadou::gpu::barriers::{cmd_barriers, memory_barrier};
use hadou::gpu::commands::FrameCommands;
use hadou::gpu::memory::Memory;
use hadou::gpu::pipeline::{create_compute_pipeline, write_set, Bound, BufferRange, DescriptorPool};
use hadou::gpu::{vk, ContextOptions, GpuContext};
use hadou::scene::transform::{Transform, TransformOp};
use hadou::testing::Rng;

const PROBE: &str = r#"#version 460
// metaballs probe: one ray per invocation through metaball_cast (tests/metaballs_gpu.rs).
layout(local_size_x = 64) in;
#include "common/metaballs.glsl"
struct ProbeRay {
    vec4 origin_tmin;   // xyz: world origin, w: t_min
    vec4 dir_tmax;      // xyz: unit world direction, w: t_max
    uvec4 target;       // x: group, y: list begin, z: list count, w: 1 to sphere-trace
};
layout(set = 0, binding = 0, std430) readonly buffer Groups { MetaGroup groups[]; };
layout(set = 0, binding = 1, std430) readonly buffer Balls { MetaBall balls[]; };
layout(set = 0, binding = 2, std430) readonly buffer Lists { uint ball_list[]; };
layout(set = 0, binding = 3, std430) readonly buffer Rays { ProbeRay rays[]; };
layout(set = 0, binding = 4, std430) writeonly buffer Results { vec4 results[]; };
#define MB_BALL(i) balls[i]
#define MB_INDEX(k) ball_list[k]
#include "common/metaballs.glsl"
layout(push_constant) uniform ProbeParams { uvec4 counts; } params;  // x: rays
void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= params.counts.x) return;
    ProbeRay ray = rays[r];
    MetaHit h = metaball_cast(ray.origin_tmin.xyz, ray.dir_tmax.xyz, groups[ray.target.x], ray.target.y,
                              ray.target.z, ray.origin_tmin.w, ray.dir_tmax.w, ray.target.w != 0u);
    results[2u * r] = vec4(h.normal, h.t);
    results[2u * r + 1u] = vec4(uintBitsToFloat(h.flags), uintBitsToFloat(h.iterations), 0.0, 0.0);
}
"#;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ProbeRay {
    origin_tmin: [f32; 4],
    dir_tmax: [f32; 4],
    target: [u32; 4],
}

fn compile() -> Vec<u32> {
    let compiler = shaderc::Compiler::new().expect("shaderc");
    let mut options = shaderc::CompileOptions::new().expect("shaderc options");
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
    options.set_target_spirv(shaderc::SpirvVersion::V1_6);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    let dir = common::root().join("shaders");
    options.set_include_callback(move |name, _, _, _| {
        let path = dir.join(name);
        std::fs::read_to_string(&path)
            .map(|content| shaderc::ResolvedInclude { resolved_name: path.display().to_string(), content })
            .map_err(|e| format!("{}: {e}", path.display()))
    });
    let spirv = compiler
        .compile_into_spirv(
            PROBE,
            shaderc::ShaderKind::Compute,
            "metaballs_probe.comp",
            "main",
            Some(&options),
        )
        .unwrap_or_else(|e| panic!("{e}"));
    spirv.as_binary().to_vec()
}

/// Runs the probe on `rays`; returns (normal, t, flags, iterations) per ray.
fn run_probe(
    groups: &[GpuMetaGroup],
    balls: &[GpuMetaBall],
    lists: &[u32],
    rays: &[ProbeRay],
) -> Vec<([f32; 3], f32, u32, u32)> {
    let options = ContextOptions {
        validation: true,
        device_filter: std::env::var("HADOU_DEVICE").ok().filter(|s| !s.is_empty()),
    };
    let ctx = GpuContext::new(&options).unwrap_or_else(|e| panic!("GPU tests need a Vulkan device: {e}"));
    let out = {
        let memory = Memory::new(&ctx).unwrap();
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let upload = |name: &str, bytes: &[u8]| {
            let mut b = memory
                .create_buffer(&ctx, name, bytes.len() as u64, usage, MemoryLocation::CpuToGpu)
                .unwrap();
            b.write(0, bytes).unwrap();
            b
        };
        let inputs = [
            upload("metaball groups", bytemuck::cast_slice(groups)),
            upload("metaball balls", bytemuck::cast_slice(balls)),
            upload("metaball lists", bytemuck::cast_slice(lists)),
            upload("metaball rays", bytemuck::cast_slice(rays)),
        ];
        let results = memory
            .create_buffer(
                &ctx,
                "metaball results",
                (rays.len() * 32) as u64,
                usage,
                MemoryLocation::GpuToCpu,
            )
            .unwrap();
        let pipeline = create_compute_pipeline(&ctx, "metaballs_probe", &compile(), 16).unwrap();
        let pool = DescriptorPool::new(&ctx, "metaballs probe pool", 1).unwrap();
        let set = pool.allocate(&ctx, pipeline.set_layout, "metaballs probe set").unwrap();
        let mut bound: Vec<(u32, Bound)> = inputs
            .iter()
            .enumerate()
            .map(|(i, b)| (i as u32, Bound::Storage(BufferRange::whole(b.raw))))
            .collect();
        bound.push((4, Bound::Storage(BufferRange::whole(results.raw))));
        write_set(&ctx, set, &bound);
        let mut commands = FrameCommands::new(&ctx, "metaballs probe").unwrap();
        commands.begin(&ctx).unwrap();
        let counts = [rays.len() as u32, 0, 0, 0];
        // SAFETY: the command buffer is recording; every handle is alive until the wait returns.
        unsafe {
            ctx.device.cmd_bind_pipeline(commands.cmd, vk::PipelineBindPoint::COMPUTE, pipeline.raw);
            ctx.device.cmd_bind_descriptor_sets(
                commands.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipeline.layout,
                0,
                &[set],
                &[],
            );
            ctx.device.cmd_push_constants(
                commands.cmd,
                pipeline.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytemuck::cast_slice(&counts),
            );
            ctx.device.cmd_dispatch(commands.cmd, (rays.len() as u32).div_ceil(64), 1, 1);
        }
        let to_host = memory_barrier(
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
            vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::HOST_READ,
        );
        cmd_barriers(&ctx.device, commands.cmd, &[], &[to_host]);
        commands.submit_and_wait(&ctx, "metaballs_probe").unwrap();
        let words: &[f32] = bytemuck::cast_slice(results.mapped().unwrap());
        let out = words
            .chunks_exact(8)
            .map(|c| ([c[0], c[1], c[2]], c[3], c[4].to_bits(), c[5].to_bits()))
            .collect();
        out
    };
    let counts = ctx.validation_counts();
    assert!(
        counts.errors == 0 && counts.warnings == 0,
        "validation: {} errors, {} warnings:\n{}",
        counts.errors,
        counts.warnings,
        ctx.validation_messages().join("\n")
    );
    out
}

fn random_group(rng: &mut Rng) -> MetaballGroupParams {
    let n = 2 + (rng.next() * 10.0) as usize;
    let balls = (0..n)
        .map(|_| {
            let q = if rng.next() < 0.2 { rng.range(-1.2, -0.3) } else { rng.range(0.6, 2.0) };
            Ball { centre: rng.vec(-2.5, 2.5), radius: rng.range(1.0, 3.0), q }
        })
        .collect();
    let mut ops = vec![TransformOp::Rotate { angle_deg: rng.range(0.0, 360.0), axis: rng.unit() }];
    if rng.next() < 0.5 {
        ops.insert(
            0,
            TransformOp::Scale(DVec3::new(rng.range(0.5, 2.0), rng.range(0.5, 2.0), rng.range(0.5, 2.0))),
        );
    }
    ops.push(TransformOp::Translate(rng.vec(-3.0, 3.0)));
    MetaballGroupParams {
        threshold: rng.range(0.3, 0.8),
        kernel: if rng.next() < 0.7 { Kernel::Wyvill6 } else { Kernel::Murakami4 },
        balls,
        transform: Transform::from_ops(&ops).unwrap(),
        method: Default::default(),
    }
}

#[test]
fn glsl_matches_the_f32_twin_and_f64() {
    let mut rng = Rng(0x6d65_7461_6261_6c6c);
    let mut groups = Vec::new();
    let mut params = Vec::new();
    let mut balls: Vec<GpuMetaBall> = Vec::new();
    let mut lists: Vec<u32> = Vec::new();
    let mut rays = Vec::new();
    let mut ray_f64 = Vec::new();
    for gi in 0..64u32 {
        let g = random_group(&mut rng);
        let first = balls.len() as u32;
        groups.push(gpu_group(&g, first, gi));
        balls.extend(gpu_balls(&g));
        // The list holds the group's balls in a shuffled order, as a binning pass might.
        let begin = lists.len() as u32;
        let mut ids: Vec<u32> = (first..first + g.balls.len() as u32).collect();
        for i in (1..ids.len()).rev() {
            ids.swap(i, (rng.next() * (i + 1) as f64) as usize);
        }
        lists.extend(&ids);
        let centre = g.transform.transform_point(DVec3::ZERO);
        for _ in 0..256 {
            let o = centre + rng.unit() * rng.range(6.0, 25.0);
            let d = (centre + rng.vec(-4.0, 4.0) - o).normalize();
            let (t_min, t_max) =
                (rng.range(0.0, 1.0), if rng.next() < 0.2 { rng.range(5.0, 20.0) } else { 100.0 });
            rays.push(ProbeRay {
                origin_tmin: [o.x as f32, o.y as f32, o.z as f32, t_min as f32],
                dir_tmax: [d.x as f32, d.y as f32, d.z as f32, t_max as f32],
                target: [gi, begin, g.balls.len() as u32, 0],
            });
            ray_f64.push((params.len(), o, d, t_min, t_max));
        }
        params.push(g);
    }
    let gpu = run_probe(&groups, &balls, &lists, &rays);
    let (mut hits, mut same_iterations, mut in_band, mut band_differ) = (0usize, 0usize, 0usize, 0usize);
    let (mut worst_twin_t, mut worst_twin_n, mut worst_f64_t) = (0.0f64, 0.0f64, 0.0f64);
    for (k, (ray, &(gi, o, d, t_min, t_max))) in rays.iter().zip(&ray_f64).enumerate() {
        let (normal, t, flags, iterations) = gpu[k];
        let (b, c) = (ray.target[1] as usize, ray.target[2] as usize);
        let twin = cast_f32(
            &groups[gi],
            &balls,
            &lists[b..b + c],
            glam::Vec3::from_slice(&ray.origin_tmin[..3]),
            glam::Vec3::from_slice(&ray.dir_tmax[..3]),
            ray.origin_tmin[3],
            ray.dir_tmax[3],
            false,
        );
        assert_eq!(flags & MB_STREAMED, 0);
        let reference = cast(&params[gi], o, d, t_min, t_max);
        let band = tangency(&params[gi], o, d, t_min, t_max).in_band();
        let gpu_hit = flags & MB_HIT != 0;
        if band {
            in_band += 1;
            band_differ += usize::from(gpu_hit != twin.hit());
            continue;
        }
        assert_eq!(gpu_hit, twin.hit(), "ray {k}: GPU flags {flags:#x}, twin {twin:?}");
        assert_eq!(gpu_hit, reference.is_some(), "ray {k}: GPU flags {flags:#x}, f64 {reference:?}");
        same_iterations += usize::from(iterations == twin.iterations);
        if let Some(r) = reference {
            hits += 1;
            let tw = (t - twin.t).abs() / twin.t;
            worst_twin_t = worst_twin_t.max(f64::from(tw));
            let gn = glam::Vec3::from(normal).as_dvec3();
            worst_twin_n = worst_twin_n.max(gn.angle_between(twin.normal.as_dvec3()).to_degrees());
            let rel = (f64::from(t) - r.t).abs() / r.t;
            worst_f64_t = worst_f64_t.max(rel);
            assert!(rel <= 1e-4, "ray {k}: GPU t {t} vs f64 {}", r.t);
            assert!(gn.angle_between(r.normal).to_degrees() <= 0.5, "ray {k}: normal {gn} vs {}", r.normal);
        }
    }
    println!(
        "GPU probe, {} rays on {} groups: {hits} hits; vs the f32 twin: worst depth {worst_twin_t:.1e} relative, \
         worst normal {worst_twin_n:.4}°, same iteration count on {same_iterations} of {} rays outside the band; vs \
         f64: worst depth {worst_f64_t:.1e}; {in_band} rays in the tangency band ({band_differ} hit/miss differ from \
         the twin)",
        rays.len(),
        groups.len(),
        rays.len() - in_band
    );
    assert!(hits > 2000, "{hits} hits");
    assert!(worst_twin_t <= 1e-5 && worst_twin_n <= 0.05);
}

/// The two variants the speed-against-error report compares, on the device against the f32
/// twin: Bézier clipping with a coarse `tolerance` (1e-3 world units) and sphere tracing (4,096
/// steps: far more than any of these rays needs, so no cast runs out). Both are the same f32
/// operations on both sides, so outside the tangency band hit/miss agree and depths agree to
/// rounding (1e-5 relative, as for the default clipping above). Sphere tracing may also skip a
/// sliver of surface thinner than its least step, where F − T stays within 2⁻¹⁰·T of zero (see
/// metaballs_trace.rs): there the device and the twin may legitimately take different steps, so
/// rays whose tangency margin is below 2⁻¹⁰ (margin = min |F − T|/(S + X·G) ≥ that, since
/// S ≥ T) are left out of the sphere-tracing comparison.
#[test]
fn glsl_variants_match_the_f32_twin() {
    use hadou::effects::metaballs::CastMethod;
    let mut rng = Rng(0x7661_7269_616e_7473);
    let (mut groups, mut params, mut balls, mut lists) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut rays, mut ray_f64) = (Vec::new(), Vec::new());
    for gi in 0..48u32 {
        let mut g = random_group(&mut rng);
        g.method = if gi % 2 == 0 {
            CastMethod::Bezier { tolerance: 1e-3 }
        } else {
            CastMethod::SphereTrace { steps: 4096 }
        };
        let first = balls.len() as u32;
        groups.push(gpu_group(&g, first, gi));
        balls.extend(gpu_balls(&g));
        let begin = lists.len() as u32;
        lists.extend(first..first + g.balls.len() as u32);
        let centre = g.transform.transform_point(DVec3::ZERO);
        for _ in 0..128 {
            let o = centre + rng.unit() * rng.range(6.0, 25.0);
            let d = (centre + rng.vec(-4.0, 4.0) - o).normalize();
            let t_min = rng.range(0.0, 1.0);
            rays.push(ProbeRay {
                origin_tmin: [o.x as f32, o.y as f32, o.z as f32, t_min as f32],
                dir_tmax: [d.x as f32, d.y as f32, d.z as f32, 100.0],
                target: [gi, begin, g.balls.len() as u32, gi % 2],
            });
            ray_f64.push((params.len(), o, d, t_min));
        }
        params.push(g);
    }
    let gpu = run_probe(&groups, &balls, &lists, &rays);
    let (mut hits, mut left_out, mut worst_t, mut worst_f64) = ([0usize; 2], [0usize; 2], [0f64; 2], 0f64);
    let mut worst_tol = 0f64;
    for (k, (ray, &(gi, o, d, t_min))) in rays.iter().zip(&ray_f64).enumerate() {
        let (normal, t, flags, _) = gpu[k];
        let trace = ray.target[3] as usize;
        let (b, c) = (ray.target[1] as usize, ray.target[2] as usize);
        let twin = cast_f32(
            &groups[gi],
            &balls,
            &lists[b..b + c],
            glam::Vec3::from_slice(&ray.origin_tmin[..3]),
            glam::Vec3::from_slice(&ray.dir_tmax[..3]),
            ray.origin_tmin[3],
            ray.dir_tmax[3],
            trace == 1,
        );
        assert_eq!(flags & (MB_STREAMED | MB_NOT_CONVERGED), 0, "ray {k}");
        assert_eq!(twin.flags & MB_NOT_CONVERGED, 0, "ray {k}");
        let margin = tangency(&params[gi], o, d, t_min, 100.0).margin;
        let limit = if trace == 1 { 2f64.powi(-10) } else { BAND_C * f64::from(f32::EPSILON) };
        if margin <= limit {
            left_out[trace] += 1;
            continue;
        }
        let gpu_hit = flags & MB_HIT != 0;
        assert_eq!(
            gpu_hit,
            twin.hit(),
            "ray {k} ({}): GPU flags {flags:#x}, twin {twin:?}",
            ["clip", "trace"][trace]
        );
        if gpu_hit {
            hits[trace] += 1;
            worst_t[trace] = worst_t[trace].max(f64::from((t - twin.t).abs() / twin.t));
            let gn = glam::Vec3::from(normal);
            assert!(
                gn.angle_between(twin.normal).to_degrees() <= 0.05,
                "ray {k}: normal {gn} vs {}",
                twin.normal
            );
            let r = cast(&params[gi], o, d, t_min, 100.0).expect("the reference hits too");
            if trace == 1 {
                // Sphere tracing finds the exact first root (away from slivers), to ~2⁻²⁶·T/L.
                worst_f64 = worst_f64.max((f64::from(t) - r.t).abs() / r.t);
            } else {
                // A part whose ends differ in sign holds the first root: within half the
                // tolerance of its middle, plus the default clipping's f32 error (≤ 1e-4).
                let err = (f64::from(t) - r.t).abs();
                assert!(err <= 0.5e-3 + 1e-4 * r.t, "ray {k}: tolerance 1e-3, t {t} vs f64 {}", r.t);
                worst_tol = worst_tol.max(err);
            }
        }
    }
    println!(
        "GPU variants vs the f32 twin: tolerance 1e-3: {} hits, worst depth {:.1e} rel (vs f64: {worst_tol:.1e} \
         world units), {} rays in the band; \
         sphere tracing: {} hits, worst depth {:.1e} rel (vs f64 reference {worst_f64:.1e}), {} rays within 2^-10",
        hits[0], worst_t[0], left_out[0], hits[1], worst_t[1], left_out[1]
    );
    assert!(hits[0] > 500 && hits[1] > 500, "{hits:?}");
    assert!(worst_t[0] <= 1e-5 && worst_t[1] <= 1e-5, "{worst_t:?}");
    assert!(worst_f64 <= 1e-4, "{worst_f64:.2e}");
}

/// The streamed cast (`mb_clip_stream`) on the device against its f32 twin and f64: crowds of 40,
/// 48 and 150 overlapping supports (`testing::crowded_metaballs`; more than the 32 slots hold at
/// one point), half the groups sphere-traced (a crowded ray is streamed with clipping whatever
/// the method). Same operations on both sides, so outside the tangency band hit/miss agree,
/// depths to rounding (1e-5 relative, as for the slot casts above) and the f64 bounds hold.
#[test]
fn glsl_streamed_casts_match_the_f32_twin() {
    use hadou::effects::metaballs::CastMethod;
    let mut rng = Rng(0x7374_7265_616d_6564);
    let (mut groups, mut params, mut balls, mut lists) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut rays, mut ray_f64) = (Vec::new(), Vec::new());
    for (gi, k) in [40usize, 48, 150, 40, 48, 150].into_iter().enumerate() {
        let gi = gi as u32;
        let mut g = hadou::testing::crowded_metaballs(&mut rng, k);
        let trace = gi >= 3;
        if trace {
            g.method = CastMethod::SphereTrace { steps: 256 };
        }
        let first = balls.len() as u32;
        groups.push(gpu_group(&g, first, gi));
        balls.extend(gpu_balls(&g));
        let begin = lists.len() as u32;
        lists.extend(first..first + g.balls.len() as u32);
        let eye = g.transform.transform_point(DVec3::new(0.0, 0.0, 10.0));
        let centre = g.transform.transform_point(DVec3::new(0.05, -0.05, -1.35));
        for _ in 0..48 {
            let d = (centre + rng.vec(-1.0, 1.0) - eye).normalize();
            rays.push(ProbeRay {
                origin_tmin: [eye.x as f32, eye.y as f32, eye.z as f32, 0.1],
                dir_tmax: [d.x as f32, d.y as f32, d.z as f32, 100.0],
                target: [gi, begin, g.balls.len() as u32, trace as u32],
            });
            ray_f64.push((params.len(), eye, d));
        }
        params.push(g);
    }
    let gpu = run_probe(&groups, &balls, &lists, &rays);
    let (mut hits, mut streamed, mut in_band, mut worst_t, mut worst_f64) =
        (0usize, 0usize, 0usize, 0f64, 0f64);
    for (k, (ray, &(gi, o, d))) in rays.iter().zip(&ray_f64).enumerate() {
        let (normal, t, flags, _) = gpu[k];
        let (b, c) = (ray.target[1] as usize, ray.target[2] as usize);
        let twin = cast_f32(
            &groups[gi],
            &balls,
            &lists[b..b + c],
            glam::Vec3::from_slice(&ray.origin_tmin[..3]),
            glam::Vec3::from_slice(&ray.dir_tmax[..3]),
            ray.origin_tmin[3],
            ray.dir_tmax[3],
            ray.target[3] == 1,
        );
        assert_eq!(flags & MB_NOT_CONVERGED, 0, "ray {k}");
        assert_eq!(flags & MB_STREAMED, twin.flags & MB_STREAMED, "ray {k}: GPU {flags:#x}, twin {twin:?}");
        streamed += usize::from(flags & MB_STREAMED != 0);
        if tangency(&params[gi], o, d, 0.1, 100.0).in_band() {
            in_band += 1;
            continue;
        }
        let gpu_hit = flags & MB_HIT != 0;
        assert_eq!(gpu_hit, twin.hit(), "ray {k}: GPU flags {flags:#x}, twin {twin:?}");
        let reference = cast(&params[gi], o, d, 0.1, 100.0);
        assert_eq!(gpu_hit, reference.is_some(), "ray {k}: GPU flags {flags:#x}, f64 {reference:?}");
        if let Some(r) = reference {
            hits += 1;
            worst_t = worst_t.max(f64::from((t - twin.t).abs() / twin.t));
            let gn = glam::Vec3::from(normal);
            assert!(
                gn.angle_between(twin.normal).to_degrees() <= 0.05,
                "ray {k}: normal {gn} vs {}",
                twin.normal
            );
            let rel = (f64::from(t) - r.t).abs() / r.t;
            worst_f64 = worst_f64.max(rel);
            assert!(rel <= 1e-4, "ray {k}: GPU t {t} vs f64 {}", r.t);
            assert!(gn.as_dvec3().angle_between(r.normal).to_degrees() <= 0.5, "ray {k}: normal vs f64");
        }
    }
    println!(
        "GPU streamed casts, {} rays: {streamed} streamed, {hits} hits; worst depth vs the twin {worst_t:.1e} rel, \
         vs f64 {worst_f64:.1e}; {in_band} in the band",
        rays.len()
    );
    assert!(streamed > rays.len() * 3 / 4 && hits > 100, "{streamed} streamed, {hits} hits");
    assert!(worst_t <= 1e-5, "{worst_t:.2e}");
}
