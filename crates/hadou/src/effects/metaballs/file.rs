//! `[[metaballs]]` tables → `MetaballGroup`: the schema (serde types mirroring
//! docs/scene-format.md), ranges and defaults, the material and transform, the ball list and its
//! compact generator, and the `[[metaballs.keyframe]]` rules (times strictly increasing, one
//! centre and one q per ball). Every refusal points at the value (or key) at fault.

use glam::DVec3;
use serde::Deserialize;
use toml::Spanned;

use crate::effects::metaballs::{CastMethod, Kernel};
use crate::scene::error::SceneError;
use crate::scene::file::{material_index, transform, Materials};
use crate::scene::file_check::{one_of, show, show_vec, Ctx, Owner, ANY, F32_NORMAL, SQUARED_LENGTH};
use crate::scene::file_schema::{Array, Int, Num, OpDef, TableList, Tables};
use crate::scene::model::{AnimatedBall, MetaballGroup, MetaballKeyframe};

/// Threshold when `threshold` is not given (the seed's T).
pub const DEFAULT_THRESHOLD: f64 = 0.5;
/// The most balls `generate` makes in one group.
pub const MAX_GENERATED: u32 = 65536;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[metaballs]] table")]
pub(crate) struct MetaballsDef {
    pub name: Option<Spanned<String>>,
    pub threshold: Option<Spanned<Num>>,
    pub kernel: Option<Spanned<String>>,
    pub method: Option<Spanned<String>>,
    pub tolerance: Option<Spanned<Num>>,
    pub steps: Option<Spanned<Int>>,
    pub material: Option<Spanned<String>>,
    pub transform: Option<Spanned<Tables<OpDef>>>,
    pub balls: Option<Spanned<Tables<BallDef>>>,
    pub generate: Option<Spanned<GenerateDef>>,
    #[serde(default)]
    pub keyframe: Tables<MetaballKeyframeDef>,
}

/// One ball: `{ centre = [x, y, z], radius = R, q = 1, velocity = [..], q_rate = 0 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a ball such as { centre = [0, 0, 0], radius = 2 }")]
pub(crate) struct BallDef {
    pub centre: Option<Spanned<Array<Num, 3>>>,
    pub radius: Option<Spanned<Num>>,
    pub q: Option<Spanned<Num>>,
    pub velocity: Option<Spanned<Array<Num, 3>>>,
    pub q_rate: Option<Spanned<Num>>,
}

/// `generate = { count = …, seed = …, bounds = [[min], [max]], radius = [min, max], q = [min, max],
/// speed = … }`.
#[derive(Debug, Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a table { count = n, bounds = [[x0, y0, z0], [x1, y1, z1]], radius = [min, max] }"
)]
pub(crate) struct GenerateDef {
    pub count: Option<Spanned<Int>>,
    pub seed: Option<Spanned<Int>>,
    pub bounds: Option<Spanned<Array<Array<Num, 3>, 2>>>,
    pub radius: Option<Spanned<Array<Num, 2>>>,
    pub q: Option<Spanned<Array<Num, 2>>>,
    pub speed: Option<Spanned<Num>>,
}

/// One `[[metaballs.keyframe]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[metaballs.keyframe]] table")]
pub(crate) struct MetaballKeyframeDef {
    pub time: Option<Spanned<Num>>,
    pub centres: Option<Spanned<Vec<Array<Num, 3>>>>,
    pub q: Option<Spanned<Vec<Num>>>,
}

impl TableList for MetaballsDef {
    const LIST: &'static str = "an array of tables, each written [[metaballs]]";
}
impl TableList for BallDef {
    const LIST: &'static str = "an array of balls such as [{ centre = [0, 0, 0], radius = 2 }]";
}
impl TableList for MetaballKeyframeDef {
    const LIST: &'static str = "an array of tables, each written [[metaballs.keyframe]]";
}

pub(crate) fn metaballs(
    ctx: Ctx,
    defs: &Tables<MetaballsDef>,
    materials: &mut Materials,
) -> Result<Vec<MetaballGroup>, SceneError> {
    let mut out = Vec::with_capacity(defs.0.len());
    for (i, def) in defs.0.iter().enumerate() {
        let d = def.get_ref();
        let label = match &d.name {
            Some(name) => format!("metaballs \"{}\"", name.get_ref()),
            None => format!("metaballs {}", i + 1),
        };
        out.push(group(&Owner::new(ctx, label, def.span()), d, materials)?);
    }
    Ok(out)
}

