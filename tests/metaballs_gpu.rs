//! shaders/common/metaballs.glsl on the device against its f32 twin (`metaballs_f32::cast_f32`)
//! and the f64 reference: a probe compute shader (below) casts rays given in a buffer through
//! `metaball_cast`, for random groups (several per dispatch, each with its own ball range and
//! index list). The GLSL and the twin share every operation, so away from the tangency band they
//! agree to rounding (the device may fuse multiply-adds): each lies within `f32_bound` (the f32
//! error model of the band, per ray) of the exact hit, so they differ by at most twice that.
//! Validation must stay silent (checked after the device is destroyed).

mod common;

use common::metaball_bound::{angle, f32_bound};

use glam::DVec3;
use hadou::effects::metaballs::{cast, Ball, Kernel, MetaballGroupParams};
use hadou::effects::metaballs_f32::{
    anchor, cast_f32, gpu_balls_cached, gpu_group, tangency, GpuMetaBall, GpuMetaGroup, IsoCache, BAND_C,
    MB_HIT, MB_NOT_CONVERGED, MB_STREAMED,
};
use hadou::gpu::barriers::{cmd_barriers, memory_barrier};
use hadou::gpu::commands::FrameCommands;
use hadou::gpu::memory::Memory;
use hadou::gpu::memory::MemoryLocation;
use hadou::gpu::pipeline::{create_compute_pipeline, write_set, Bound, BufferRange, DescriptorPool};
use hadou::gpu::vk;
use hadou::scene::transform::{Transform, TransformOp};
use hadou::testing::{Comparison, Rng};

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
    // The guard checks the validation log after the device is destroyed (leaks included).
    let (_leaks, ctx) = common::context();
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
        // Placed from its anchor, as the pass places them (the error model's X is measured from it).
        groups.push(gpu_group(&g, first, gi, (DVec3::ZERO, anchor(&g))));
        balls.extend(gpu_balls_cached(&g, &mut IsoCache::default(), anchor(&g)));
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
    // Hit/miss as an error of 0 or 1 (tolerance 0) over every ray, band rays excluded; depths and
    // normals in units of their bounds (`f32_bound`: the device and the twin each err by at most
    // one bound, so they differ by at most two), and the pass's contract against f64 (depth 1e-4
    // relative, normal 0.5°: metaballs_f32's module docs) on the same hits.
    let mut hit_miss = Comparison::new("hit/miss differs from the twin or f64 (outside the band)");
    let mut twin_t = Comparison::new("depth vs the f32 twin / 2 bounds");
    let mut twin_n = Comparison::new("normal vs the f32 twin / 2 bounds");
    let mut f64_t = Comparison::new("depth vs f64 / its bound");
    let mut f64_n = Comparison::new("normal vs f64 / its bound");
    let mut contract_t = Comparison::new("depth vs f64, relative (contract 1e-4)");
    let mut contract_n = Comparison::new("normal vs f64, degrees (contract 0.5°)");
    let (mut same_iterations, mut band_differ) = (0usize, 0usize);
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
            hit_miss.exclude();
            band_differ += usize::from(gpu_hit != twin.hit());
            continue;
        }
        let differ = gpu_hit != twin.hit() || gpu_hit != reference.is_some();
        hit_miss.error(
            format_args!("ray {k}: GPU flags {flags:#x}, twin {twin:?}, f64 {reference:?}"),
            f64::from(u8::from(differ)),
        );
        same_iterations += usize::from(iterations == twin.iterations);
        if let (Some(r), true, true) = (reference, gpu_hit, twin.hit()) {
            let (depth, bound_n) = f32_bound(&params[gi], o, d, r.t, 0.0);
            let gn = glam::Vec3::from(normal).as_dvec3();
            let tn = twin.normal.as_dvec3();
            let at = format_args!("ray {k}");
            twin_t.error(at, (f64::from(t) - f64::from(twin.t)).abs() / r.t / (2.0 * depth));
            twin_n.error(at, angle(gn, tn) / (2.0 * bound_n));
            f64_t.error(at, (f64::from(t) - r.t).abs() / r.t / depth);
            f64_n.error(at, angle(gn, r.normal) / bound_n);
            contract_t.rel(at, f64::from(t), r.t);
            contract_n.error(at, angle(gn, r.normal).to_degrees());
        }
    }
    println!(
        "GPU probe, {} rays on {} groups: same iteration count as the twin on {same_iterations} of {} rays \
         outside the band; {} rays in the band ({band_differ} hit/miss differ from the twin)",
        rays.len(),
        groups.len(),
        hit_miss.compared(),
        hit_miss.excluded()
    );
    // The band is a shell ~δ/‖∇F‖ ≈ 10⁻⁵ units thick about grazing rays; rays aimed into a ±4-unit
    // box cross it with a chance of that order, so 1% (a thousand times more) caps the exclusion.
    hit_miss.assert_excluded_at_most(0.01);
    hit_miss.assert_within(0.0, rays.len() * 99 / 100);
    // About a quarter of the rays hit (4,633 of 16,384 when written); 2,000 is the floor.
    for c in [&twin_t, &twin_n, &f64_t, &f64_n] {
        c.assert_within(1.0, 2000);
    }
    contract_t.assert_within(1e-4, 2000);
    contract_n.assert_within(0.5, 2000);
}

