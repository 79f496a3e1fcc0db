//! The metaballs pass's tile lists built on the device (shaders/metaballs_bin.comp) against their
//! CPU twin (`passes::metaballs::bin_balls` with the device's f32 entry keys), on hard cases:
//! balls off screen, behind the camera, straddling tile edges, one whose support holds the camera
//! (the whole screen), none visible, two groups, a crowded group's flag, 10,000 balls, and lists
//! past the capacity (the shared lists every tile walks). The device's rectangles are computed in
//! f32 and padded wider, so its lists may hold more balls than the twin's (none a ray of the tile
//! meets); every ball the twin lists is there, in the twin's order, with the twin's run flags.
//! Validation (with synchronization validation) must stay silent.

mod common;

use glam::DVec3;
use hadou::effects::metaballs::MetaballGroupParams;
use hadou::effects::metaballs_f32::{gpu_balls, gpu_group, GpuMetaBall, GpuMetaGroup};
use hadou::gpu::barriers::{cmd_barriers, memory_barrier};
use hadou::gpu::commands::FrameCommands;
use hadou::gpu::memory::{Memory, MemoryLocation};
use hadou::gpu::pipeline::{bind_set, Bound, BufferRange, DescriptorPool};
use hadou::gpu::recorder::Recorder;
use hadou::gpu::shader::ShaderCompiler;
use hadou::gpu::texel_buffer::{TexelBuffer, Texels};
use hadou::gpu::vk;
use hadou::passes::gpu_structs::FrameUniforms;
use hadou::passes::metaballs::{bin_balls, sphere_tiles, GroupBins, TileLists, TILE};
use hadou::passes::metaballs_bin::{
    self, bin_key, BinBuffers, BinGroup, BinPipelines, BinSizes, BIN_OVERFLOW,
};
use hadou::scene::Scene;

