//! `[[wave]]` tables → `Wave`: ranges and defaults of each field, the integration method and the
//! fields only it takes, and the `[[wave.keyframe]]` rules (times strictly increasing, consecutive
//! directions not opposite). Every refusal points at the value (or key) at fault.

use std::ops::Range;

use glam::DVec3;
use toml::Spanned;

use crate::scene::error::SceneError;
use crate::scene::file_check::{
    one_of, show, show_vec, show_vec_approx, Ctx, Owner, Rule, ANY, NON_NEGATIVE, POSITIVE,
};
use crate::scene::file_schema::{Array, KeyframeDef, Num, Tables, WaveDef};
use crate::scene::model::{Wave, WaveKeyframe, WaveMethod};

/// The integration methods, as `method` spells them; the first is the default.
const METHODS: &[&str] = &["analytic", "raymarch"];
/// A wave's tolerance: a relative error, 0 (exact) up to but not including 1.
const TOLERANCE: Rule =
    Rule { ok: |v| (0.0..1.0).contains(&v), bound: "in [0, 1) (a relative error; 0: exact)" };
/// Raymarch samples per ray: default and most.
pub const DEFAULT_STEPS: u32 = 64;
pub const MAX_STEPS: u32 = 65536;
/// Two consecutive keyframe directions whose dot product is at most this are refused: their
/// normalized lerp would pass (nearly) through the zero vector.
pub const MIN_DIRECTION_DOT: f64 = -0.99;

pub(crate) fn waves(ctx: Ctx, defs: &Tables<WaveDef>) -> Result<Vec<Wave>, SceneError> {
    let wave_at = |(i, def): (usize, &Spanned<WaveDef>)| {
        let d = def.get_ref();
        let label = match &d.name {
            Some(name) => format!("wave \"{}\"", name.get_ref()),
            None => format!("wave {}", i + 1),
        };
        wave(&Owner::new(ctx, label, def.span()), d)
    };
    defs.0.iter().enumerate().map(wave_at).collect()
}

fn wave(o: &Owner, d: &WaveDef) -> Result<Wave, SceneError> {
    let origin_def = o.required("origin", d.origin.as_ref(), "an array of 3 numbers")?;
    let origin = o.check_vec3("origin", origin_def, ANY)?;
    let velocity = o.vec3("velocity", d.velocity.as_ref(), DVec3::ZERO, ANY)?;
    let direction_def = o.required("direction", d.direction.as_ref(), "a non-zero array of 3 numbers")?;
    let direction = unit(o, "direction", direction_def)?;
    let a = o.num("a", d.a.as_ref(), 0.0, NON_NEGATIVE)?;
    let b = o.num("b", d.b.as_ref(), 0.0, NON_NEGATIVE)?;
    let core = o.num("core", d.core.as_ref(), 0.0, NON_NEGATIVE)?;
    let length = o.num("length", d.length.as_ref(), f64::INFINITY, POSITIVE)?;
    let color = o.vec3("color", d.color.as_ref(), DVec3::ONE, NON_NEGATIVE)?;
    let intensity = o.num("intensity", d.intensity.as_ref(), 1.0, NON_NEGATIVE)?;
    let cutoff = o.num("cutoff", d.cutoff.as_ref(), 0.0, NON_NEGATIVE)?;
    let method = method(o, d)?;
    let tolerance = d.tolerance.as_ref().map(|t| o.check_num("tolerance", t, TOLERANCE)).transpose()?;
    let keyframes = keyframes(o, &d.keyframe)?;
    check_strength(o, d, a, b, &keyframes)?;
    check_emission(o, d, color, intensity, &keyframes)?;
    Ok(Wave {
        name: d.name.as_ref().map(|n| n.get_ref().clone()),
        origin,
        velocity,
        direction,
        a,
        b,
        core,
        length,
        color,
        intensity,
        cutoff,
        method,
        tolerance,
        keyframes,
    })
}