/// The two variants the speed-against-error report compares, on the device against the f32
/// twin: Bézier clipping with a coarse `tolerance` (1e-3 world units) and sphere tracing (4,096
/// steps: far more than any of these rays needs, so no cast runs out). Both are the same f32
/// operations on both sides, so outside the tangency band hit/miss agree and depths and normals
/// agree within twice `f32_bound` (plus each method's own term, below). Sphere tracing may also skip a
/// sliver of surface thinner than its least step, where F − T stays within 2⁻¹⁰·T of zero (see
/// metaballs_trace.rs): there the device and the twin may legitimately take different steps, so
/// rays whose tangency margin is below 2⁻¹⁰ (margin = min |F − T|/(S + X·G) ≥ that, since
/// S ≥ T) are left out of the sphere-tracing comparison.
#[test]
fn glsl_variants_match_the_f32_twin() {
    use hadou::effects::metaballs::CastMethod;
    use hadou::effects::metaballs_trace::{TRACE_BISECT, TRACE_MIN_STEP};
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
        // Placed from its anchor, as the pass places them (the error model's X is measured from it).
        groups.push(gpu_group(&g, first, gi, (DVec3::ZERO, anchor(&g))));
        balls.extend(gpu_balls_cached(&g, &mut IsoCache::default(), anchor(&g)));
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
    let names = ["clip 1e-3", "trace 4096"];
    let new = |what: &str| names.map(|m| Comparison::new(format!("{m}: {what}")));
    let (mut hit_miss, mut twin_t, mut twin_n, mut f64_t) = (
        new("hit/miss differs from the twin"),
        new("depth vs the twin / 2 bounds"),
        new("normal vs the twin / 2 bounds"),
        new("depth vs f64 / its bound"),
    );
    let mut same_steps = [0usize; 2];
    for (k, (ray, &(gi, o, d, t_min))) in rays.iter().zip(&ray_f64).enumerate() {
        let (normal, t, flags, iterations) = gpu[k];
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
            hit_miss[trace].exclude();
            continue;
        }
        let gpu_hit = flags & MB_HIT != 0;
        let at = format_args!("ray {k}: GPU flags {flags:#x}, twin {twin:?}");
        hit_miss[trace].error(at, f64::from(u8::from(gpu_hit != twin.hit())));
        same_steps[trace] += usize::from(iterations == twin.iterations);
        if !(gpu_hit && twin.hit()) {
            continue;
        }
        let g = &params[gi];
        let r = cast(g, o, d, t_min, 100.0).expect("the reference hits too");
        let ts = g.transform.ray_to_object(o, d).t_scale;
        // Each method's own term (object units) beside the f32 error of `f32_bound`:
        // - sphere tracing bisects a bracket one least step wide (TRACE_MIN_STEP·T/L, L ≥ the
        //   group's least |q|γ/R) 16 times: its middle is within 2⁻¹⁷ of that of the root (see
        //   metaballs_math.rs), on each side;
        // - clipping with a tolerance answers the middle of a bracket up to 1e-3 world units wide:
        //   within 0.5e-3 of the root. The device and the twin take the same steps (same
        //   iteration count) and so the same brackets up to rounding; where the counts differ,
        //   each may end anywhere in its bracket: 1e-3 apart.
        let (twin_extra, f64_extra) = if trace == 1 {
            let l_min = g
                .balls
                .iter()
                .map(|b| b.q.abs() * g.kernel.max_slope() / b.radius)
                .fold(f64::INFINITY, f64::min);
            let bracket = TRACE_MIN_STEP * g.threshold / l_min * 0.5f64.powi(TRACE_BISECT as i32 + 1);
            (bracket, bracket)
        } else {
            (if iterations == twin.iterations { 0.0 } else { 0.5e-3 * ts }, 0.5e-3 * ts)
        };
        let (twin_depth, twin_angle) = f32_bound(g, o, d, r.t, twin_extra);
        let (f64_depth, _) = f32_bound(g, o, d, r.t, f64_extra);
        let gn = glam::Vec3::from(normal).as_dvec3();
        twin_t[trace].error(at, (t - twin.t).abs() as f64 / r.t / (2.0 * twin_depth));
        twin_n[trace].error(at, angle(gn, twin.normal.as_dvec3()) / (2.0 * twin_angle));
        f64_t[trace].error(at, (f64::from(t) - r.t).abs() / r.t / f64_depth);
    }
    println!("same step count as the twin outside the band: clip {}, trace {}", same_steps[0], same_steps[1]);
    for m in 0..2 {
        // Rays within 2⁻¹⁰ of tangency (sphere tracing) are ~1% of these (104 of 3,072 when
        // written): 10% caps it; the clip band (16·ε) holds none of them.
        hit_miss[m].assert_excluded_at_most(0.1);
        hit_miss[m].assert_within(0.0, 2000);
        // About 850 hits per method when written.
        for c in [&twin_t[m], &twin_n[m], &f64_t[m]] {
            c.assert_within(1.0, 500);
        }
    }
}