/// The device's lists of `scene` at `width`×`height` (entry capacity `capacity`), and whether
/// they overflowed.
fn device_lists(scene: &Scene, width: u32, height: u32, capacity: u64) -> (TileLists, bool) {
    let (_leaks, ctx) = common::context();
    let extent = vk::Extent2D { width, height };
    let groups: Vec<MetaballGroupParams> = scene.metaballs().iter().map(|g| g.at(0.0)).collect();
    let mut gpu_groups: Vec<GpuMetaGroup> = Vec::new();
    let mut balls: Vec<GpuMetaBall> = Vec::new();
    let mut bin_groups = Vec::new();
    for g in &groups {
        let first = balls.len() as u32;
        gpu_groups.push(gpu_group(g, first, 0, (scene.camera.position, DVec3::ZERO)));
        balls.extend(gpu_balls(g));
        bin_groups.push(BinGroup::new(g, first, &scene.camera, DVec3::ZERO));
    }
    let out = {
        let memory = Memory::new(&ctx).unwrap();
        let mut compiler = ShaderCompiler::new(hadou::SHADERS).unwrap();
        let pipelines = BinPipelines::new(&ctx, &mut compiler).unwrap();
        let host = MemoryLocation::CpuToGpu;
        let upload = |name: &str, bytes: &[u8], usage| {
            let mut b = memory.create_buffer(&ctx, name, bytes.len().max(16) as u64, usage, host).unwrap();
            b.write(0, bytes).unwrap();
            b
        };
        let uniforms = FrameUniforms::new(scene, width, height, 1.0);
        let uniforms =
            upload("uniforms", bytemuck::bytes_of(&uniforms), vk::BufferUsageFlags::UNIFORM_BUFFER);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let bin_groups = upload("bin groups", bytemuck::cast_slice(&bin_groups), storage);
        let stats = memory.create_buffer(&ctx, "stats", 64, storage, MemoryLocation::GpuToCpu).unwrap();
        let group_texels = TexelBuffer::from_bytes(
            &ctx,
            &memory,
            "groups",
            bytemuck::cast_slice(&gpu_groups),
            Texels::U32x4,
        )
        .unwrap();
        let ball_bytes: &[u8] = bytemuck::cast_slice(&balls);
        let ball_texels = TexelBuffer::from_bytes(&ctx, &memory, "balls", ball_bytes, Texels::U32x4).unwrap();
        let sizes = BinSizes::new(balls.len() as u32, gpu_groups.len() as u32, extent);
        let mut bins = BinBuffers::at(&ctx, &memory, sizes, capacity, MemoryLocation::GpuToCpu).unwrap();
        bins.reset().unwrap();
        let params = bins.params(&scene.camera, extent);
        // Bindings by number as the pass gives them; those the stages do not declare are unused.
        let mut bound = vec![Bound::Storage(BufferRange::whole(stats.raw)); 24];
        bound[4] = Bound::Uniform(BufferRange::whole(uniforms.raw));
        bound[6] = Bound::UniformTexel(group_texels.view);
        bound[7] = Bound::UniformTexel(ball_texels.view);
        let views = bins.views();
        bound[8] = views[0];
        bound[9] = views[1];
        bound[13] = views[2];
        bound[14] = Bound::Storage(BufferRange::whole(bin_groups.raw));
        for (i, b) in bins.written().into_iter().enumerate() {
            bound[15 + i] = Bound::Storage(b);
        }
        let pool = DescriptorPool::new(&ctx, "binning pool", 8).unwrap();
        let sets: Vec<vk::DescriptorSet> =
            pipelines.all().into_iter().map(|p| bind_set(&ctx, &pool, p, &bound).unwrap()).collect();
        let mut commands = FrameCommands::new(&ctx, "binning").unwrap();
        commands.begin(&ctx).unwrap();
        let rec = Recorder { ctx: &ctx, cmd: commands.cmd };
        metaballs_bin::record(&rec, &pipelines, &sets, &params);
        let to_host = memory_barrier(
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
            vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::HOST_READ,
        );
        cmd_barriers(&ctx.device, commands.cmd, &[], &[to_host]);
        commands.submit_and_wait(&ctx, "binning").unwrap();
        assert_eq!(u32::from_le_bytes(stats.mapped().unwrap()[..4].try_into().unwrap()), 0, "dropped");
        (bins.read_back().expect("host-visible lists"), bins.state_word(BIN_OVERFLOW) != 0)
    };
    out
}

/// The twin: `bin_balls` with the device's entry keys (f32, `bin_key`).
fn twin(scene: &Scene, width: u32, height: u32) -> (TileLists, Vec<Vec<(DVec3, f64)>>) {
    let extent = vk::Extent2D { width, height };
    let mut bins = Vec::new();
    let mut bounds = Vec::new();
    for g in scene.metaballs().iter().map(|g| g.at(0.0)) {
        let mut b = GroupBins::new(&g, &scene.camera, extent);
        let origin = BinGroup::new(&g, 0, &scene.camera, DVec3::ZERO).origin;
        b.keys = gpu_balls(&g).iter().map(|ball| f64::from(bin_key(ball, origin))).collect();
        bounds.push(b.bounds.clone());
        bins.push(b);
    }
    (bin_balls(&scene.camera, extent, &bins), bounds)
}