/// A direction, normalized; refused when zero. Scaling by the largest component first keeps
/// huge (|v|² overflows) and tiny (subnormal) vectors normalizable.
fn unit(o: &Owner, field: &str, v: &Spanned<Array<Num, 3>>) -> Result<DVec3, SceneError> {
    let vec = o.check_vec3(field, v, ANY)?;
    let largest = vec.abs().max_element();
    match (vec / largest).try_normalize() {
        Some(u) if largest > 0.0 => Ok(u),
        _ => Err(o.fail(v.span(), field, "a non-zero vector", show_vec(vec))),
    }
}

fn method(o: &Owner, d: &WaveDef) -> Result<WaveMethod, SceneError> {
    let name = match &d.method {
        None => METHODS[0],
        Some(m) => match METHODS.iter().find(|k| **k == m.get_ref()) {
            Some(k) => k,
            None => return Err(o.fail(m.span(), "method", &one_of(METHODS), format!("\"{}\"", m.get_ref()))),
        },
    };
    if name == "raymarch" {
        if let Some(t) = &d.tolerance {
            let span = t.span();
            let message = format!(
                "{}: `tolerance` is a field of method = \"analytic\" only (the ray march is evaluated at every pixel)",
                o.label
            );
            return Err(o.ctx.err(o.ctx.key_start(&span)..span.end, message));
        }
        let steps = o.count("steps", d.steps.as_ref(), DEFAULT_STEPS, 1, MAX_STEPS)?;
        let jitter = d.jitter.as_ref().is_some_and(|j| *j.get_ref());
        return Ok(WaveMethod::Raymarch { steps, jitter });
    }
    let raymarch_only =
        [("steps", d.steps.as_ref().map(Spanned::span)), ("jitter", d.jitter.as_ref().map(Spanned::span))];
    if let Some((field, span)) = raymarch_only.into_iter().find_map(|(f, s)| s.map(|s| (f, s))) {
        let default = if d.method.is_none() { ", the default" } else { "" };
        let message = format!(
            "{}: `{field}` is a field of method = \"raymarch\" only (expected no `{field}` when the method is \"{name}\"{default})",
            o.label
        );
        return Err(o.ctx.err(o.ctx.key_start(&span)..span.end, message));
    }
    Ok(WaveMethod::Analytic)
}

fn keyframes(o: &Owner, defs: &Tables<KeyframeDef>) -> Result<Vec<WaveKeyframe>, SceneError> {
    let mut out: Vec<WaveKeyframe> = Vec::with_capacity(defs.0.len());
    // The last keyframe that set `direction`: its number (1-based) and unit direction.
    let mut last_direction: Option<(usize, DVec3)> = None;
    for (i, def) in defs.0.iter().enumerate() {
        let k = Owner::new(o.ctx, format!("{} keyframe {}", o.label, i + 1), def.span());
        let d = def.get_ref();
        let time = k.keyframe_time(d.time.as_ref(), out.last().map(|p| p.time))?;
        let direction = match &d.direction {
            Some(v) => Some(keyframe_direction(&k, v, last_direction)?),
            None => None,
        };
        if let Some(u) = direction {
            last_direction = Some((i + 1, u));
        }
        let num = |field, v: Option<&Spanned<Num>>, rule| v.map(|v| k.check_num(field, v, rule)).transpose();
        out.push(WaveKeyframe {
            time,
            origin: d.origin.as_ref().map(|v| k.check_vec3("origin", v, ANY)).transpose()?,
            direction,
            a: num("a", d.a.as_ref(), NON_NEGATIVE)?,
            b: num("b", d.b.as_ref(), NON_NEGATIVE)?,
            core: num("core", d.core.as_ref(), NON_NEGATIVE)?,
            length: num("length", d.length.as_ref(), POSITIVE)?,
            intensity: num("intensity", d.intensity.as_ref(), NON_NEGATIVE)?,
        });
    }
    Ok(out)
}