fn group(o: &Owner, d: &MetaballsDef, materials: &mut Materials) -> Result<MetaballGroup, SceneError> {
    let threshold = o.num("threshold", d.threshold.as_ref(), DEFAULT_THRESHOLD, F32_NORMAL)?;
    let kernel = match &d.kernel {
        None => Kernel::default(),
        Some(k) => Kernel::from_name(k.get_ref()).ok_or_else(|| {
            o.fail(k.span(), "kernel", &one_of(&Kernel::NAMES), format!("\"{}\"", k.get_ref()))
        })?,
    };
    let material = match &d.material {
        Some(m) => material_index(o, m, materials)?,
        None => materials.default_index(),
    };
    let (ops, transform) = transform(o, d.transform.as_ref())?;
    let mut balls = Vec::new();
    if let Some(list) = &d.balls {
        for (i, def) in list.get_ref().0.iter().enumerate() {
            let b = Owner::new(o.ctx, format!("{} ball {}", o.label, i + 1), def.span());
            balls.push(ball(&b, def.get_ref())?);
        }
    }
    if let Some(g) = &d.generate {
        let go = Owner::new(o.ctx, format!("{} `generate`", o.label), g.span());
        balls.extend(generate(&go, g.get_ref())?);
    }
    if balls.is_empty() {
        let expected = "at least one ball: a `balls` list such as [{ centre = [0, 0, 0], radius = 2 }] or a \
                        `generate` table";
        return Err(match &d.balls {
            Some(list) => o.fail(list.span(), "balls", expected, "an empty list"),
            None => o.fail_here(format!("missing `balls` (expected {expected})")),
        });
    }
    let keyframes = keyframes(o, &d.keyframe, balls.len())?;
    let method = method(o, d)?;
    Ok(MetaballGroup {
        name: d.name.as_ref().map(|n| n.get_ref().clone()),
        threshold,
        kernel,
        material,
        ops,
        transform,
        balls,
        keyframes,
        method,
        device: None,
    })
}

/// `method` ("bezier", the default, with an optional `tolerance` > 0 in world units; or
/// "sphere_trace" with `steps`), refusing the other method's field.
fn method(o: &Owner, d: &MetaballsDef) -> Result<CastMethod, SceneError> {
    let names = &CastMethod::NAMES;
    let name = match &d.method {
        None => names[0],
        Some(m) => match names.iter().find(|k| **k == m.get_ref()) {
            Some(k) => k,
            None => return Err(o.fail(m.span(), "method", &one_of(names), format!("\"{}\"", m.get_ref()))),
        },
    };
    let (method, other) = if name == "sphere_trace" {
        let steps =
            o.count("steps", d.steps.as_ref(), CastMethod::DEFAULT_STEPS, 1, CastMethod::MAX_STEPS)?;
        (CastMethod::SphereTrace { steps }, ("tolerance", d.tolerance.as_ref().map(Spanned::span), "bezier"))
    } else {
        let tolerance = match &d.tolerance {
            None => 0.0,
            Some(t) => o.check_num("tolerance", t, F32_NORMAL)?,
        };
        (CastMethod::Bezier { tolerance }, ("steps", d.steps.as_ref().map(Spanned::span), "sphere_trace"))
    };
    if let (field, Some(span), owner) = other {
        let default = if d.method.is_none() { ", the default" } else { "" };
        let message = format!(
            "{}: `{field}` is a field of method = \"{owner}\" only (expected no `{field}` when the method is \"{name}\"{default})",
            o.label
        );
        return Err(o.ctx.err(o.ctx.key_start(&span)..span.end, message));
    }
    Ok(method)
}