/// Every ball the twin lists in a tile is in the device's list of that tile (same group, same
/// order, same flags); a ball only the device lists lies within a tile of it by its f64
/// rectangle (or just off screen). Returns (twin entries, device entries).
fn check(scene: &Scene, width: u32, height: u32, capacity: u64) -> (usize, usize, bool) {
    let (device, overflow) = device_lists(scene, width, height, capacity);
    let (cpu, bounds) = twin(scene, width, height);
    let extent = vk::Extent2D { width, height };
    let (tx, ty) = (width.div_ceil(TILE), height.div_ceil(TILE));
    let firsts: Vec<usize> = bounds
        .iter()
        .scan(0, |n, b| {
            let f = *n;
            *n += b.len();
            Some(f)
        })
        .collect();
    let (mut cpu_n, mut dev_n) = (0, 0);
    for y in 0..ty {
        for x in 0..tx {
            let want = cpu.runs(x, y);
            let have = if overflow { shared_runs(&device) } else { device.runs(x, y) };
            let mut h = have.iter();
            for (g, list) in &want {
                let Some((_, got)) = h.find(|(hg, _)| hg == g) else {
                    panic!("tile ({x}, {y}): group {g} missing from the device's lists")
                };
                // The twin's list is a subsequence of the device's.
                let mut it = got.iter();
                for b in list.iter() {
                    assert!(
                        it.any(|d| d == b),
                        "tile ({x}, {y}) group {g}: ball {b} missing or out of order"
                    );
                }
            }
            for (g, got) in &have {
                dev_n += got.len();
                let listed: &[u32] = want.iter().find(|(wg, _)| wg == g).map_or(&[], |(_, l)| l);
                for b in got.iter().filter(|b| !listed.contains(b)) {
                    let i = *b as usize - firsts[*g as usize];
                    let (c, r) = bounds[*g as usize][i];
                    if overflow {
                        continue; // the shared lists hold every visible ball
                    }
                    if let Some(rect) = sphere_tiles(&scene.camera, extent, c, r) {
                        let near =
                            x + 1 >= rect[0] && x <= rect[2] + 1 && y + 1 >= rect[1] && y <= rect[3] + 1;
                        assert!(near, "tile ({x}, {y}): ball {b} listed, its rectangle is {rect:?}");
                    }
                }
            }
            cpu_n += want.iter().map(|(_, l)| l.len()).sum::<usize>();
        }
    }
    // The flags of the device's runs are the twin's (one group's runs all carry the same).
    for (g, flags) in
        scene.metaballs().iter().enumerate().map(|(g, _)| (g as u32, group_flags(&cpu, g as u32)))
    {
        if let Some(want) = flags {
            assert_eq!(group_flags(&device, g), Some(want), "group {g}'s run flags");
        }
    }
    (cpu_n, dev_n, overflow)
}

fn group_flags(lists: &TileLists, g: u32) -> Option<u32> {
    lists.tiles[lists.active as usize..].iter().find(|r| r[0] == g).map(|r| r[3])
}

/// An overflowing frame's lists: every tile's header points at the same runs.
fn shared_runs(lists: &TileLists) -> Vec<(u32, &[u32])> {
    lists.runs(lists.tiles[0][2], lists.tiles[0][3])
}

fn scene(camera: &str, groups: &[&str]) -> Scene {
    let groups: String = groups.iter().map(|g| format!("[[metaballs]]\n{g}\n")).collect();
    common::parse(&format!(
        "[camera]\n{camera}\nfov_y_deg = 50\nnear = 0.1\nfar = 100\n[[light]]\ndirection = [-1, -2, -1]\n{groups}"
    ))
}

const CAMERA: &str = "position = [0, 0, 10]\nlook_at = [0, 0, 0]";