/// The streamed cast (`mb_clip_stream`) on the device against its f32 twin and f64: crowds of 40,
/// 48 and 150 overlapping supports (`testing::crowded_metaballs`; more than the 32 slots hold at
/// one point, and at 150 more than the cast's cache of 128 chords, so the rest of the ray walks
/// the whole list) and tubes of 300 supports met one after another (`testing::crowded_tube`: ~88
/// on a point, gathered in rounds of the cache), half the groups sphere-traced (a crowded ray is streamed with clipping whatever
/// the method). Same operations on both sides, so outside the tangency band hit/miss agree,
/// depths and normals within twice `f32_bound` (as for the slot casts above) and the f64 bounds
/// hold.
#[test]
fn glsl_streamed_casts_match_the_f32_twin() {
    use hadou::effects::metaballs::CastMethod;
    let mut rng = Rng(0x7374_7265_616d_6564);
    let (mut groups, mut params, mut balls, mut lists) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut rays, mut ray_f64) = (Vec::new(), Vec::new());
    let crowds = [(40usize, false), (48, false), (150, false), (300, true)];
    for (gi, (k, tube)) in crowds.into_iter().chain(crowds).enumerate() {
        let gi = gi as u32;
        let mut g = if tube {
            hadou::testing::crowded_tube(&mut rng, k)
        } else {
            hadou::testing::crowded_metaballs(&mut rng, k)
        };
        let trace = gi >= crowds.len() as u32;
        if trace {
            g.method = CastMethod::SphereTrace { steps: 256 };
        }
        let first = balls.len() as u32;
        // Placed from its anchor, as the pass places them (the error model's X is measured from it).
        groups.push(gpu_group(&g, first, gi, (DVec3::ZERO, anchor(&g))));
        balls.extend(gpu_balls_cached(&g, &mut IsoCache::default(), anchor(&g)));
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
    let mut hit_miss = Comparison::new("hit/miss differs from the twin or f64 (outside the band)");
    let mut twin_t = Comparison::new("depth vs the twin / 2 bounds");
    let mut twin_n = Comparison::new("normal vs the twin / 2 bounds");
    let mut f64_t = Comparison::new("depth vs f64 / its bound");
    let mut f64_n = Comparison::new("normal vs f64 / its bound");
    let mut contract_t = Comparison::new("depth vs f64, relative (contract 1e-4)");
    let mut contract_n = Comparison::new("normal vs f64, degrees (contract 0.5°)");
    let mut streamed = 0usize;
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
            hit_miss.exclude();
            continue;
        }
        let gpu_hit = flags & MB_HIT != 0;
        let reference = cast(&params[gi], o, d, 0.1, 100.0);
        let at = format_args!("ray {k}: GPU flags {flags:#x}, twin {twin:?}, f64 {reference:?}");
        hit_miss.error(at, f64::from(u8::from(gpu_hit != twin.hit() || gpu_hit != reference.is_some())));
        if let (Some(r), true, true) = (reference, gpu_hit, twin.hit()) {
            // A streamed cast clips like the slot cast (Bézier clipping whatever the method).
            let (depth, bound_n) = f32_bound(&params[gi], o, d, r.t, 0.0);
            let gn = glam::Vec3::from(normal).as_dvec3();
            twin_t.error(at, (t - twin.t).abs() as f64 / r.t / (2.0 * depth));
            twin_n.error(at, angle(gn, twin.normal.as_dvec3()) / (2.0 * bound_n));
            f64_t.error(at, (f64::from(t) - r.t).abs() / r.t / depth);
            f64_n.error(at, angle(gn, r.normal) / bound_n);
            contract_t.rel(at, f64::from(t), r.t);
            contract_n.error(at, angle(gn, r.normal).to_degrees());
        }
    }
    println!("GPU streamed casts, {} rays: {streamed} streamed", rays.len());
    assert!(streamed > rays.len() * 3 / 4, "{streamed} streamed");
    // The crowds' rays are aimed at the dense middle, not at silhouettes (none in the band when
    // written); the band shell (~10⁻⁵ units) cannot hold a tenth of them.
    hit_miss.assert_excluded_at_most(0.1);
    hit_miss.assert_within(0.0, rays.len() * 9 / 10);
    // 176 of the 288 rays hit when written.
    for c in [&twin_t, &twin_n, &f64_t, &f64_n] {
        c.assert_within(1.0, 100);
    }
    contract_t.assert_within(1e-4, 100);
    contract_n.assert_within(0.5, 100);
}