fn ball(b: &Owner, d: &BallDef) -> Result<AnimatedBall, SceneError> {
    let centre =
        b.check_vec3("centre", b.required("centre", d.centre.as_ref(), "an array of 3 numbers")?, ANY)?;
    let radius_def = b.required("radius", d.radius.as_ref(), "a number > 0")?;
    let radius = b.check_num("radius", radius_def, SQUARED_LENGTH)?;
    Ok(AnimatedBall {
        centre,
        radius,
        q: b.num("q", d.q.as_ref(), 1.0, ANY)?,
        velocity: b.vec3("velocity", d.velocity.as_ref(), DVec3::ZERO, ANY)?,
        q_rate: b.num("q_rate", d.q_rate.as_ref(), 0.0, ANY)?,
    })
}

/// The balls of `generate`, deterministic for a given seed (module `Splitmix`).
fn generate(o: &Owner, d: &GenerateDef) -> Result<Vec<AnimatedBall>, SceneError> {
    let count = o.required("count", d.count.as_ref(), &format!("an integer in 1..={MAX_GENERATED}"))?;
    let count = o.count("count", Some(count), 1, 1, MAX_GENERATED)?;
    let seed = d.seed.as_ref().map_or(0, |s| s.get_ref().0 as u64);
    let bounds_def = o.required("bounds", d.bounds.as_ref(), "[[x0, y0, z0], [x1, y1, z1]]")?;
    let [lo, hi] = bounds_def.get_ref().0.map(|v| v.vec3());
    if !(lo.cmple(hi).all()) {
        let expected = "[[x0, y0, z0], [x1, y1, z1]] with each min <= max";
        return Err(o.fail(
            bounds_def.span(),
            "bounds",
            expected,
            format!("{} and {}", show_vec(lo), show_vec(hi)),
        ));
    }
    let radius_def = o.required("radius", d.radius.as_ref(), "[min, max] with 0 < min <= max")?;
    let [r0, r1] = radius_def.get_ref().values();
    if !(r0 <= r1 && (SQUARED_LENGTH.ok)(r0) && (SQUARED_LENGTH.ok)(r1)) {
        let found = format!("[{}, {}]", show(r0), show(r1));
        let expected = if r0 > 0.0 && r0 <= r1 {
            format!("[min, max] with each {}", SQUARED_LENGTH.bound)
        } else {
            "[min, max] with 0 < min <= max".to_owned()
        };
        return Err(o.fail(radius_def.span(), "radius", &expected, found));
    }
    let (q0, q1) = match &d.q {
        None => (1.0, 1.0),
        Some(q) => {
            let [q0, q1] = q.get_ref().values();
            if q0 > q1 {
                let found = format!("[{}, {}]", show(q0), show(q1));
                return Err(o.fail(q.span(), "q", "[min, max] with min <= max", found));
            }
            (q0, q1)
        }
    };
    let speed = o.num("speed", d.speed.as_ref(), 0.0, crate::scene::file_check::NON_NEGATIVE)?;
    let mut rng = Splitmix(seed);
    Ok((0..count)
        .map(|_| {
            let centre = DVec3::new(rng.range(lo.x, hi.x), rng.range(lo.y, hi.y), rng.range(lo.z, hi.z));
            let radius = rng.range(r0, r1);
            let q = rng.range(q0, q1);
            // A uniform direction (z uniform in [-1, 1], angle uniform) times a speed in [0, speed].
            let z = rng.range(-1.0, 1.0);
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let s = (1.0 - z * z).max(0.0).sqrt();
            let velocity = DVec3::new(s * phi.cos(), s * phi.sin(), z) * rng.range(0.0, speed);
            AnimatedBall { centre, radius, q, velocity, q_rate: 0.0 }
        })
        .collect())
}

/// splitmix64 (Steele, Lea, Flood 2014): the generator's documented random sequence.
struct Splitmix(u64);

impl Splitmix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