#[test]
fn hard_cases_match_the_cpu_twin() {
    // Straddling tile edges (small balls on a grid of 0.37), off screen, behind the camera,
    // crossing the near plane, and a second group with a transform.
    let mut balls = Vec::new();
    for i in 0..12 {
        for j in 0..8 {
            let (x, y) = (-2.2 + 0.37 * i as f64, -1.5 + 0.37 * j as f64);
            balls.push(format!("{{ centre = [{x}, {y}, {}], radius = 0.21 }}", 0.1 * (i % 3) as f64));
        }
    }
    balls.push("{ centre = [40, 0, 0], radius = 1 }".into()); // off screen
    balls.push("{ centre = [0, 0, 14], radius = 1 }".into()); // behind the camera
    balls.push("{ centre = [0.2, 0.1, 9.5], radius = 0.7 }".into()); // crosses the near plane
    balls.push("{ centre = [3.1, -2.0, 1], radius = 0.9, q = -0.3 }".into());
    let first = format!("balls = [{}]", balls.join(", "));
    let second = "balls = [{ centre = [0, 0, 0], radius = 1.2 }, { centre = [1, 1, -1], radius = 0.8 }]\n\
                  transform = [{ scale = [1.5, 0.7, 1] }, { rotate = { angle_deg = 30, axis = [0, 1, 0] } }, { translate = [-1, 0.5, 0] }]";
    let s = scene(CAMERA, &[&first, second]);
    for (w, h) in [(100, 60), (64, 64), (37, 23)] {
        let (cpu, dev, overflow) = check(&s, w, h, 1 << 16);
        assert!(!overflow);
        assert!(
            cpu > 0 && dev >= cpu && dev <= cpu + cpu / 2,
            "{w}x{h}: {cpu} listed by the twin, {dev} by the device"
        );
    }
}

/// A crowded group (400 supports of radius 1–1.2 in a unit cube: ~55 deep) beside a sparse one:
/// the device's runs carry RUN_CROWDED for the first only, as the twin's do.
#[test]
fn a_crowded_groups_flag_reaches_the_device_lists() {
    use hadou::passes::metaballs::RUN_CROWDED;
    let crowd = "generate = { count = 400, seed = 3, bounds = [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]], \
                 radius = [1, 1.2], q = [0.001, 0.002], speed = 0 }";
    let sparse = "balls = [{ centre = [2, 0, 0], radius = 0.5 }, { centre = [-2, 1, 0], radius = 0.4 }]";
    let s = scene(CAMERA, &[crowd, sparse]);
    let (cpu, _, overflow) = check(&s, 64, 48, 1 << 16);
    assert!(!overflow && cpu > 400);
    let (device, _) = device_lists(&s, 64, 48, 1 << 16);
    assert_eq!(group_flags(&device, 0).map(|f| f & RUN_CROWDED), Some(RUN_CROWDED));
    assert_eq!(group_flags(&device, 1).map(|f| f & RUN_CROWDED), Some(0));
}

#[test]
fn camera_inside_a_support_and_nothing_visible() {
    // The camera inside one support: that ball is in every tile.
    let s = scene(
        CAMERA,
        &["balls = [{ centre = [0, 0, 10.3], radius = 1 }, { centre = [0.5, 0, 0], radius = 1 }]"],
    );
    let (cpu, _, _) = check(&s, 48, 40, 1 << 12);
    assert!(cpu >= 6 * 5);
    // Every ball behind the camera or off screen: no lists at all.
    let s = scene(
        CAMERA,
        &["balls = [{ centre = [0, 0, 20], radius = 1 }, { centre = [0, 80, 0], radius = 1 }]"],
    );
    let (device, _) = device_lists(&s, 48, 40, 1 << 12);
    assert_eq!(device.active, 0);
    assert!(device.entries.is_empty());
}

#[test]
fn ten_thousand_balls_and_a_full_capacity() {
    let generate = "generate = { count = 10000, seed = 7, bounds = [[-10, -3, -10], [10, 3, 10]], \
                    radius = [0.35, 0.75], q = [0.8, 1.2], speed = 0 }";
    let s = scene("position = [0, 6, 24]\nlook_at = [0, 0, 0]", &[generate]);
    let (cpu, dev, overflow) = check(&s, 96, 64, 1 << 20);
    assert!(!overflow && cpu > 10_000 && dev >= cpu, "{cpu} {dev}");
    // Lists past the capacity: every tile shares one run per group over all its visible balls,
    // in the same order, and the twin's balls are all there.
    let (_, _, overflow) = check(&s, 96, 64, 100);
    assert!(overflow);
}
