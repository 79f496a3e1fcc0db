//! The depth import converts the game's depth into hadou's own `depth` only over the raster's
//! rectangle (the screen bounds of hadou's instances, `depth_import::raster_pixels`), and into
//! `distance` everywhere; a frame that runs a pass of a game's effect — which may read `depth`
//! anywhere — imports the whole of it. Both must give the same frame bit for bit: the game
//! prototype's frame (translucent target, slime, a charging wave) and the same frame with the
//! target despawned (no instance: no depth converted at all), each rendered without and then with
//! a game's pass that declares `depth`, every colour byte and every AOV value compared. Lavapipe,
//! validation + synchronization validation on: zero errors, zero warnings.

mod common;

#[path = "../examples/game_prototype/game.rs"]
mod game;
#[path = "../examples/game_prototype/gpu.rs"]
mod gpu;
#[path = "../examples/game_prototype/painter.rs"]
mod painter;
#[path = "../examples/game_prototype/slime_sim.rs"]
mod slime_sim;

use ash::vk;
use game::{Game, Input};
use glam::{DMat4, DVec3};
use hadou::effect::{
    Binding, Effect, EffectPass, Effects, FrameContext, GpuResult, ImageAccess, ImageUse, Pass,
    PassRecording, Pipeline, Target,
};
use hadou::passes::depth_import::raster_pixels;
use hadou::Aov;

/// A game's effect whose pass declares hadou's `depth` as its depth attachment (what a
/// depth-tested pass of a game declares) and records nothing: it only makes the frame one whose
/// passes are not all hadou's own.
struct DepthReader;

/// Its world data: present = the pass runs.
#[derive(Clone, Debug)]
struct ReadsDepth;

impl Effect for DepthReader {
    fn name(&self) -> &'static str {
        "depth_reader"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "depth_reader",
            |s| s.effects.get::<ReadsDepth>().is_some(),
            |_| Ok(Box::new(ReaderPass)),
        )]
    }
}

struct ReaderPass;

impl Pass for ReaderPass {
    fn name(&self) -> &'static str {
        "depth_reader"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![ImageUse::new(Target::Depth, ImageAccess::DEPTH_ATTACHMENT)]
    }

    fn prepare(&mut self, _frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        Ok(Vec::new())
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        Vec::new()
    }

    fn record(&self, _pass: &PassRecording) {}
}

const AOVS: [Aov; 5] = [Aov::Depth, Aov::Energy, Aov::Normal, Aov::Hdr, Aov::Thickness];

/// One frame of the current state, waited for: its colour bytes and its AOVs as bits.
fn frame(g: &mut Game, e: vk::Extent2D) -> (Vec<u8>, Vec<(Aov, Vec<u32>)>) {
    let f = g.offscreen_frame(e, &AOVS).unwrap();
    let bits = f.aovs().iter().map(|(a, img)| (*a, img.data.iter().map(|v| v.to_bits()).collect())).collect();
    (f.color, bits)
}

/// The frame without and with the game's pass: identical.
fn same_with_and_without_reader(g: &mut Game, e: vk::Extent2D, what: &str) {
    let (color, aovs) = frame(g, e);
    g.hadou.insert_effect("depth_reader", ReadsDepth).unwrap();
    let (color_whole, aovs_whole) = frame(g, e);
    assert!(g.hadou.remove_effect("depth_reader").unwrap());
    assert_eq!(aovs.len(), aovs_whole.len(), "{what}: the same AOVs");
    for ((a, v), (_, w)) in aovs.iter().zip(&aovs_whole) {
        let differ = v.iter().zip(w).filter(|(x, y)| x != y).count();
        assert_eq!(
            differ, 0,
            "{what}: {a:?} differs in {differ} pixels between the depth rectangle and the whole depth"
        );
    }
    let differ = color.iter().zip(&color_whole).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{what}: {differ} colour bytes differ");
}

#[test]
fn depth_rectangle_and_whole_depth_give_the_same_frame() {
    let e = vk::Extent2D { width: 160, height: 96 };
    let vk = gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap();
    let effects = Effects::builtin().with(DepthReader).unwrap();
    let mut g = Game::with_effects(vk, 2, effects).unwrap();
    // Charge for 0.6 s, then hold with time stopped: every frame below renders the same state.
    for i in 0..8 {
        g.update(&Input { charge: true, ..Input::default() }, if i < 6 { 0.1 } else { 0.0 }).unwrap();
    }
    // The target sunk halfway into the game's floor (top at y = 0): only the game's depth hides
    // its lower half, so a depth rectangle that missed it would show in the frame.
    let target = g.hadou.instance_ids()[0];
    let sunk =
        DMat4::from_translation(DVec3::new(6.5, 0.0, 0.0)) * DMat4::from_rotation_y(20f64.to_radians());
    g.hadou.set_transform(target, sunk).unwrap();
    // The target covers a small part of the frame: the rectangle path is the one taken.
    let scene = g.hadou.scene().unwrap();
    let bounds: Vec<_> = scene.meshes.iter().map(|m| m.mesh.bounds()).collect();
    let rect = raster_pixels(scene, &bounds, e).expect("the target is on screen");
    assert!(
        rect.width() * rect.height() < e.width * e.height / 4,
        "the target's rectangle {rect:?} should be a small part of the frame"
    );
    same_with_and_without_reader(&mut g, e, "the game prototype's frame");

    // No instance: no depth is converted, and nothing reads it.
    g.hadou.despawn_instance(target).unwrap();
    assert!(raster_pixels(g.hadou.scene().unwrap(), &bounds, e).is_none());
    same_with_and_without_reader(&mut g, e, "the frame without instances");

    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors + warnings == 0, "validation: {errors} errors, {warnings} warnings: {:?}", messages.texts);
}