/// A keyframe's unit direction, refused when (nearly) opposite to the previous keyframe direction.
fn keyframe_direction(
    k: &Owner,
    v: &Spanned<Array<Num, 3>>,
    previous: Option<(usize, DVec3)>,
) -> Result<DVec3, SceneError> {
    let u = unit(k, "direction", v)?;
    if let Some((number, p)) = previous {
        let dot = u.dot(p);
        if dot <= MIN_DIRECTION_DOT {
            let expected = format!(
                "a direction not opposite to keyframe {number}'s {} (dot product > {MIN_DIRECTION_DOT}; the \
                 normalized lerp between them would pass through zero)",
                show_vec_approx(p)
            );
            let found = format!("{} (dot product {})", show_vec(v.get_ref().vec3()), show_approx(dot));
            return Err(k.fail(v.span(), "direction", &expected, found));
        }
    }
    Ok(u)
}

/// The pass adds emission × H with emission = colour × intensity uploaded as f32: every
/// intensity in effect (the table's, each keyframe's) times the colour must stay finite in f32.
fn check_emission(
    o: &Owner,
    d: &WaveDef,
    color: DVec3,
    intensity: f64,
    keyframes: &[WaveKeyframe],
) -> Result<(), SceneError> {
    let keyed = keyframes.iter().zip(&d.keyframe.0).filter_map(|(k, def)| {
        let span = def.get_ref().intensity.as_ref().map(Spanned::span)?;
        Some((k.intensity?, span))
    });
    let table = d.intensity.as_ref().map(|v| (intensity, v.span()));
    for (value, span) in table.into_iter().chain(keyed) {
        if color.max_element() * value > f32::MAX as f64 {
            let expected = "colour × intensity <= 3.4028235e38 per channel (the emission is an f32)";
            return Err(o.fail(
                span,
                "intensity",
                expected,
                format!("{} × {}", show_vec(color), show(value)),
            ));
        }
    }
    Ok(())
}

fn show_approx(x: f64) -> String {
    let s = format!("{x:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// A wave must have some strength: a + b > 0 at some time. With keyframes that is: some value of
/// `a` or `b` in effect (the keyframes' values of a field they set, else the table's) is > 0.
fn check_strength(
    o: &Owner,
    d: &WaveDef,
    a: f64,
    b: f64,
    keyframes: &[WaveKeyframe],
) -> Result<(), SceneError> {
    let values = |base: f64, get: fn(&WaveKeyframe) -> Option<f64>| -> Vec<f64> {
        let keyed: Vec<f64> = keyframes.iter().filter_map(get).collect();
        if keyed.is_empty() {
            vec![base]
        } else {
            keyed
        }
    };
    let any_positive = values(a, |k| k.a).into_iter().chain(values(b, |k| k.b)).any(|v| v > 0.0);
    if any_positive {
        return Ok(());
    }
    let keyed = keyframes.iter().any(|k| k.a.is_some() || k.b.is_some());
    let at_every = if keyed { " at every keyframe" } else { "" };
    // Point at the first `a` or `b` written: the table's, else a keyframe's.
    let written: Option<(&str, Range<usize>)> =
        d.a.as_ref().map(|v| ("a", v.span())).or_else(|| d.b.as_ref().map(|v| ("b", v.span()))).or_else(
            || {
                d.keyframe.0.iter().find_map(|k| {
                    let k = k.get_ref();
                    k.a.as_ref().map(|v| ("a", v.span())).or_else(|| k.b.as_ref().map(|v| ("b", v.span())))
                })
            },
        );
    match written {
        Some((field, span)) => Err(o.fail(
            span,
            field,
            "a + b > 0 (a sphere strength `a` or a line strength `b` above 0; with both 0 the wave is empty)",
            format!("a = 0 and b = 0{at_every}"),
        )),
        None => Err(o.fail_here(
            "missing `a` and `b` (expected a sphere strength `a` or a line strength `b` > 0; both default to 0)",
        )),
    }
}
