//! A temporal effect: a pass that reads an image as the previous frame left it
//! (`Target::Previous`) and writes this frame's (`Target::Custom`) — an exponential moving
//! average, the shape of an accumulation or a TAA history. Against its f64 twin over a sequence
//! of frames, a resize and a frame without the effect (each starts the history from zeros), and
//! the frame checks: the previous frame is read-only, and read only where this frame's is written.

mod common;

use hadou::effect::{
    Binding, Bound, Effect, EffectError, EffectPass, Effects, FrameContext, GpuResult, ImageAccess,
    ImageDesc, ImageUse, Pass, PassBuilder, PassRecording, Pipeline, Target,
};
use hadou::gpu::vk;
use hadou::{Aov, Error, FrameRequest};

static TRAIL: ImageDesc = ImageDesc {
    name: "trail",
    format: vk::Format::R32_SFLOAT,
    texel_bytes: 4,
    usage: vk::ImageUsageFlags::empty(),
    needs: "the trail effect's data",
};

/// The trail's world data; `declare` makes its pass get the declaration wrong (frame checks).
#[derive(Clone, Debug, PartialEq)]
struct Trail {
    weight: f32,
    level: f32,
    declare: Declare,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Declare {
    Right,
    /// Writes the previous frame.
    WritesHistory,
    /// Reads the previous frame and this frame's image, writes neither.
    NoWriter,
}

struct TrailEffect;

impl Effect for TrailEffect {
    fn name(&self) -> &'static str {
        "trail"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "trail",
            |s| s.effects.get::<Trail>().is_some(),
            |b| Ok(Box::new(TrailPass::new(b)?)),
        )]
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct TrailParams {
    p: [f32; 4],
}

struct TrailPass {
    pipeline: Pipeline,
    params: TrailParams,
    declare: Declare,
    extent: vk::Extent2D,
}

impl TrailPass {
    fn new(b: &mut PassBuilder) -> GpuResult<Self> {
        let source = include_str!("data/temporal/trail.comp");
        let pipeline = b.compute_pipeline("trail", source, std::mem::size_of::<TrailParams>() as u32)?;
        Ok(TrailPass {
            pipeline,
            params: TrailParams::default(),
            declare: Declare::Right,
            extent: Default::default(),
        })
    }
}