fn keyframes(
    o: &Owner,
    defs: &Tables<MetaballKeyframeDef>,
    n: usize,
) -> Result<Vec<MetaballKeyframe>, SceneError> {
    let mut out: Vec<MetaballKeyframe> = Vec::with_capacity(defs.0.len());
    for (i, def) in defs.0.iter().enumerate() {
        let k = Owner::new(o.ctx, format!("{} keyframe {}", o.label, i + 1), def.span());
        let d = def.get_ref();
        let time = k.keyframe_time(d.time.as_ref(), out.last().map(|p| p.time))?;
        let per_ball = |field: &str, len: usize, span: std::ops::Range<usize>| {
            if len == n {
                Ok(())
            } else {
                let expected = format!("{n} entries (one per ball of the group)");
                Err(k.fail(span, field, &expected, format!("{len}")))
            }
        };
        let centres = match &d.centres {
            None => None,
            Some(c) => {
                per_ball("centres", c.get_ref().len(), c.span())?;
                Some(c.get_ref().iter().map(|v| v.vec3()).collect())
            }
        };
        let q = match &d.q {
            None => None,
            Some(q) => {
                per_ball("q", q.get_ref().len(), q.span())?;
                Some(q.get_ref().iter().map(|v| v.0).collect())
            }
        };
        out.push(MetaballKeyframe { time, centres, q });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::scene::parse_scene;

    const HEAD: &str = "[camera]\nposition = [0, 0, 10]\nlook_at = [0, 0, 0]\n";

    #[test]
    fn methods_and_their_defaults() {
        use crate::effects::metaballs::CastMethod;
        let method = |fields: &str| {
            let text =
                format!("{HEAD}[[metaballs]]\n{fields}\nballs = [{{ centre = [0, 0, 0], radius = 2 }}]\n");
            parse_scene(&text, Path::new("m.toml")).unwrap().metaballs()[0].method
        };
        assert_eq!(method(""), CastMethod::Bezier { tolerance: 0.0 });
        assert_eq!(method("tolerance = 0.25"), CastMethod::Bezier { tolerance: 0.25 });
        assert_eq!(method("method = \"bezier\""), CastMethod::Bezier { tolerance: 0.0 });
        assert_eq!(method("method = \"sphere_trace\""), CastMethod::SphereTrace { steps: 64 });
        assert_eq!(method("method = \"sphere_trace\"\nsteps = 7"), CastMethod::SphereTrace { steps: 7 });
    }

    #[test]
    fn defaults_and_generator() {
        let text = format!(
            "{HEAD}[[metaballs]]\nballs = [{{ centre = [0, 0, 0], radius = 2 }}]\n\
             generate = {{ count = 100, seed = 7, bounds = [[-1, -2, -3], [1, 2, 3]], radius = [0.5, 1], speed = 2 }}\n"
        );
        let scene = parse_scene(&text, Path::new("m.toml")).unwrap();
        let g = &scene.metaballs()[0];
        assert_eq!(g.threshold, 0.5);
        assert_eq!(g.balls.len(), 101);
        assert_eq!(scene.materials[g.material].name, "default");
        for b in &g.balls[1..] {
            assert!(b.centre.abs().cmple(glam::DVec3::new(1.0, 2.0, 3.0)).all());
            assert!((0.5..=1.0).contains(&b.radius) && b.q == 1.0 && b.velocity.length() <= 2.0);
        }
        // Deterministic: the same seed gives the same balls.
        let again = parse_scene(&text, Path::new("m.toml")).unwrap();
        assert_eq!(again.metaballs()[0].balls, g.balls);
    }

    #[test]
    fn keyframe_rules() {
        let bad = |body: &str| {
            let text = format!("{HEAD}[[metaballs]]\nballs = [{{ centre = [0, 0, 0], radius = 2 }}]\n{body}");
            parse_scene(&text, Path::new("m.toml")).unwrap_err().to_string()
        };
        let e = bad("[[metaballs.keyframe]]\ntime = 0\ncentres = [[0, 0, 0], [1, 0, 0]]\n");
        assert!(e.contains("m.toml:8:11: metaballs 1 keyframe 1 `centres`: expected 1 entries"), "{e}");
        let e = bad("[[metaballs.keyframe]]\ntime = 1\n[[metaballs.keyframe]]\ntime = 1\n");
        assert!(e.contains("keyframe 2 `time`: expected a time > 1"), "{e}");
        let e = bad("generate = { count = 0, bounds = [[0, 0, 0], [1, 1, 1]], radius = [1, 1] }\n");
        assert!(e.contains("`generate` `count`: expected an integer in 1..=65536, found 0"), "{e}");
        let e = bad("generate = { count = 3, bounds = [[0, 0, 0], [1, 1, 1]], radius = [2, 1] }\n");
        assert!(e.contains("`radius`: expected [min, max] with 0 < min <= max, found [2, 1]"), "{e}");
    }
}