impl Pass for TrailPass {
    fn name(&self) -> &'static str {
        "trail"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        if let Some(t) = frame.scene.effects.get::<Trail>() {
            self.params = TrailParams { p: [t.weight, t.level, 0.0, 0.0] };
            self.declare = t.declare;
        }
        self.extent = frame.extent;
        let (previous, current) = match self.declare {
            Declare::Right => (ImageAccess::COMPUTE_READ, ImageAccess::COMPUTE_WRITE),
            Declare::WritesHistory => (ImageAccess::COMPUTE_WRITE, ImageAccess::COMPUTE_WRITE),
            Declare::NoWriter => (ImageAccess::COMPUTE_READ, ImageAccess::COMPUTE_READ),
        };
        Ok(vec![
            Binding::Image(ImageUse::new(Target::Previous(&TRAIL), previous)),
            Binding::Image(ImageUse::new(Target::Custom(&TRAIL), current)),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        pass.rec.dispatch_2d(self.extent.width, self.extent.height, (8, 8));
    }
}

const SCENE: &str = r#"
[camera]
position = [0, 1, 5]
look_at = [0, 0, 0]

[[light]]
kind = "directional"
direction = [0, -1, -1]
color = [1, 1, 1]
intensity = 1

[[mesh]]
name = "box"
kind = "cube"
size = 1

[[instance]]
mesh = "box"
"#;

/// The f64 twin of trail.comp over a sequence of levels (from a history of zeros), at column x.
/// Every value is a dyadic rational with few significant bits (weight 3/4, levels and x small
/// integers, 1 − weight = 1/4, at most 8 frames: numerators below 3⁸·2⁴·64 < 2²⁴), so f32
/// computes each step exactly, fused or not: the GPU must match bit for bit.
fn twin(weight: f64, levels: &[f64], x: u32) -> f64 {
    levels.iter().fold(0.0, |acc, level| weight * acc + (1.0 - weight) * level * f64::from(x + 1))
}

fn trail_at(rt: &mut common::CheckedRuntime, size: (u32, u32)) -> hadou::AovImage {
    let mut request = FrameRequest::new(size.0, size.1);
    request.aovs = vec![Aov::Effect(&TRAIL)];
    rt.render(&request).unwrap().aov(Aov::Effect(&TRAIL)).unwrap().clone()
}

fn set_level(rt: &mut common::CheckedRuntime, level: f32) {
    rt.renderer().update_effect(|t: &mut Trail| t.level = level).unwrap();
}

fn assert_trail(image: &hadou::AovImage, levels: &[f64], what: &str) {
    for y in 0..image.height {
        for x in 0..image.width {
            let want = twin(0.75, levels, x);
            let got = f64::from(image.at(x, y, 0));
            assert_eq!(got, want, "{what}: ({x}, {y}) after levels {levels:?}");
        }
    }
}

#[test]
fn a_pass_reads_the_previous_frame() {
    let mut rt = common::runtime_with_effects(Effects::builtin().with(TrailEffect).unwrap());
    rt.load_scene(common::parse(SCENE)).unwrap();
    let trail = Trail { weight: 0.75, level: 1.0, declare: Declare::Right };
    rt.renderer().insert_effect("trail", trail).unwrap();
    let size = (40, 24);
    let mut levels = Vec::new();
    for level in [1.0, 0.0, 2.0, 0.0, 0.0, 3.0] {
        set_level(&mut rt, level as f32);
        levels.push(level);
        assert_trail(&trail_at(&mut rt, size), &levels, "frame by frame");
    }
    // A resize: no previous frame at the new size, the history starts from zeros.
    set_level(&mut rt, 2.0);
    assert_trail(&trail_at(&mut rt, (24, 16)), &[2.0], "after a resize");
    assert_trail(&trail_at(&mut rt, (24, 16)), &[2.0, 2.0], "the frame after the resize");
    // A frame without the effect: its images go, and the history starts again from zeros.
    let kept = rt.renderer().effect::<Trail>().unwrap().clone();
    assert!(rt.renderer().remove_effect("trail").unwrap());
    let mut request = FrameRequest::new(24, 16);
    request.aovs = vec![Aov::Hdr];
    rt.render(&request).unwrap();
    rt.renderer().insert_effect("trail", kept).unwrap();
    assert_trail(&trail_at(&mut rt, (24, 16)), &[2.0], "after a frame without it");
}

#[test]
fn the_previous_frame_is_read_only_and_needs_a_writer() {
    let mut rt = common::runtime_with_effects(Effects::builtin().with(TrailEffect).unwrap());
    rt.load_scene(common::parse(SCENE)).unwrap();
    for (declare, check) in
        [(Declare::WritesHistory, "WritesHistory"), (Declare::NoWriter, "HistoryNotWritten")]
    {
        rt.renderer().insert_effect("trail", Trail { weight: 0.5, level: 1.0, declare }).unwrap();
        let err = rt.render(&FrameRequest::new(16, 16)).unwrap_err();
        let text = err.to_string();
        match (&err, check) {
            (
                Error::Effect(EffectError::WritesHistory { pass: "trail", image: "trail" }),
                "WritesHistory",
            ) => {}
            (
                Error::Effect(EffectError::HistoryNotWritten { pass: "trail", image: "trail", .. }),
                "HistoryNotWritten",
            ) => {}
            _ => panic!("{declare:?}: {err:?}"),
        }
        assert!(text.contains("previous frame of image trail"), "{text}");
    }
    // Declared right again, the frames go on.
    rt.renderer().update_effect(|t: &mut Trail| t.declare = Declare::Right).unwrap();
    rt.render(&FrameRequest::new(16, 16)).unwrap();
}
